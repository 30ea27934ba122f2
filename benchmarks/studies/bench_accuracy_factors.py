"""Where recognition of new people is lost: the holdout benchmark, one factor at a time.

The ``holdout`` suite of ``bench_accuracy.py`` changes everything at once between the
database and a query: a new performance of the motion, a new body in clothes the
database never wore, a view between the virtual cameras, and silhouettes cut out of a
video with a shadow and noise.  This script answers the same held-out clips (same
folds, motions, views, bodies, garments and seeds) with the silhouettes made four
ways, from the most ideal to the real one:

1. ``db body, db view``: true silhouettes of the database's own (plain) body, seen
   from the rig camera nearest to the clip's view — only the performance is new;
2. ``db body, clip view``: the same body, seen from the clip's own view;
3. ``clip body``: the clip's body and garments from the clip's view, true silhouettes;
4. ``video``: cut out of the rendered ``.mp4`` (with its empty-scene image), as
   ``eigmotion query`` does — the ``holdout`` benchmark itself.

Each is scored against the fold databases (the performance is new: what the holdout
benchmark measures) and against one database of the whole library (the performance is
seen: only body, clothes, view and silhouettes differ), so the table splits the loss
between a new performance and everything else.  True silhouettes are rendered with the
clip's camera (fitted like :func:`eigmotion.synth.clips.render_clip`) at 320×240, 30 fps.

The database images are rendered once (``render_views``) and every fold database is
built from them (``build_database(..., views=...)``), so a run costs one render of the
library, the clips, and about 5–30 s per fold database::

    python benchmarks/studies/bench_accuracy_factors.py [--rig virtual_cameras/ring6.toml]
        [--clips-dir DIR] [--clips-per-motion 2] [--seed 0] [--workers N]
"""

from __future__ import annotations

import os

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

import argparse  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable, Sequence  # noqa: E402
from dataclasses import replace  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from eigmotion.body.garments import (
    BENCHMARK_GARMENTS,  # noqa: E402
    dress,  # noqa: E402
)
from eigmotion.body.retarget import animate_avatar  # noqa: E402
from eigmotion.errors import EigmotionError, VideoError  # noqa: E402
from eigmotion.evaluation.query_clips import (  # noqa: E402
    CLIP_FPS,
    HEIGHT_PX,
    WIDTH_PX,
    ClipMaker,
    ClipSpec,
    holdout_parser,
    parse_holdout_args,
    random_specs,
    run_with_clips,
    subject_folds,
    variation_folds,
)
from eigmotion.evaluation.statistics import markdown_table  # noqa: E402
from eigmotion.imaging.cameras import CameraRig, load_rig  # noqa: E402
from eigmotion.imaging.silhouettes import render_masks  # noqa: E402
from eigmotion.mocap.library import LibraryMotion, load_library  # noqa: E402
from eigmotion.retrieval.build import build_database  # noqa: E402
from eigmotion.retrieval.database import MotionDatabase  # noqa: E402
from eigmotion.retrieval.library_views import BuildConfig, ViewImages, render_views  # noqa: E402
from eigmotion.synth.clips import clip_camera  # noqa: E402

CONDITIONS = ("db body, db view", "db body, clip view", "clip body", "video")


def nearest_rig_view(rig: CameraRig, azimuth_deg: float, elevation_deg: float):
    """(azimuth, elevation) of the rig camera nearest to a direction, degrees."""
    az = np.array([c.azimuth_deg for c in rig.cameras])
    el = np.array([c.elevation_deg for c in rig.cameras])
    gap = np.abs((az - azimuth_deg + 180.0) % 360.0 - 180.0) + np.abs(el - elevation_deg)
    best = int(np.argmin(gap))
    return float(az[best]), float(el[best])


def true_masks(
    item: LibraryMotion, body, azimuth_deg: float, elevation_deg: float, margin: float
) -> np.ndarray:
    """(F, 240, 320) bool silhouettes of ``item`` on ``body``, filmed at 30 fps by a
    camera fitted as a query clip's is."""
    _, vertices = animate_avatar(body, item.motion.resample(CLIP_FPS))
    camera = clip_camera(vertices, azimuth_deg, elevation_deg, WIDTH_PX, HEIGHT_PX, margin)
    return render_masks(vertices, body.faces, camera)


class QueryMasks:
    """The silhouettes of one clip spec under each condition of :data:`CONDITIONS`."""

    def __init__(
        self,
        maker: ClipMaker,
        rig: CameraRig,
        items: dict[str, LibraryMotion],
        config: BuildConfig,
    ):
        from eigmotion.body.avatar import load_default_avatar

        self.maker, self.rig, self.items, self.config = maker, rig, items, config
        self.db_body = load_default_avatar()

    def masks(self, condition: str, spec: ClipSpec) -> tuple[np.ndarray, float]:
        """``(masks (F, H, W) bool, fps)``."""
        item = self.items[spec.motion]
        if condition == "db body, db view":
            view = nearest_rig_view(self.rig, spec.azimuth_deg, spec.elevation_deg)
            return true_masks(item, self.db_body, *view, spec.margin), CLIP_FPS
        if condition == "db body, clip view":
            view = (spec.azimuth_deg, spec.elevation_deg)
            return true_masks(item, self.db_body, *view, spec.margin), CLIP_FPS
        if condition == "clip body":
            body = dress(self.maker.body(spec.height_m, spec.girth), spec.outfit)
            view = (spec.azimuth_deg, spec.elevation_deg)
            return true_masks(item, body, *view, spec.margin), CLIP_FPS
        from eigmotion.retrieval.database import QUERY_SILHOUETTE_SIDE_PX
        from eigmotion.segmentation.config import SilhouetteConfig
        from eigmotion.segmentation.video import load_clip_masks

        clip = self.maker.make(spec, item)
        config = SilhouetteConfig(work_max_side_px=QUERY_SILHOUETTE_SIDE_PX)
        sample_fps = self.config.motion_image.sample_fps  # as MotionDatabase.query_clip
        found = load_clip_masks(clip.video, clip.background, config, sample_fps)
        return found.masks, found.fps


def answer(db: MotionDatabase, masks: np.ndarray, fps: float) -> tuple[str, ...]:
    """The distinct labels of the database's answer, best first (``()``: no answer)."""
    try:
        result = db.query_masks(masks, fps)
    except VideoError:
        return ()
    return tuple(m.label for m in result.labels)


def fold_views(all_views: Sequence[ViewImages], kept: Sequence[int]) -> list[ViewImages]:
    """The images of the kept motions (indices into the library), renumbered in order."""
    new_index = {old: new for new, old in enumerate(kept)}
    return [
        replace(view, motion_index=new_index[view.motion_index])
        for view in all_views
        if view.motion_index in new_index
    ]


def run(args: argparse.Namespace) -> None:
    t0 = time.perf_counter()
    library = [m for m in load_library() if m.role == "basic"]
    items = {m.name: m for m in library}
    rig = load_rig(args.rig)
    config = BuildConfig()
    folds = subject_folds(library, args) + variation_folds(library, args)
    maker = ClipMaker(args.clips_dir)
    outfits = ((), *((name,) for name in BENCHMARK_GARMENTS))
    specs = {name: [s for m in held for s in random_specs(m, args, maker, outfits)]
             for name, held in folds}  # fmt: skip
    print(f"rendering the database images: {len(library)} motions on {rig.name}", file=sys.stderr)
    all_views = list(render_views(library, rig, config, workers=args.workers))
    queries = QueryMasks(maker, rig, items, config)
    from tqdm import tqdm

    # Kept bit-packed (each clip is answered by its fold's database and the whole
    # library's): a few hundred MB instead of several GB.
    packed: dict[tuple[str, str], tuple[np.ndarray, int, float]] = {}
    every_spec = [s for fold in specs.values() for s in fold]
    for spec in tqdm(every_spec, desc="query silhouettes", unit="clip"):
        for condition in CONDITIONS:
            found, fps = queries.masks(condition, spec)
            packed[condition, spec.stem] = (np.packbits(found, axis=-1), found.shape[-1], fps)

    def masks(condition: str, spec: ClipSpec) -> tuple[np.ndarray, float]:
        bits, width, fps = packed[condition, spec.stem]
        return np.unpackbits(bits, axis=-1, count=width).astype(bool), fps

    # hits[database kind][condition] = list of (top-1, top-3) per in-library clip
    hits: dict[str, dict[str, list[tuple[bool, bool]]]] = {
        kind: {c: [] for c in CONDITIONS} for kind in ("new", "seen")
    }

    def score_into(
        kind: str, db: MotionDatabase, labels: set[str], fold_specs: Sequence[ClipSpec]
    ) -> None:
        for spec in fold_specs:
            if spec.label not in labels:
                continue  # out of the library for this fold: scored by bench_accuracy
            for condition in CONDITIONS:
                ranked = answer(db, *masks(condition, spec))
                hits[kind][condition].append(
                    (ranked[:1] == (spec.label,), spec.label in ranked[:3])
                )

    with tempfile.TemporaryDirectory(prefix="eigmotion-factors-") as tmp:

        def with_database(kept: list[int], use: Callable[[MotionDatabase, set], None]) -> None:
            uri = Path(tmp) / "fold.fs"
            train = [library[i] for i in kept]
            build_database(train, rig, uri, config, progress=False,
                           views=fold_views(all_views, kept))  # fmt: skip
            with MotionDatabase.open(uri) as db:
                use(db, {m.label for m in train})
            for suffix in ("", ".index", ".lock", ".tmp"):
                Path(f"{uri}{suffix}").unlink(missing_ok=True)

        for name, held in tqdm(folds, desc="fold databases", unit="fold"):
            held_names = {m.name for m in held}
            kept = [i for i, m in enumerate(library) if m.name not in held_names]
            fold_specs = specs[name]
            with_database(kept, lambda db, labels, f=fold_specs: score_into("new", db, labels, f))
        everything = list(range(len(library)))
        with_database(everything, lambda db, labels: score_into("seen", db, labels, every_spec))

    def cell(results: list[tuple[bool, bool]], k: int) -> str:
        n = len(results)
        hit = sum(r[k] for r in results)
        return f"{hit}/{n} ({100.0 * hit / max(n, 1):.1f} %)"

    print(
        f"\n## holdout, one factor at a time: {len(folds)} folds, {len(every_spec)} clips, "
        f"databases on {rig.name} ({len(rig)} views), seed {args.seed}\n"
    )
    rows = [
        [c, cell(hits["new"][c], 0), cell(hits["new"][c], 1), cell(hits["seen"][c], 0),
         cell(hits["seen"][c], 1)]
        for c in CONDITIONS
    ]  # fmt: skip
    header = ["query silhouettes", "new performance top-1", "top-3", "seen performance top-1",
              "top-3"]  # fmt: skip
    print("\n".join(markdown_table(header, rows)))
    print(f"\nwall time {time.perf_counter() - t0:.0f} s")


def main(argv: Sequence[str] | None = None) -> int:
    run_with_clips(run, parse_holdout_args(holdout_parser(__doc__.splitlines()[0]), argv))
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except EigmotionError as exc:
        print(f"bench_accuracy_factors: error: {exc}", file=sys.stderr)
        sys.exit(2)
