"""The query's decision stage on the holdout clips, in seconds instead of half an hour.

``bench_accuracy.py holdout`` builds a database per fold (about 3.5 min each, 11
folds) before it asks anything.  Settings of what a query does *after* its motion
image is made — how the candidates are ranked again by their silhouette sequences,
how the clip's answer is chosen — do not change a database, so they can be compared
without building one.  This script answers the same held-out clips (same folds,
motions, views, bodies, garments and seeds: ``--seed``, repeatable, 220 clips per seed
all compared together) with one database of the whole library, the fold's motions
taken out of the search: an exact brute-force index over the entries of the motions
the fold keeps stands in for the tree.  Everything else is the query as ``eigmotion
query`` runs it (``MotionDatabase.query_masks`` on the silhouettes cut from the
``.mp4`` with its empty-scene image).

It is an approximation of the holdout benchmark, not a substitute: the motion
eigenspace and the pose eigenspace were fitted with the held-out motions among the
others, and the acceptance threshold of a clip asked with its label in the search is
the whole database's.  On the seed-0 clips it gave 130/176 top-1 and 166/176 top-3
where the holdout benchmark gave 131 and 165 (the engine before pace counted), and 141
and 166 where it gave 140 and 164 (with pace).  Use it to choose settings, and the holdout
benchmark to report them.

Each ``--variant`` sets query-time constants of :mod:`eigmotion.retrieval.sequences` or
:mod:`eigmotion.retrieval.database` (``NAME=VALUE,NAME=VALUE``) for one run; the shipped
settings run first and are the baseline every variant is compared with, clip by clip:
the clips a variant gained and lost, and the exact McNemar test's p-value of that split
(below 0.05: unlikely to be chance)::

    python benchmarks/accuracy/bench_rerank.py [--seed 0 [--seed 1 ...]] [--clips-dir DIR]
        [--db PATH] [--variant PACE_WEIGHT=0] [--variant SEQUENCE_WEIGHT=3,PACE_FLOOR=0.6 ...]
        [--no-background [--compare-cuts]] [--silhouettes NAME=VALUE ...] [--unknown]
        [--segments]

``--no-background`` cuts the clips as a query without an image of the empty scene
does (the background estimated from each clip), to compare silhouette front ends by
what they do to recognition.

``--compare-cuts`` (with ``--no-background``) also cuts each clip with its empty-scene
image and prints, per label, how the estimated silhouettes agree with those
(:func:`mask_agreement`): where the estimate loses recognition, and what it misses.

``--silhouettes NAME=VALUE`` (repeatable) cuts the clips with a field of
:class:`~eigmotion.segmentation.config.SilhouetteConfig` changed from what a query uses (the working
size ``work_max_side_px``, the thresholds, the shadow test ...), to compare silhouette
settings by what they do to recognition; VALUE is JSON (``shadow_ratio=[0.35,0.85]``)
or text (``background=median``).

``--segments`` also scores the clips' ``segments`` for every run: each clip alone (one
part: its label), and each clip followed by another of a different label (two parts;
the partner drawn with a fixed seed, both folds out of the search).  Per run: the
share of frames whose segment has their part's label, the share given another
specific action (:func:`~eigmotion.evaluation.segments.segment_agreement`), the segmental F1
at 50 % overlap, and segments per clip.  ``--variant SEGMENT_SWITCH_COST=0`` gives each
window its nearest entry's label (the clip's answer where every window has the same).
About 20 s per run.

``--unknown`` also measures the rejection of unknown motions on all the clips instead
of the holdout suite's few: each label is left out of the search in turn (every
motion of that label, and the clip's fold), the "unknown" threshold and the quantiles
behind ``p_known`` calibrated again on the entries left
(:func:`~eigmotion.retrieval.database.leave_one_motion_out_distances`, as a build of that
database would), and every clip of that label asked.  Beside it, the false rejection
of the clips asked with their label in the search (at the whole database's
threshold), how well the best match's distance alone separates the two
(:func:`~eigmotion.evaluation.scoring.separation`), and what each share of ``eigmotion query
--false-rejection`` would turn away of both
(:func:`~eigmotion.evaluation.scoring.operating_points`).  About 30 s more.

Clips are rendered into ``--clips-dir`` (every seed's into the same folder: their
names differ) when missing (about 4 min for 184 clips) and reused; making their
specifications (the avatar posed to frame each clip) and cutting their silhouettes
takes about 2 min per seed, each run about 7 s.
"""

from __future__ import annotations

import os

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

from eigmotion.body.garments import BENCHMARK_GARMENTS  # noqa: E402
from eigmotion.errors import EigmotionError, InvalidParameterError  # noqa: E402
from eigmotion.evaluation.query_clips import (  # noqa: E402
    ClipMaker,
    random_specs,
    subject_folds,
    variation_folds,
)
from eigmotion.evaluation.query_variants import (  # noqa: E402
    HeldOutClip,
    Variant,
    answer_all,
    composite_pairs,
    cut_config,
    mask_agreement_report,
    motion_names,
    parse_silhouette_setting,
    parse_variant,
    runs_report,
    segment_all,
    segments_report,
    unknown_all,
    unknown_report,
)
from eigmotion.mocap.library import load_library  # noqa: E402
from eigmotion.retrieval.database import MotionDatabase  # noqa: E402
from eigmotion.retrieval.storage import DEFAULT_DB_PATH  # noqa: E402
from eigmotion.segmentation.video import load_clip_masks  # noqa: E402


def silhouette_setting_argument(text: str) -> tuple[str, object]:
    """:func:`parse_silhouette_setting` for argparse."""
    try:
        return parse_silhouette_setting(text)
    except InvalidParameterError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def variant_argument(text: str) -> dict[str, float]:
    """:func:`parse_variant` for argparse, which then prints what is wrong."""
    try:
        return parse_variant(text)
    except InvalidParameterError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def held_out_clips(args) -> list[HeldOutClip]:
    """Every in-library clip of the holdout suite of each of ``args.seeds`` (rendered
    when missing), cut out."""
    return [clip for seed in args.seeds for clip in _held_out_clips(args, seed)]


def _held_out_clips(args, seed: int) -> list[HeldOutClip]:
    from tqdm import tqdm

    library = load_library(include_distractors=True)
    basic = [m for m in library if m.role == "basic"]
    items = {m.name: m for m in basic}
    bench_args = argparse.Namespace(seed=seed, clips_per_motion=2, quick=False, subjects=None)
    folds = subject_folds(basic, bench_args) + variation_folds(basic, bench_args)
    outfits = ((), *((name,) for name in BENCHMARK_GARMENTS))
    maker = ClipMaker(args.clips_dir)
    config = cut_config(args.silhouettes)
    clips = []
    for _, held in folds:
        held_names = tuple(sorted(m.name for m in held))
        known = {m.label for m in basic if m.name not in held_names}
        # the fold's out-of-library clips (a label it holds out whole) are not scored
        specs = [s for m in held for s in random_specs(m, bench_args, maker, outfits)]
        specs = [s for s in specs if s.label in known]
        for spec in tqdm(specs, desc="clips", unit="clip", leave=False):
            clip = maker.make(spec, items[spec.motion])
            background = clip.background if args.background else None
            cut = load_clip_masks(clip.video, background, config, args.sample_fps)
            given = None
            if args.compare_cuts:
                given = load_clip_masks(clip.video, clip.background, config, args.sample_fps).masks
            clips.append(
                HeldOutClip(clip.video.stem, spec.label, held_names, cut.masks, cut.fps, given)
            )
    return clips


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--db", type=Path, default=DEFAULT_DB_PATH)
    parser.add_argument(
        "--seed",
        dest="seeds",
        type=int,
        action="append",
        help="the holdout clips of this seed (repeatable: the clips of every seed together; "
        "default 0)",
    )
    parser.add_argument("--clips-dir", type=Path, default=Path("/tmp/eigmotion-holdout-clips"))
    parser.add_argument("--variant", action="append", default=[], type=variant_argument)
    parser.add_argument(
        "--no-background",
        dest="background",
        action="store_false",
        help="cut the clips without their empty-scene images (estimated from each clip)",
    )
    parser.add_argument(
        "--compare-cuts",
        action="store_true",
        help="with --no-background: also cut each clip with its empty-scene image and print "
        "how the estimated silhouettes agree with those, per label",
    )
    parser.add_argument(
        "--silhouettes",
        action="append",
        default=[],
        type=silhouette_setting_argument,
        metavar="NAME=VALUE",
        help="cut the clips with this SilhouetteConfig field changed (repeatable), e.g. "
        "low_factor=2.5 or work_max_side_px=320",
    )
    parser.add_argument(
        "--unknown",
        action="store_true",
        help="also ask every clip with its label left out of the search: rejection",
    )
    parser.add_argument(
        "--segments",
        action="store_true",
        help="also score the segments of each clip alone and of two clips one after the other",
    )
    args = parser.parse_args(argv)
    args.seeds = sorted(set(args.seeds or [0]))
    if args.compare_cuts and args.background:
        raise InvalidParameterError("--compare-cuts compares cuts made with --no-background")
    with MotionDatabase.open(args.db) as db:
        args.sample_fps = db.config.motion_image.sample_fps
        stored = set(motion_names(db).values())
    basic = {m.name for m in load_library(include_distractors=True) if m.role == "basic"}
    if stored != basic:
        raise InvalidParameterError(
            f"{args.db}: holds {len(stored)} motions, not the library's {len(basic)} basic "
            "motions; rebuild it with `eigmotion build`"
        )
    cut_config(args.silhouettes)  # a wrong field or value stops the run before any cut
    t0 = time.perf_counter()
    clips = held_out_clips(args)
    seconds = time.perf_counter() - t0
    how = "with their backgrounds" if args.background else "without their backgrounds"
    if args.silhouettes:
        how += " (" + ", ".join(f"{name}={value}" for name, value in args.silhouettes) + ")"
    seeds = ", ".join(map(str, args.seeds))
    print(f"{len(clips)} holdout clips (seed {seeds}), cut out {how} in {seconds:.0f} s")
    runs = [("shipped", {})]
    runs += [(",".join(f"{k}={v:g}" for k, v in values.items()), values) for values in args.variant]
    outcomes, segmented = {}, {}
    pairs = composite_pairs(clips) if args.segments else []
    for name, values in runs:
        t0 = time.perf_counter()
        with Variant(values):
            outcomes[name] = answer_all(args.db, clips)
            if args.segments:
                segmented[name] = segment_all(args.db, clips, pairs)
        print(f"{name}: {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    print(runs_report(clips, outcomes))
    if args.segments:
        print(segments_report(segmented))
    if args.compare_cuts:
        print(mask_agreement_report(clips))
    if args.unknown:
        print(unknown_report(outcomes["shipped"], *unknown_all(args.db, clips)))
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except EigmotionError as exc:
        print(f"bench_rerank: error: {exc}", file=sys.stderr)
        sys.exit(2)
