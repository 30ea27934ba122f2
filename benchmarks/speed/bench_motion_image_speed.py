"""Motion images per second on one core, by configuration, against the plain image.

The avatar walks (CMU 02_01, low-poly default avatar); its silhouettes are rendered
by the CPU rasteriser from the side (a 4-view ring at 10° elevation, fitted to the
motion, ``--mask-size`` pixels square), as a ``--frames``-frame clip at each
``--fps`` (default 120 and 30: 0.75 s and 3 s of walking, sampled down to 15 frames/s
by the motion image).  For each configuration, :func:`eigmotion.retrieval.motion_image.
motion_image` is called on the clip for ``--seconds`` seconds in ``--rounds``
interleaved rounds (the best round counts, so that the load of a shared machine
hits every configuration alike); the table gives the frames the clip had and used,
motion images per second, and that rate as a ratio of the rate of the patent's plain
image (image frame, uniform weights, no filter, 64×64,
no silhouette term) on the same clip in the same run.  One thread
(``OMP_NUM_THREADS=1``, ``cv2.setNumThreads(1)``).

Run from the repository root with the venv active::

    python benchmarks/speed/bench_motion_image_speed.py [--frames 90] [--mask-size 128]
        [--fps 120 30] [--seconds 2] [--rounds 4]
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")  # one core, before numpy is imported

import argparse  # noqa: E402
import time  # noqa: E402

import cv2  # noqa: E402

from eigmotion.evaluation.measures import PLAIN_CONFIG, ratio  # noqa: E402
from eigmotion.imaging.silhouettes import render_masks  # noqa: E402
from eigmotion.retrieval.motion_image import MotionImageConfig, motion_image, sample_indices  # noqa: E402
from eigmotion.synth.walk_scenes import low_poly_avatar, ring_camera, walk_vertices  # noqa: E402

#: (row name, MotionImageConfig arguments); the last row is the baseline.
CONFIGS = (
    ("default", {}),
    ("size=64", dict(size=64)),
    (
        "size=64, filter=none, silhouette_weight=0.0",
        dict(size=64, filter="none", silhouette_weight=0.0),
    ),
    ("frame=image", dict(frame="image")),
    ("plain (image, uniform, none, 64, sil 0)", PLAIN_CONFIG),
)


def rate(clip, config: MotionImageConfig, fps: float, seconds: float) -> float:
    """Motion images per second of ``clip``, timed over about ``seconds``."""
    motion_image(clip, config, fps)  # warm-up
    n, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        motion_image(clip, config, fps)
        n += 1
    return n / (time.perf_counter() - t0)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frames", type=int, default=90, help="frames per clip (90)")
    parser.add_argument("--mask-size", type=int, default=128, help="mask width = height (128)")
    parser.add_argument(
        "--fps", type=float, nargs="+", default=[120.0, 30.0], help="clip frame rates (120 30)"
    )
    parser.add_argument("--seconds", type=float, default=2.0, help="timing per cell, s (2)")
    parser.add_argument("--rounds", type=int, default=4, help="interleaved rounds (4)")
    args = parser.parse_args(argv)
    cv2.setNumThreads(1)

    body = low_poly_avatar()
    clips = {}
    for fps in args.fps:
        vertices = walk_vertices(body, fps, args.frames)
        camera = ring_camera(vertices, 1, args.mask_size, args.mask_size)
        clips[fps] = render_masks(vertices, body.faces, camera)

    configs = [(name, MotionImageConfig(**kwargs)) for name, kwargs in CONFIGS]
    rates: dict[tuple[str, float], float] = {}
    for _ in range(args.rounds):
        for name, config in configs:
            for fps, clip in clips.items():
                cell = rate(clip, config, fps, args.seconds / args.rounds)
                rates[name, fps] = max(rates.get((name, fps), 0.0), cell)
    baseline = configs[-1][0]
    print(f"masks {args.mask_size}x{args.mask_size}, one thread; ratio = images/s / plain's")
    print(f"{'config':<46} {'clip':>9} {'used':>5} {'images/s':>9} {'plain/s':>8} {'ratio':>6}")
    for name, config in configs:
        for fps, clip in clips.items():
            used = len(sample_indices(len(clip), fps, config.sample_fps))
            ours, base = rates[name, fps], rates[baseline, fps]
            print(
                f"{name:<46} {len(clip):>3}@{fps:<5g} {used:>5} {ours:>9.0f} {base:>8.0f} "
                f"{ratio(ours, base):>6.2f}"
            )


if __name__ == "__main__":
    main()
