"""Posing speed: skinning the default avatar on one core, against naive baselines.

Retargets a CMU clip onto the default avatar (time printed separately), then skins
the same frames four ways and prints one table — frames per second, the ratio to
the per-joint baseline, and the largest vertex difference from ``Avatar.skin``:

* ``Avatar.skin``: the per-joint 3×4 transforms of a batch of frames, stacked as a
  (4J, 3F) matrix, times the constant sparse (V, 4J) matrix ``w_vj · (v, 1)``: one
  sparse product blends and applies them (float32);
* ``blend GEMM``: dense ``W (V×J) @ M (J×12F)`` blends the 3×4 matrices per vertex,
  then a batched multiply applies them (float32);
* ``per-joint``: for every frame and joint, transform the whole mesh and accumulate
  it with that joint's weights (the usual numpy loop, float64);
* ``per-vertex``: a Python loop over vertices and their influences (timed on a few
  frames only).

    python benchmarks/speed/bench_posing.py [--clip 16_15] [--frames 480] [--faces 4000]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMEXPR_NUM_THREADS"):
    os.environ[_var] = "1"  # one core, set before numpy is imported

import argparse  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from eigmotion.body.avatar import load_default_avatar, skinning_transforms  # noqa: E402
from eigmotion.body.retarget import retarget  # noqa: E402
from eigmotion.evaluation.timing import best_time  # noqa: E402
from eigmotion.mocap.amc import read_amc  # noqa: E402

CMU = Path(__file__).resolve().parents[2] / "database" / "motions" / "cmu"


def blend_gemm(avatar, rotations, positions, chunk: int = 64) -> np.ndarray:
    """Dense blend of 3×4 matrices (W @ M) then a batched application, float32."""
    w = avatar.weights
    homog = np.concatenate([avatar.vertices, np.ones((avatar.n_vertices, 1), np.float32)], 1)
    t = skinning_transforms(rotations, positions, avatar.joint_positions).astype(np.float32)
    out = np.empty((len(t), avatar.n_vertices, 3), np.float32)
    for start in range(0, len(t), chunk):
        part = t[start : start + chunk]  # (f, J, 3, 4)
        m = part.transpose(1, 0, 2, 3).reshape(avatar.n_joints, -1)  # (J, 12f)
        blended = (w @ m).reshape(avatar.n_vertices, len(part), 3, 4)
        out[start : start + len(part)] = np.einsum("vfrk,vk->fvr", blended, homog)
    return out


def per_joint(avatar, rotations, positions) -> np.ndarray:
    """For each frame and joint, transform every vertex; accumulate weighted."""
    v = avatar.vertices.astype(np.float64)
    w = avatar.weights.astype(np.float64)
    out = np.zeros((len(rotations), avatar.n_vertices, 3))
    for f in range(len(rotations)):
        for j in range(avatar.n_joints):
            moved = (v - avatar.joint_positions[j]) @ rotations[f, j].T + positions[f, j]
            out[f] += w[:, j : j + 1] * moved
    return out


def per_vertex(avatar, rotations, positions) -> np.ndarray:
    """A Python loop over vertices and their non-zero weights."""
    out = np.zeros((len(rotations), avatar.n_vertices, 3))
    influences = [np.flatnonzero(row) for row in avatar.weights]
    for f in range(len(rotations)):
        for i, joints in enumerate(influences):
            p = np.zeros(3)
            for j in joints:
                p += avatar.weights[i, j] * (
                    rotations[f, j] @ (avatar.vertices[i] - avatar.joint_positions[j])
                    + positions[f, j]
                )
            out[f, i] = p
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description="avatar skinning speed on one core")
    parser.add_argument("--clip", default="16_15", help="CMU clip (subject_trial)")
    parser.add_argument("--frames", type=int, default=480, help="frames skinned")
    parser.add_argument("--faces", type=int, default=4000, help="decimated avatar faces")
    parser.add_argument("--baseline-frames", type=int, default=20, help="frames for per-joint")
    parser.add_argument("--naive-frames", type=int, default=1, help="frames for per-vertex")
    parser.add_argument("--repeats", type=int, default=3, help="best of N timed runs")
    args = parser.parse_args()

    start = time.perf_counter()
    avatar = load_default_avatar()
    load_s = time.perf_counter() - start
    low = avatar.decimated(args.faces)
    motion = read_amc(CMU / "amc" / f"{args.clip}.amc", CMU / "asf" / f"{args.clip[:2]}.asf")
    motion = motion.trim(0, min(args.frames, motion.n_frames))
    n = motion.n_frames
    retarget_s, anim = best_time(lambda: retarget(motion, avatar), args.repeats)
    rot, pos = anim.joint_rotations, anim.joint_positions

    print(
        f"default avatar: {avatar.n_vertices} vertices, {avatar.n_faces} faces, "
        f"{avatar.n_joints} joints; loaded in {load_s:.2f} s (cached afterwards)"
    )
    print(f"CMU {args.clip}: {n} frames; one core (OMP/OPENBLAS/MKL_NUM_THREADS=1)")
    print(f"retarget(): {retarget_s * 1e3:.1f} ms = {n / retarget_s:.0f} frames/s")
    avatar.skin(rot[:2], pos[:2])  # builds the cached sparse matrix
    low.skin(rot[:2], pos[:2])
    nb, nn = min(args.baseline_frames, n), min(args.naive_frames, n)
    rows = []
    ours_s, ours = best_time(lambda: avatar.skin(rot, pos), args.repeats)
    rows.append(("Avatar.skin (sparse, float32)", avatar, n, ours_s, ours))
    t, out = best_time(lambda: blend_gemm(avatar, rot, pos), args.repeats)
    rows.append(("blend GEMM W@M + apply (float32)", avatar, n, t, out))
    t, out = best_time(lambda: per_joint(avatar, rot[:nb], pos[:nb]), 1)
    rows.append(("per-joint loop (baseline, float64)", avatar, nb, t, out))
    baseline_fps = nb / t
    t, out = best_time(lambda: per_vertex(avatar, rot[:nn], pos[:nn]), 1)
    rows.append(("per-vertex Python loop (float64)", avatar, nn, t, out))
    t, out = best_time(lambda: low.skin(rot, pos), args.repeats)
    rows.append((f"Avatar.skin, decimated to {low.n_faces} faces", low, n, t, None))

    print(
        f"{'method':<40} {'vertices':>8} {'frames':>6} {'frames/s':>10} "
        f"{'× baseline':>10} {'max |Δ| m':>10}"
    )
    for label, mesh, frames, seconds, verts in rows:
        fps = frames / seconds
        diff = "" if verts is None else f"{np.abs(verts - ours[:frames]).max():.1e}"
        print(
            f"{label:<40} {mesh.n_vertices:>8} {frames:>6} {fps:>10.0f} "
            f"{fps / baseline_fps:>10.1f} {diff:>10}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
