"""Invariance of the motion image to position, size, travel, frame rate and camera,
and its sense of time direction: person frame against image frame.

Cosine distances between the default motion images (``frame="person"``) of two
clips that show the same motion, and the same with ``frame="image"`` (the patent's
crop of the whole clip) as the baseline; the ratio is image-frame distance over
person-frame distance (above 1: the person frame is the more invariant).

* Stick figure (:func:`eigmotion.synth.scene.stick_figure_masks`, 160×120, ``--body-px``
  tall, 45 frames at 30 fps) against the same masks scaled by ``--scale`` and pasted
  30 px down / 90 px right into a 260×200 frame; with recency and uniform weights.
* Walking on the spot against walking across at 60 px/s.
* Arms lifting against lowering (the clip reversed): here a *large* distance is
  wanted with recency weights; uniform weights see the same set of differences.
* 1.5 s of the figure drawn at 30, 60 and 120 fps against 24 fps.
* The avatar walk (CMU 02_01, 1.5 s, low-poly default avatar; ``--no-avatar`` skips
  it): a side camera fitted to the motion (128×128) against one 1.7× further, aimed
  0.4 m off, 160×120; and rendered at 120 fps against 30 fps.

The same cases are asserted in ``tests/test_motion_image.py``.  Run from the
repository root with the venv active (a few seconds)::

    python benchmarks/studies/bench_motion_image_invariance.py [--scale 0.6] [--body-px 80]
        [--no-avatar]
"""

from __future__ import annotations

import argparse

import cv2
import numpy as np

from eigmotion.evaluation.measures import cosine_distance, ratio
from eigmotion.retrieval.motion_image import MotionImageConfig, motion_image
from eigmotion.synth.scene import stick_figure_masks
from eigmotion.synth.walk_scenes import (
    WALK_FRAMES_30FPS,
    low_poly_avatar,
    offset_camera,
    walk_vertices,
)


def shift_and_scale(masks: np.ndarray, scale: float, offset_rc, shape_hw) -> np.ndarray:
    """Every mask resized by ``scale`` and pasted at ``offset_rc`` into a bigger frame."""
    h, w = masks.shape[1:]
    size = (int(round(w * scale)), int(round(h * scale)))
    out = np.zeros((len(masks), *shape_hw), bool)
    r, c = offset_rc
    for i, mask in enumerate(masks):
        small = cv2.resize(mask.astype(np.float32), size, interpolation=cv2.INTER_AREA) >= 0.5
        out[i, r : r + size[1], c : c + size[0]] = small
    return out


def distances(a, b, fps_a: float, fps_b: float, weighting: str = "recency") -> tuple[float, float]:
    """(person frame, image frame) cosine distance between the motion images of two clips."""
    return tuple(
        cosine_distance(
            motion_image(a, MotionImageConfig(frame=frame, weighting=weighting), fps_a),
            motion_image(b, MotionImageConfig(frame=frame, weighting=weighting), fps_b),
        )
        for frame in ("person", "image")
    )


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scale", type=float, default=0.6, help="size of the moved copy (0.6)")
    parser.add_argument("--body-px", type=float, default=80.0, help="stick figure height (80)")
    parser.add_argument("--no-avatar", action="store_true", help="skip the avatar rows")
    args = parser.parse_args(argv)

    def walk(n_frames=45, fps=30.0, **kwargs):
        return stick_figure_masks(
            n_frames, 120, 160, fps=fps, body_height_px=args.body_px, **kwargs
        )

    masks = walk()
    moved = shift_and_scale(masks, args.scale, (30, 90), (200, 260))
    arms = dict(walk_speed_px_s=0.0, arm_swing_deg=0.0, leg_swing_deg=0.0, raise_arms_deg=80.0)
    rows = [
        (f"shift 30 px + scale x{args.scale:g}, recency", distances(masks, moved, 30, 30)),
        (
            f"shift 30 px + scale x{args.scale:g}, uniform",
            distances(masks, moved, 30, 30, "uniform"),
        ),
        (
            "walking on the spot vs across at 60 px/s",
            distances(
                walk(start_x_px=80.0, walk_speed_px_s=0.0),
                walk(start_x_px=30.0, walk_speed_px_s=60.0),
                30,
                30,
            ),
        ),
        (
            "arms lifting vs lowering, recency (want large)",
            distances(walk(**arms), walk(reverse=True, **arms), 30, 30),
        ),
        (
            "arms lifting vs lowering, uniform",
            distances(walk(**arms), walk(reverse=True, **arms), 30, 30, "uniform"),
        ),
    ]
    reference = walk(37, fps=24.0)
    for fps in (30.0, 60.0, 120.0):
        clip = walk(int(round(1.5 * fps)) + 1, fps=fps)
        rows.append((f"{fps:g} fps vs 24 fps", distances(clip, reference, fps, 24.0)))
    if not args.no_avatar:
        from eigmotion.imaging.silhouettes import render_masks

        body = low_poly_avatar()
        v30 = walk_vertices(body, 30.0, WALK_FRAMES_30FPS)
        v120 = walk_vertices(body, 120.0, 4 * (WALK_FRAMES_30FPS - 1) + 1)
        near = render_masks(v30, body.faces, offset_camera(v30, 90.0, 5.0, 128, 128))
        far_camera = offset_camera(v30, 90.0, 5.0, 160, 120, 1.7, (0.4, 0.2, 0.0))
        far = render_masks(v30, body.faces, far_camera)
        rows.append(
            ("avatar walk, fitted vs 1.7x further, 0.4 m off", distances(near, far, 30, 30))
        )
        camera = offset_camera(v120, 90.0, 5.0, 128, 128)
        rows.append(
            (
                "avatar walk, 120 fps vs 30 fps",
                distances(
                    render_masks(v120, body.faces, camera),
                    render_masks(v30, body.faces, camera),
                    120,
                    30,
                ),
            )
        )

    print("cosine distances; ratio = image frame / person frame")
    print(f"{'check':<48} {'person':>8} {'image':>8} {'ratio':>7}")
    for name, (person, image) in rows:
        person, image = max(person, 0.0), max(image, 0.0)  # rounding can give -1e-8
        r = f"{ratio(image, person):>7.2f}" if person > 1e-6 else f"{'-':>7}"
        print(f"{name:<48} {person:>8.4f} {image:>8.4f} {r}")


if __name__ == "__main__":
    main()
