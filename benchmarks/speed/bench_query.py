"""Query time of the bundled sample clips, in process, end to end and stage by stage.

For each sample clip (``database/samples/*.mp4``; ``walk_3s`` is a 3 s, 320×240
clip), with its background image and without, prints the median wall time over
``--repeat`` runs of :meth:`MotionDatabase.query_clip` — reading the video, cutting
the person out, motion images, exact search through the tree — with the default
front end (``auto``: fused with the background image, learned without) and with the
classical subtraction, for our settings (only the frames the motion
image samples, segmented at ``QUERY_SILHOUETTE_SIDE_PX``) beside the baseline of the
same run (every frame, subtraction at the video's full resolution, searched by brute
force), with the ratio.
Start-up is excluded: the database is opened and each query run once before timing.
Each end-to-end figure is followed by its stages, ours beside the baseline's with the
ratio: the CPU time of the process (every thread; it moves less than the wall time on
a busy machine), silhouettes (reading and cutting the person out), motion images,
search, silhouette sequences (the query's own ``timing_ms``).  Then the stages of our query
with the background alone: reading, silhouettes, retrieval from masks, one search
(tree vs brute force).  ``--cores 1`` pins the process to one core.

    python benchmarks/speed/bench_query.py [--db database/eigmotion.fs] [--repeat 7] [--cores 1]
"""

from __future__ import annotations

import argparse
import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import time  # noqa: E402
from functools import partial  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from eigmotion.imaging.media import read_frame_sample  # noqa: E402
from eigmotion.retrieval.brute_force import BruteForceIndex  # noqa: E402
from eigmotion.retrieval.database import QUERY_SILHOUETTE_SIDE_PX, MotionDatabase  # noqa: E402
from eigmotion.retrieval.storage import DEFAULT_DB_PATH  # noqa: E402
from eigmotion.segmentation.config import SilhouetteConfig  # noqa: E402
from eigmotion.segmentation.learned import resolve_segmenter  # noqa: E402
from eigmotion.segmentation.video import (  # noqa: E402
    extract_silhouettes,
    load_clip_masks,
    read_background,
)

SAMPLES = Path(__file__).resolve().parents[2] / "database" / "samples"


def _median_ms(repeat: int, fn, *args) -> tuple[float, object]:
    """Median wall time of ``fn(*args)`` over ``repeat`` calls, ms, and its result."""
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn(*args)
        times.append((time.perf_counter() - t0) * 1e3)
    return float(np.median(times)), out


#: The query's stages, as its ``timing_ms`` names them.
STAGES = ("silhouettes", "motion_images", "search", "sequences")


class _Stages:
    """The stage times of every run of one query (``timing_ms``), and its answer."""

    def __init__(self):
        self.runs: list[dict] = []
        self.cpu_ms: list[float] = []
        self.label = ""

    def median(self, stage: str) -> float:
        return float(np.median([run[stage] for run in self.runs]))


def _timed_runs(repeat: int, query, *args) -> tuple[float, _Stages]:
    """Median wall time of ``query(*args)`` over ``repeat`` calls, ms, and the stages
    of every call."""
    stages = _Stages()

    def run():
        cpu = time.process_time()
        answer = query(*args)
        stages.cpu_ms.append((time.process_time() - cpu) * 1e3)
        result = answer[0] if isinstance(answer, tuple) else answer
        stages.runs.append(dict(result.timing_ms))
        stages.label = result.best.label

    ms, _ = _median_ms(repeat, run)
    return ms, stages


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--db", default=str(DEFAULT_DB_PATH))
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--cores", type=int, help="run on this many cores only")
    args = parser.parse_args()
    if args.cores:
        os.sched_setaffinity(0, sorted(os.sched_getaffinity(0))[: args.cores])
    db = MotionDatabase.open(args.db)
    arrays = db.store.arrays()
    brute = BruteForceIndex.from_arrays(arrays.points, arrays.ids)
    sample_fps = db.config.motion_image.sample_fps
    ours_cfg = SilhouetteConfig(work_max_side_px=QUERY_SILHOUETTE_SIDE_PX)
    full_cfg = SilhouetteConfig(work_max_side_px=4096)
    print(f"database {args.db}: {db.n_entries} entries, k = {db.eigenspace.n_components_}")
    header = f"{'clip':<24}{'stage':<26}{'ours ms':>10}{'baseline ms':>13}{'ratio':>8}"
    print(header)
    print("-" * len(header))

    def baseline_query(clip, bg):
        """Every frame, full resolution, brute-force search: the same answer, slower."""
        t0 = time.perf_counter()
        masks = load_clip_masks(clip, bg, full_cfg)
        silhouettes_ms = (time.perf_counter() - t0) * 1e3
        tree, db.index = db.index, brute
        try:
            result = db.query_masks(masks.masks, masks.fps)
        finally:
            db.index = tree
        result.timing_ms["silhouettes"] = silhouettes_ms
        return result

    for clip in sorted(SAMPLES.glob("*.mp4")):
        background = clip.with_name(clip.stem + "_background.png")
        sample = read_frame_sample(clip)
        size = f"{sample.frames.shape[2]}×{sample.frames.shape[1]}"
        print(f"{clip.stem}: {sample.n_frames} frames at {sample.clip_fps:.0f} fps, {size}")
        for bg_name, bg in (("given bg", background), ("no bg", None)):
            base_ms, base = _timed_runs(max(1, args.repeat // 3), baseline_query, clip, bg)
            for segmenter in ("auto", "subtraction"):  # auto: fused with bg, learned without
                front = resolve_segmenter(segmenter, bg is not None)
                ask = partial(db.query_clip, clip, bg, segmenter=segmenter)
                ask()  # warm the caches, load the networks (and compile what is compiled)
                ours_ms, ours = _timed_runs(args.repeat, ask)
                name = f"  {bg_name}, {front}"
                print(
                    f"{name:<24}{'query (end to end)':<26}{ours_ms:>10.1f}{base_ms:>13.1f}"
                    f"{base_ms / ours_ms:>8.1f}"
                )
                mine, theirs = float(np.median(ours.cpu_ms)), float(np.median(base.cpu_ms))
                cpu_line = f"{'':<24}{'  CPU (every thread)':<26}{mine:>10.1f}{theirs:>13.1f}"
                print(f"{cpu_line}{theirs / mine:>8.1f}")
                for stage in STAGES:
                    mine, theirs = ours.median(stage), base.median(stage)
                    print(
                        f"{'':<24}{'  ' + stage:<26}{mine:>10.1f}{theirs:>13.1f}"
                        f"{theirs / mine:>8.1f}"
                    )
                print(f"{'':<24}{'  answer':<26}{ours.label:>10}{base.label:>13}")
        read_ms, sample = _median_ms(args.repeat, read_frame_sample, clip, sample_fps)
        frames = sample.frames
        bg_image = read_background(background)
        cut_ms, masks = _median_ms(args.repeat, extract_silhouettes, frames, bg_image, ours_cfg)
        query_ms, result = _median_ms(args.repeat, db.query_masks, masks, sample.fps)
        point = db.eigenspace.transform(result.motion_image[None])
        tree_ms, _ = _median_ms(args.repeat * 20, db.index.search, point, 1)
        brute_ms, _ = _median_ms(args.repeat * 20, brute.search, point, 1)
        read_what = f"read {len(frames)} frames"
        print(f"{'  stages (given bg)':<24}{read_what:<26}{read_ms:>10.1f}")
        print(f"{'':<24}{'silhouettes':<26}{cut_ms:>10.1f}")
        print(f"{'':<24}{'retrieval (masks→answer)':<26}{query_ms:>10.1f}")
        print(
            f"{'':<24}{'one search (vs brute)':<26}{tree_ms:>10.3f}{brute_ms:>13.3f}"
            f"{brute_ms / tree_ms:>8.1f}"
        )


if __name__ == "__main__":
    main()
