"""Silhouette accuracy of the video front end against OpenCV's MOG2, on composed scenes.

The avatar walks (CMU 02_01, 1.5 s at 30 fps, low-poly default avatar), rendered
shaded by pyrender (no floor) and as true masks by the CPU rasteriser, filmed from
its side (azimuth 90 and 270, elevation 10°) and from the front (azimuth 0: walking
towards the camera), and composed by :func:`eigmotion.synth.scene.compose_scene` (textured
wall and tiled floor, cast shadow, a camouflage band of 25 % of the body height,
blur σ 0.7 px, noise σ 3 levels) with seeds ``0 .. --seeds - 1``.  The frames are used
as composed ("direct") and after writing them to ``.mp4`` with
:func:`eigmotion.imaging.media.write_video` and reading them back ("mp4").

:func:`eigmotion.segmentation.video.extract_silhouettes` cuts the person out with the background
given ("given"), estimated by the refined temporal median ("median"), and — the
baseline — estimated by OpenCV's MOG2 ("mog2").  The table gives the IoU against the
true masks (mean over the clip; then mean and minimum over the seeds), the seconds
per frame, and the mean IoU as a ratio of MOG2's on the same frames.

Run from the repository root with the venv active::

    python benchmarks/studies/bench_video_silhouettes.py [--seeds 3] [--no-mp4]
        [--views side90 side90-320 side270 front]

With the defaults it takes about 1.5 min on two cores; ``--seeds 1`` a third of it.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from eigmotion.evaluation.measures import iou, ratio
from eigmotion.imaging.media import read_frames, write_video
from eigmotion.segmentation.config import SilhouetteConfig
from eigmotion.segmentation.video import extract_silhouettes
from eigmotion.synth.walk_scenes import WALK_VIEWS, composed_walks, walk_views

#: (row name, background given?, SilhouetteConfig.background); the last is the baseline.
METHODS = (("given", True, "median"), ("median", False, "median"), ("mog2", False, "mog2"))


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, default=3, help="scenes per view (3)")
    parser.add_argument(
        "--views", nargs="+", choices=list(WALK_VIEWS), default=list(WALK_VIEWS), help="views (all)"
    )
    parser.add_argument("--no-mp4", action="store_true", help="skip the .mp4 round trip")
    args = parser.parse_args(argv)

    views, labels = walk_views(args.views)
    sources = ("direct",) if args.no_mp4 else ("direct", "mp4")
    scores: dict[tuple, list[tuple[float, float]]] = {}
    for view, _seed, truth, frames, background in composed_walks(views, range(args.seeds)):
        clips = {"direct": frames}
        if "mp4" in sources:
            with tempfile.TemporaryDirectory() as tmp:
                clips["mp4"], _ = read_frames(write_video(frames, Path(tmp) / "clip.mp4", 30.0))
        for source in sources:
            for name, given, method in METHODS:
                t0 = time.perf_counter()
                masks = extract_silhouettes(
                    clips[source],
                    background if given else None,
                    SilhouetteConfig(background=method),
                )
                seconds = (time.perf_counter() - t0) / len(masks)
                scores.setdefault((view, source, name), []).append((iou(masks, truth), seconds))

    baseline = METHODS[-1][0]
    print(f"{len(range(args.seeds))} seeds; ratio = mean IoU / mog2's mean IoU on the same frames")
    print(
        f"{'view':<13} {'size':<8} {'frames':<7} {'background':<10} "
        f"{'mean IoU':>8} {'min':>6} {'s/frame':>8} {'mog2':>6} {'ratio':>6}"
    )
    for view in views:
        for source in sources:
            base = np.mean([v[0] for v in scores[view, source, baseline]])
            for name, _, _ in METHODS:
                values = np.array(scores[view, source, name])
                mean = values[:, 0].mean()
                print(
                    f"{labels[view]} {source:<7} {name:<10} "
                    f"{mean:>8.3f} {values[:, 0].min():>6.3f} {values[:, 1].mean():>8.4f} "
                    f"{base:>6.3f} {ratio(mean, base):>6.2f}",
                    flush=True,
                )


if __name__ == "__main__":
    main()
