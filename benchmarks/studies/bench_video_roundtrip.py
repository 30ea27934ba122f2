"""The motion image through a video file: composed frames against the same frames
written to ``.mp4`` / ``.avi`` and read back.

The avatar walks (CMU 02_01, 1.5 s at 30 fps, low-poly default avatar), filmed from
its side (``--views``, default azimuth 90 and 270 at 160×120 and azimuth 90 at
320×240) and composed by :func:`eigmotion.synth.scene.compose_scene` with seeds
``0 .. --seeds - 1``.  Three default motion images (:func:`eigmotion.retrieval.motion_image.
motion_image`) per clip: of the true masks ("truth"), of the masks
:func:`eigmotion.segmentation.video.extract_silhouettes` cuts from the composed frames ("direct",
background estimated), and of the masks :func:`eigmotion.segmentation.video.load_clip_masks`
cuts from the file that :func:`eigmotion.imaging.media.write_video` made of those frames
("file", background estimated).  The table gives the cosine distances between
them, and truth-vs-file as a ratio of truth-vs-direct: how much further from the
true motion image the file takes the silhouettes than cutting them out already does.

Run from the repository root with the venv active::

    python benchmarks/studies/bench_video_roundtrip.py [--seeds 3]
        [--views side90 side270 side90-320]
        [--formats .mp4 .avi]

With the defaults it takes under a minute on two cores.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from eigmotion.evaluation.measures import cosine_distance, ratio
from eigmotion.imaging.media import write_video
from eigmotion.retrieval.motion_image import motion_image
from eigmotion.segmentation.video import extract_silhouettes, load_clip_masks
from eigmotion.synth.walk_scenes import WALK_VIEWS, composed_walks, walk_views


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, default=3, help="scenes per view (3)")
    parser.add_argument(
        "--views",
        nargs="+",
        choices=list(WALK_VIEWS),
        default=["side90", "side270", "side90-320"],
        help="views (side90 side270 side90-320)",
    )
    parser.add_argument(
        "--formats", nargs="+", default=[".mp4", ".avi"], help="file suffixes (.mp4 .avi)"
    )
    args = parser.parse_args(argv)

    views, labels = walk_views(args.views)
    print("cosine distances; ratio = truth-vs-file / truth-vs-direct")
    print(
        f"{'view':<13} {'size':<8} {'seed':>4} {'file':<5} {'direct-vs-file':>14} "
        f"{'truth-vs-direct':>15} {'truth-vs-file':>13} {'ratio':>6}"
    )
    rows = []
    for view, seed, truth, frames, _ in composed_walks(views, range(args.seeds)):
        t = motion_image(truth, clip_fps=30.0)
        d = motion_image(extract_silhouettes(frames), clip_fps=30.0)
        for suffix in args.formats:
            with tempfile.TemporaryDirectory() as tmp:
                clip = load_clip_masks(write_video(frames, Path(tmp) / f"clip{suffix}", 30.0))
                masks, fps = clip.masks, clip.fps
            f = motion_image(masks, clip_fps=fps)
            row = (cosine_distance(d, f), cosine_distance(t, d), cosine_distance(t, f))
            rows.append((suffix, *row))
            print(
                f"{labels[view]} {seed:>4} {suffix:<5} "
                f"{row[0]:>14.4f} {row[1]:>15.4f} {row[2]:>13.4f} {ratio(row[2], row[1]):>6.2f}",
                flush=True,
            )
    for suffix in args.formats:
        values = np.array([r[1:] for r in rows if r[0] == suffix])
        direct, file = values[:, 1].mean(), values[:, 2].mean()
        print(
            f"{suffix}: direct-vs-file {values[:, 0].min():.4f}-{values[:, 0].max():.4f}, "
            f"truth-vs-direct mean {direct:.4f}, truth-vs-file mean {file:.4f} "
            f"(ratio of means {ratio(file, direct):.2f})"
        )


if __name__ == "__main__":
    main()
