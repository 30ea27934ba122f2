"""Query time of the bundled sample clips, stage by stage, in process.

Times (median of ``--repeat`` runs, start-up excluded: the database is opened and
each clip decoded once beforehand) of the three stages of a query — silhouettes
from video, motion images (whole clip and sliding windows), exact search through the
tree — for our settings beside the baseline of segmenting at full video resolution
and searching by brute force, with the ratio.

    python benchmarks/bench_query.py [--db database/eigmotion.fs] [--repeat 5]
"""

from __future__ import annotations

import argparse
import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from eigmotion.database import DEFAULT_DB_PATH, QUERY_SILHOUETTE_SIDE_PX, MotionDatabase  # noqa: E402
from eigmotion.media import read_frames  # noqa: E402
from eigmotion.search import BruteForceIndex  # noqa: E402
from eigmotion.video import SilhouetteConfig, extract_silhouettes, read_background  # noqa: E402

SAMPLES = Path(__file__).resolve().parents[1] / "database" / "samples"


def _median_ms(repeat: int, fn, *args) -> tuple[float, object]:
    """Median wall time of ``fn(*args)`` over ``repeat`` calls, ms, and its result."""
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn(*args)
        times.append((time.perf_counter() - t0) * 1e3)
    return float(np.median(times)), out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--db", default=str(DEFAULT_DB_PATH))
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    db = MotionDatabase.open(args.db)
    arrays = db.store.arrays()
    brute = BruteForceIndex.from_arrays(arrays.points, arrays.ids)
    ours_cfg = SilhouetteConfig(work_max_side_px=QUERY_SILHOUETTE_SIDE_PX)
    full_cfg = SilhouetteConfig(work_max_side_px=4096)
    print(f"database {args.db}: {db.n_entries} entries, k = {db.eigenspace.n_components_}")
    header = f"{'clip':<22}{'stage':<22}{'ours ms':>10}{'baseline ms':>13}{'ratio':>8}"
    print(header)
    print("-" * len(header))
    for clip in sorted(SAMPLES.glob("*.mp4")):
        frames, fps = read_frames(clip)
        background = read_background(clip.with_name(clip.stem + "_background.png"))
        for bg_name, bg in (("given bg", background), ("no bg", None)):
            ours_ms, masks = _median_ms(args.repeat, extract_silhouettes, frames, bg, ours_cfg)
            full_ms, _ = _median_ms(args.repeat, extract_silhouettes, frames, bg, full_cfg)
            name = f"{clip.stem} ({bg_name})"
            ratio = full_ms / ours_ms
            print(f"{name:<22}{'silhouettes':<22}{ours_ms:>10.1f}{full_ms:>13.1f}{ratio:>8.1f}")
        query_ms, result = _median_ms(args.repeat, db.query_masks, masks, fps)
        images_ms = float(np.median([result.timing_ms["motion_images"]]))
        point = db.eigenspace.transform(result.motion_image[None])
        tree_ms, _ = _median_ms(args.repeat * 20, db.index.search, point, 1)
        brute_ms, _ = _median_ms(args.repeat * 20, brute.search, point, 1)
        print(f"{'':<22}{'retrieval (masks→answer)':<22}{query_ms:>10.1f}")
        print(f"{'':<22}{'  of which images':<22}{images_ms:>10.1f}")
        print(
            f"{'':<22}{'one search':<22}{tree_ms:>10.3f}{brute_ms:>13.3f}{brute_ms / tree_ms:>8.1f}"
        )
        print(f"{'':<22}{'answer':<22}{result.best.label:>10}")
        size = f"{frames.shape[2]}×{frames.shape[1]}"
        print(f"{'':<22}{'frames':<22}{len(frames):>10} at {fps:.0f} fps, {size}")


if __name__ == "__main__":
    main()
