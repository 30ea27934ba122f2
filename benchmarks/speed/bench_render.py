"""Silhouette rendering speed: the CPU rasteriser against pyrender, on one core.

Renders the same posed avatar frames through the same camera (128×128 by default)
with :func:`eigmotion.imaging.silhouettes.render_masks` (full mesh and a decimated copy) and
with :func:`eigmotion.imaging.render.render_masks_gl` (pyrender, EGL), and prints one table:
masks per second, the speed ratio against the GL render of the full mesh, and the
IoU of every mask against that GL render.  Then, if :mod:`eigmotion.retrieval.motion_image`
is there, motion images per second from the CPU masks.

Poses are the first ``--frames`` frames of a CMU clip retargeted onto the default
avatar (``--clip``, default the walk 16_15), or with ``--random`` random joint
rotations (uniform ±``--max-angle-deg`` on every Euler channel of the canonical
skeleton, a random root shift); the camera is one view of the default rig, fitted to
all frames.  Skinning speed is printed too: the build pays it once per frame, the
rendering once per frame and view.

    python benchmarks/speed/bench_render.py [--frames 300] [--faces 4000] [--view 30 10]
"""

from __future__ import annotations

import os

for _var in (
    "OMP_NUM_THREADS",
    "OPENBLAS_NUM_THREADS",
    "MKL_NUM_THREADS",
    "NUMEXPR_NUM_THREADS",
    "NUMBA_NUM_THREADS",
    "LP_NUM_THREADS",  # Mesa llvmpipe's rasteriser threads
):
    os.environ[_var] = "1"  # one core, set before numpy and numba are imported
os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

import argparse  # noqa: E402
import importlib  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from eigmotion.body.avatar import load_default_avatar  # noqa: E402
from eigmotion.imaging.cameras import virtual_rig  # noqa: E402
from eigmotion.imaging.silhouettes import render_masks  # noqa: E402
from eigmotion.mocap.canonical import canonical_skeleton  # noqa: E402
from eigmotion.mocap.kinematics import forward_kinematics  # noqa: E402
from eigmotion.mocap.motion import Motion  # noqa: E402


def random_pose_transforms(n_frames: int, max_angle_deg: float, seed: int):
    """Joint world rotations (F, J, 3, 3) and positions (F, J, 3) of random poses."""
    rng = np.random.default_rng(seed)
    skeleton = canonical_skeleton()
    values = rng.uniform(-max_angle_deg, max_angle_deg, (n_frames, skeleton.n_channels))
    values[:, :3] = rng.uniform(-0.3, 0.3, (n_frames, 3)) * [1, 0, 1]
    pose = forward_kinematics(Motion(skeleton, values, 1 / 30, 1.0, "random"), ground=False)
    return pose.rotations, pose.positions


def cmu_pose_transforms(clip: str, n_frames: int, avatar):
    """Joint world rotations (F, J, 3, 3) and positions (F, J, 3) of a CMU clip."""
    from eigmotion.body.retarget import retarget
    from eigmotion.mocap.amc import read_amc

    cmu = Path(__file__).resolve().parents[2] / "database" / "motions" / "cmu"
    motion = read_amc(cmu / "amc" / f"{clip}.amc", cmu / "asf" / f"{clip.split('_')[0]}.asf")
    animation = retarget(motion.trim(0, min(n_frames, motion.n_frames)), avatar)
    return animation.joint_rotations, animation.joint_positions


def per_second(work, n_items: int, repeats: int):
    """Best of ``repeats`` timed runs of ``work()`` that makes ``n_items`` things →
    (items per second, what the last run returned)."""
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        result = work()
        best = min(best, time.perf_counter() - start)
    return n_items / best, result


def iou(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(F,) intersection over union of two (F, H, W) bool stacks."""
    inter = (a & b).sum(axis=(1, 2))
    union = np.maximum((a | b).sum(axis=(1, 2)), 1)
    return inter / union


def main() -> int:
    parser = argparse.ArgumentParser(description="CPU vs GL silhouette rendering speed")
    parser.add_argument("--frames", type=int, default=300, help="poses rendered")
    parser.add_argument("--faces", type=int, default=4000, help="decimated avatar faces")
    parser.add_argument("--size", type=int, default=128, help="image width = height, px")
    parser.add_argument(
        "--view",
        type=float,
        nargs=2,
        default=(30.0, 10.0),
        metavar=("AZ_DEG", "EL_DEG"),
        help="camera azimuth and elevation",
    )
    parser.add_argument("--clip", default="16_15", help="CMU clip (subject_trial)")
    parser.add_argument("--random", action="store_true", help="random poses, not a clip")
    parser.add_argument("--max-angle-deg", type=float, default=35.0)
    parser.add_argument("--repeats", type=int, default=3, help="best of N timed runs")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()

    avatar = load_default_avatar()
    low = avatar.decimated(args.faces)
    if args.random:
        rotations, positions = random_pose_transforms(args.frames, args.max_angle_deg, args.seed)
        poses = f"{args.frames} random poses (±{args.max_angle_deg:g}° per channel)"
        clip_fps = 30.0
    else:
        rotations, positions = cmu_pose_transforms(args.clip, args.frames, avatar)
        poses = f"{len(rotations)} frames of CMU {args.clip}"
        clip_fps = 120.0  # the CMU capture rate
    n_frames = len(rotations)
    skin_rates = {}
    for mesh in (avatar, low):
        rate, verts = per_second(
            lambda m=mesh: m.skin(rotations, positions), n_frames, args.repeats
        )
        skin_rates[mesh.n_faces] = (rate, verts)
    full_v, low_v = skin_rates[avatar.n_faces][1], skin_rates[low.n_faces][1]
    camera = virtual_rig([args.view[0]], [args.view[1]], width=args.size, height=args.size).fitted(
        full_v.reshape(-1, 3)
    )[0]

    print(f"{poses}, camera {camera.name} fitted to them, {camera.width}×{camera.height}, one core")
    rows = []
    render_masks(full_v[:1], avatar.faces, camera)  # compile (cached on disk after once)
    for label, verts, mesh in (("cpu", full_v, avatar), ("cpu", low_v, low)):
        rate, masks = per_second(
            lambda v=verts, m=mesh: render_masks(v, m.faces, camera), n_frames, args.repeats
        )
        rows.append((label, mesh, rate, masks))
    gl_masks = None
    try:
        from eigmotion.imaging.render import default_renderer, render_masks_gl
    except ImportError as exc:
        print(f"(no GL row: {exc})")
    else:
        default_renderer()
        render_masks_gl(full_v[:1], avatar.faces, camera)  # context, shaders, buffers
        for verts, mesh in ((full_v, avatar), (low_v, low)):
            rate, masks = per_second(
                lambda v=verts, m=mesh: render_masks_gl(v, m.faces, camera), n_frames, 1
            )
            rows.append(("pyrender", mesh, rate, masks))
            if mesh is avatar:
                gl_masks, gl_rate = masks, rate

    for faces, (rate, _) in skin_rates.items():
        print(f"skinning (Avatar.skin), {faces} faces: {rate:.0f} frames/s")
    header = f"{'renderer':<10} {'faces':>6} {'vertices':>8} {'masks/s':>9}"
    if gl_masks is not None:
        header += f" {'× GL full':>9} {'IoU vs GL full: mean':>21} {'min':>6}"
    print(header)
    for label, mesh, rate, masks in rows:
        line = f"{label:<10} {mesh.n_faces:>6} {mesh.n_vertices:>8} {rate:>9.0f}"
        if gl_masks is not None:
            overlap = iou(masks, gl_masks)
            line += f" {rate / gl_rate:>9.1f} {overlap.mean():>21.4f} {overlap.min():>6.4f}"
        print(line)

    try:
        module = importlib.import_module("eigmotion.retrieval.motion_image")
        motion_image = module.motion_image
    except (ImportError, AttributeError):
        print("motion images/s: skipped (retrieval.motion_image.motion_image not available)")
        return 0
    clip = rows[1][3]  # decimated-mesh CPU masks, the whole clip
    config = module.MotionImageConfig()
    rate, _ = per_second(lambda: motion_image(clip, config, clip_fps), 1, args.repeats)
    print(
        f"motion images/s: {rate:.1f} ({n_frames}-frame clip at {clip_fps:g} fps, "
        f"sample_fps {config.sample_fps:g}, size {config.size}, default config)"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
