"""Garments: their size, their cost in the build, and how well they follow the body.

For the plain body and every garment of :data:`eigmotion.body.garments.GARMENTS` (worn
alone) prints one table: faces and vertices the garment adds, the time to fit it,
the faces of the low-poly dressed avatar the build renders, skinning and CPU
silhouette speed of that low-poly avatar on a walk (one core, one 160×120 view), and
over a whole walk and a whole kick (library ``walk_02_01`` and ``kick_135_04``) the
largest stretch of a garment edge (posed / rest length) and the largest growth of a
garment vertex's distance to the skin over its rest distance.  The same stretch with
every garment vertex skinned by its nearest body vertex's weights shows the tear
the garment's own weights avoid.

With ``--figure PATH`` it also writes the contact sheet of ``docs/avatar.md``: the
plain body and each garment in three frames of the walk (widest stride, legs
passing, next stride) and three of the kick (chamber, highest, recoil), shaded.

    python benchmarks/speed/bench_garments.py [--figure docs/images/garments.png]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ[_var] = "1"  # one core, set before numpy and numba are imported
os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

import argparse  # noqa: E402

import numpy as np  # noqa: E402
from scipy.spatial import cKDTree  # noqa: E402

from eigmotion.body.avatar import Avatar, load_default_avatar  # noqa: E402
from eigmotion.body.garments import (  # noqa: E402
    GARMENTS,
    DressedAvatar,
    dress,  # noqa: E402
    garment_mesh,
)
from eigmotion.body.retarget import animate_avatar  # noqa: E402
from eigmotion.evaluation.timing import best_time  # noqa: E402
from eigmotion.imaging.cameras import virtual_rig  # noqa: E402
from eigmotion.imaging.silhouettes import render_masks  # noqa: E402
from eigmotion.mocap.library import find_motion  # noqa: E402
from eigmotion.retrieval.library_views import hull_points  # noqa: E402

MOTIONS = ("walk_02_01", "kick_135_04")


def edges(faces: np.ndarray) -> np.ndarray:
    return np.unique(np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]]]), 1), axis=0)


def follow_measures(body: Avatar, name: str, animations: dict) -> tuple[float, float, float]:
    """Largest edge stretch (own weights, nearest-vertex weights) and distance growth, m."""
    mesh = garment_mesh(body, name)
    rest_gap, nearest = cKDTree(body.vertices).query(mesh.vertices)
    pairs = edges(mesh.faces)
    rest_len = np.linalg.norm(mesh.vertices[pairs[:, 0]] - mesh.vertices[pairs[:, 1]], axis=1)
    stretch = torn = growth = 0.0
    for anim, skin in animations.values():
        for weights in (mesh.weights, body.weights[nearest]):
            probe = Avatar(
                mesh.vertices,
                mesh.faces,
                body.joint_names,
                body.parents,
                body.joint_positions,
                body.bone_tails,
                weights,
                name,
            )
            posed = probe.skin(anim.joint_rotations, anim.joint_positions)
            length = np.linalg.norm(posed[:, pairs[:, 0]] - posed[:, pairs[:, 1]], axis=2)
            ratio = float((length / rest_len).max())
            if weights is mesh.weights:
                stretch = max(stretch, ratio)
                for f in range(len(posed)):
                    gap, _ = cKDTree(skin[f]).query(posed[f])
                    growth = max(growth, float((gap - rest_gap).max()))
            else:
                torn = max(torn, ratio)
    return stretch, torn, growth


def key_frames(body: Avatar, anim, kind: str) -> np.ndarray:
    """Three telling frames of a walk (by stride) or a kick (by foot height)."""
    p = anim.joint_positions
    left, right = body.joint_index("LeftFoot"), body.joint_index("RightFoot")
    if kind == "walk":
        spread = np.linalg.norm(p[:, left] - p[:, right], axis=1)
        wide = int(np.argmax(spread))
        half = int(round(0.5 / anim.frame_time_s))  # the next stride is ~0.5 s away
        passing = wide + int(np.argmin(spread[wide : wide + half]))
        return np.array([wide, passing, min(2 * passing - wide, len(p) - 1)])
    top = int(np.argmax(np.maximum(p[:, left, 1], p[:, right, 1])))
    quarter = int(round(0.2 / anim.frame_time_s))
    return np.array([max(top - quarter, 0), top, min(top + quarter, len(p) - 1)])


def figure(body: Avatar, path: str) -> None:
    from eigmotion.imaging.figures import contact_sheet, save_image
    from eigmotion.imaging.framing import frame_cameras
    from eigmotion.imaging.render import BODY_RGB, Renderer

    images, labels = [], []
    with Renderer() as renderer:
        for outfit in [None, *GARMENTS]:
            dressed = body if outfit is None else dress(body, [outfit])
            colours = dressed.vertex_rgb(BODY_RGB) if isinstance(dressed, DressedAvatar) else None
            title = "body" if outfit is None else outfit
            for motion_name in MOTIONS:
                anim, _ = animate_avatar(dressed, find_motion(motion_name))
                frames = key_frames(body, anim, motion_name.split("_")[0])
                posed = dressed.skin(anim.joint_rotations[frames], anim.joint_positions[frames])
                for f, vertices in zip(frames, posed, strict=True):
                    camera = frame_cameras(vertices[None], np.zeros(1), 35, 10, 150, 200, "fixed")
                    images.append(
                        renderer.render_shaded(
                            vertices[None], dressed.faces, camera, vertex_rgb=colours
                        )[0]
                    )
                    labels.append(f"{title} {f * anim.frame_time_s:.2f} s")
    title = "plain body and garments: walk 02_01 (3 frames), kick 135_04 (3 frames)"
    save_image(contact_sheet(images, 6, labels, title), path)
    print(f"wrote {path}")


def main() -> int:
    parser = argparse.ArgumentParser(description="garment size, cost and fit")
    parser.add_argument("--faces", type=int, default=4000, help="decimated body faces")
    parser.add_argument("--figure", help="also write the contact sheet to this PNG")
    args = parser.parse_args()

    body = load_default_avatar()
    low_body = body.decimated(args.faces)
    animations = {name: animate_avatar(body, find_motion(name)) for name in MOTIONS}
    walk, walk_skin = animations["walk_02_01"]
    rot, pos = walk.joint_rotations, walk.joint_positions
    camera = virtual_rig([30], [10], 160, 120).fitted(hull_points(walk_skin))[0]
    print(f"walk_02_01: {walk.n_frames} frames; one core; silhouettes 160×120, one view")
    print(
        f"{'garment':<16} {'faces':>6} {'verts':>6} {'fit ms':>7} {'low faces':>9} "
        f"{'skin f/s':>9} {'masks f/s':>9} {'stretch':>8} {'nn-stretch':>10} {'gap+ m':>7}"
    )
    for name in [None, *GARMENTS]:
        if name is None:
            low, faces, verts, fit_ms, fit = low_body, 0, 0, 0.0, ("", "", "")
        else:
            fit_s, mesh = best_time(lambda name=name: garment_mesh(body, name))
            low = dress(body, [name]).decimated(args.faces)
            faces, verts, fit_ms = mesh.n_faces, len(mesh.vertices), fit_s * 1e3
            fit = tuple(f"{x:.2f}" for x in follow_measures(body, name, animations))
        low.skin(rot[:2], pos[:2])  # builds the cached sparse matrix
        render_masks(low.skin(rot[:2], pos[:2]), low.faces, camera)  # compiles the kernel
        skin_s, vertices = best_time(lambda low=low: low.skin(rot, pos))
        mask_s, _ = best_time(lambda low=low, v=vertices: render_masks(v, low.faces, camera))
        print(
            f"{name or 'plain body':<16} {faces:>6} {verts:>6} {fit_ms:>7.1f} "
            f"{low.n_faces:>9} {len(rot) / skin_s:>9.0f} {len(rot) / mask_s:>9.0f} "
            f"{fit[0]:>8} {fit[1]:>10} {fit[2]:>7}"
        )
    if args.figure:
        figure(body, args.figure)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
