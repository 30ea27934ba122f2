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

    python benchmarks/bench_rerank.py [--seed 0 [--seed 1 ...]] [--clips-dir DIR] [--db PATH]
        [--variant PACE_WEIGHT=0] [--variant SEQUENCE_WEIGHT=3,PACE_FLOOR=0.6 ...]
        [--no-background [--compare-cuts]] [--silhouettes NAME=VALUE ...] [--unknown]
        [--segments]

``--no-background`` cuts the clips as a query without an image of the empty scene
does (the background estimated from each clip), to compare silhouette front ends by
what they do to recognition.

``--compare-cuts`` (with ``--no-background``) also cuts each clip with its empty-scene
image and prints, per label, how the estimated silhouettes agree with those
(:func:`mask_agreement`): where the estimate loses recognition, and what it misses.

``--silhouettes NAME=VALUE`` (repeatable) cuts the clips with a field of
:class:`~eigmotion.segmentation.video.SilhouetteConfig` changed from what a query uses (the working
size ``work_max_side_px``, the thresholds, the shadow test ...), to compare silhouette
settings by what they do to recognition; VALUE is JSON (``shadow_ratio=[0.35,0.85]``)
or text (``background=median``).

``--segments`` also scores the clips' ``segments`` for every run: each clip alone (one
part: its label), and each clip followed by another of a different label (two parts;
the partner drawn with a fixed seed, both folds out of the search).  Per run: the
share of frames whose segment has their part's label, the share given another
specific action (:func:`~eigmotion.evaluation.scoring.segment_agreement`), the segmental F1
at 50 % overlap, and segments per clip.  ``--variant SEGMENT_SWITCH_COST=0`` gives each
window its nearest entry's label (the clip's answer where every window has the same).
About 20 s per run.

``--unknown`` also measures the rejection of unknown motions on all the clips instead
of the holdout suite's few: each label is left out of the search in turn (every
motion of that label, and the clip's fold), the "unknown" threshold and the quantiles
behind ``p_known`` calibrated again on the entries left
(:func:`~eigmotion.retrieval.calibration.leave_one_motion_out_distances`, as a build of that
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
import json  # noqa: E402
import math  # noqa: E402
import random  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from collections import Counter  # noqa: E402
from dataclasses import dataclass  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from bench_accuracy import (  # noqa: E402
    TOP_K,
    ClipMaker,
    random_specs,
    subject_folds,
    variation_folds,
)

import eigmotion.retrieval.database as database_module  # noqa: E402
import eigmotion.retrieval.query_windows as query_windows_module  # noqa: E402
import eigmotion.retrieval.sequences as sequences_module  # noqa: E402
from eigmotion.body.garments import BENCHMARK_GARMENTS  # noqa: E402
from eigmotion.errors import EigmotionError, InvalidParameterError  # noqa: E402
from eigmotion.evaluation.scoring import (  # noqa: E402
    QueryOutcome,
    SegmentAgreement,
    format_operating_points,
    format_rate,
    markdown_table,
    operating_points,
    paired_comparison,
    rejection_rates,
    segment_agreement,
    separation,
)
from eigmotion.mocap.library import FILLER_LABELS, load_library  # noqa: E402
from eigmotion.retrieval.brute_force import BruteForceIndex  # noqa: E402
from eigmotion.retrieval.calibration import (  # noqa: E402
    THRESHOLD_QUANTILE,
    calibration_quantiles,
    leave_one_motion_out_distances,
)
from eigmotion.retrieval.database import QUERY_SILHOUETTE_SIDE_PX, MotionDatabase  # noqa: E402
from eigmotion.retrieval.storage import DEFAULT_DB_PATH  # noqa: E402
from eigmotion.segmentation.video import SilhouetteConfig, load_clip_masks  # noqa: E402

#: The constants a variant may set: those read while a query is answered, never
#: those a database was built with.
QUERY_CONSTANTS = {
    "sequences": (
        "PACE_WEIGHT", "PACE_FLOOR", "PACE_SMOOTHING_PASSES", "SEQUENCE_WEIGHT",
        "VIEW_REACH_DEG", "CANDIDATE_MOTIONS", "WARP_BAND",
    ),
    "database": ("CANDIDATE_ENTRIES", "CANDIDATE_MOTIONS"),
    "query_windows": (
        "WINDOW_CANDIDATES", "SPECIFIC_MARGIN", "MIN_SPECIFIC_WINDOWS", "SEGMENT_SWITCH_COST",
    ),
}  # fmt: skip
MODULES = {
    "sequences": sequences_module,
    "database": database_module,
    "query_windows": query_windows_module,
}


@dataclass(frozen=True)
class HeldOutClip:
    """One holdout clip's silhouettes, as a query cuts them, and what it shows.

    ``name``: the clip's file stem; ``held_out``: the names of its fold's motions;
    ``masks``: (F, H, W) bool, the frames the motion image samples, at the query's
    working size; ``fps``: their rate, frames/s; ``given_masks``: the same frames cut
    with the clip's empty-scene image, where ``masks`` were cut without it and both
    were asked for (``--compare-cuts``), else None.
    """

    name: str
    label: str
    held_out: tuple[str, ...]
    masks: np.ndarray
    fps: float
    given_masks: np.ndarray | None = None


def parse_variant(text: str) -> dict[str, float]:
    """``"NAME=VALUE,NAME=VALUE"`` → {NAME: value}, each NAME a query-time constant."""
    allowed = {name for names in QUERY_CONSTANTS.values() for name in names}
    out = {}
    for part in filter(None, text.split(",")):
        name, sep, value = part.partition("=")
        if not sep or name not in allowed:
            raise InvalidParameterError(
                f"--variant {text!r}: expected NAME=VALUE with NAME one of {sorted(allowed)}"
            )
        try:
            number = float(value)
        except ValueError:
            number = math.nan
        if not math.isfinite(number):
            raise InvalidParameterError(f"--variant {text!r}: {value!r} is not a finite number")
        out[name] = number
    return out


def parse_silhouette_setting(text: str) -> tuple[str, object]:
    """``"NAME=VALUE"`` → (NAME, value): a :class:`SilhouetteConfig` field for the cut.

    VALUE is read as JSON (``2.5``, ``[0.35, 0.85]``), or taken as text when it is not
    (``background=median``); the field and its value are checked when the clips are cut.
    """
    name, sep, value = text.partition("=")
    if not sep or not name:
        raise InvalidParameterError(f"--silhouettes {text!r}: expected NAME=VALUE")
    try:
        return name, json.loads(value)
    except json.JSONDecodeError:
        return name, value


def silhouette_setting_argument(text: str) -> tuple[str, object]:
    """:func:`parse_silhouette_setting` for argparse."""
    try:
        return parse_silhouette_setting(text)
    except InvalidParameterError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def cut_config(settings: list[tuple[str, object]]) -> SilhouetteConfig:
    """The query's silhouette configuration with ``settings`` (from ``--silhouettes``)
    in place of its fields (InvalidParameterError naming a field or value that is wrong)."""
    fields = {"work_max_side_px": QUERY_SILHOUETTE_SIDE_PX, **dict(settings)}
    return SilhouetteConfig.from_dict(fields)


def variant_argument(text: str) -> dict[str, float]:
    """:func:`parse_variant` for argparse, which then prints what is wrong."""
    try:
        return parse_variant(text)
    except InvalidParameterError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


class Variant:
    """Sets constants for the length of a ``with`` block, then puts them back."""

    def __init__(self, values: dict[str, float]):
        self.values = values
        self._saved: list[tuple[object, str, object]] = []

    def __enter__(self):
        for name, value in self.values.items():
            for module_name, names in QUERY_CONSTANTS.items():
                if name in names:
                    module = MODULES[module_name]
                    old = getattr(module, name)
                    self._saved.append((module, name, old))
                    setattr(module, name, type(old)(value))
        return self

    def __exit__(self, *exc):
        for module, name, old in reversed(self._saved):
            setattr(module, name, old)
        self._saved.clear()


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


def motion_names(db: MotionDatabase) -> dict[int, str]:
    """Motion id → the stored motion's name."""
    return {
        int(mid): db.motion_record(int(mid))["metadata"]["name"] for mid in db.store.motion_ids()
    }


def answer_all(db_path: Path, clips: list[HeldOutClip]) -> list[QueryOutcome]:
    """Each clip's answer, its fold's motions out of the search.

    The database is opened afresh, so nothing a query keeps (the candidates' pose
    speeds) outlives the constants it was computed with."""
    answers = {}
    with MotionDatabase.open(db_path) as db:
        entries = EntryTable(db)
        for held in sorted({c.held_out for c in clips}):
            entries.search_only(db, ~np.isin(entries.motion, held))
            for i, clip in enumerate(clips):
                if clip.held_out == held:
                    answers[i] = _outcome(db, clip, in_library=True)
    return [answers[i] for i in range(len(clips))]


def unknown_all(db_path: Path, clips: list[HeldOutClip]) -> tuple[list[QueryOutcome], dict]:
    """Each clip asked with its label left out of the search (see ``--unknown``).

    Returns
    -------
    outcomes : list of QueryOutcome
        Out of the library, in the order of ``clips``.
    thresholds : dict of str to float
        The threshold calibrated without each label.
    """
    answers, thresholds = {}, {}
    with MotionDatabase.open(db_path) as db:
        entries = EntryTable(db)
        whole, body = entries.calibration(db)
        for label in sorted({c.label for c in clips}):
            without = entries.label != label
            distances = leave_one_motion_out_distances(
                entries.points[without], entries.performance[without], whole[without],
                None if body is None else body[without],
            )  # fmt: skip
            quantiles = calibration_quantiles(distances)
            thresholds[label] = float(np.quantile(distances, THRESHOLD_QUANTILE))
            for held in sorted({c.held_out for c in clips if c.label == label}):
                entries.search_only(db, without & ~np.isin(entries.motion, held))
                db.threshold = thresholds[label]
                db.calibration_quantiles = np.asarray(quantiles)
                for i, clip in enumerate(clips):
                    if clip.label == label and clip.held_out == held:
                        answers[i] = _outcome(db, clip, in_library=False)
    return [answers[i] for i in range(len(clips))], thresholds


class EntryTable:
    """What each entry of a database is, as arrays (N,): ``motion`` (its motion's
    name), ``label``, ``performance`` (an index; a motion and its mirror image are
    one), and ``points`` (N, k); :meth:`calibration` reads which cover a whole motion,
    and the body each was rendered on."""

    def __init__(self, db: MotionDatabase):
        self.arrays = db.store.arrays()
        records = {int(m): db.motion_record(int(m)) for m in db.store.motion_ids()}
        self._meta = {m: r["metadata"] for m, r in records.items()}
        motions = self.arrays.motions.tolist()
        self.points = self.arrays.points
        self.motion = np.array([self._meta[m]["name"] for m in motions])
        self.label = np.array([records[m]["label"] for m in motions])
        originals = [self._meta[m].get("mirror_of") or self._meta[m]["name"] for m in motions]
        self.performance = np.unique(originals, return_inverse=True)[1]

    def calibration(self, db: MotionDatabase) -> tuple[np.ndarray, np.ndarray | None]:
        """What the threshold is calibrated on, from every entry record (read from
        the store, so only when the threshold is calibrated again): (N,) bool, the
        entries that cover their whole motion, and (N,) int, the body each was
        rendered on (None for a database stored without it)."""
        records = [db.store.entry(i) for i in self.arrays.ids.tolist()]
        whole = np.array(
            [self._meta[int(m)]["n_frames"] == e["end_frame"] and e["start_frame"] == 0
             for m, e in zip(self.arrays.motions, records, strict=True)]
        )  # fmt: skip
        bodies = [e.get("body") for e in records]
        return whole, None if None in bodies else np.array(bodies)

    def search_only(self, db: MotionDatabase, kept: np.ndarray) -> None:
        """Point ``db``'s search at the ``kept`` (N,) bool entries, by brute force."""
        db.index = BruteForceIndex.from_arrays(self.arrays.points[kept], self.arrays.ids[kept])


def _outcome(db: MotionDatabase, clip: HeldOutClip, in_library: bool) -> QueryOutcome:
    result = db.query_masks(clip.masks, clip.fps)
    return QueryOutcome(
        clip.label,
        tuple(m.label for m in result.labels),
        result.accepted,
        in_library,
        0.0,
        result.best.distance,
        result.p_known,
    )


def scores(clips: list[HeldOutClip], answers: list[QueryOutcome]) -> dict:
    """Top-1 and top-k counts, overall and per label."""
    top1, topk, n = Counter(), Counter(), Counter()
    for clip, answer in zip(clips, answers, strict=True):
        n[clip.label] += 1
        top1[clip.label] += answer.hit(1)
        topk[clip.label] += answer.hit(TOP_K)
    return {"n": n, "top1": top1, "topk": topk}


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
    print_runs(clips, outcomes)
    if args.segments:
        print_segments(segmented)
    if args.compare_cuts:
        print_mask_agreement(clips)
    if args.unknown:
        print_unknown(outcomes["shipped"], *unknown_all(args.db, clips))
    return 0


def print_runs(clips: list[HeldOutClip], outcomes: dict[str, list[QueryOutcome]]) -> None:
    """Each run's top-1 and top-k beside the first (shipped) run's on the same clips.

    Beside each count, the ratio to the shipped one and the clips it gained and lost,
    with the exact McNemar test's p-value (:func:`~eigmotion.evaluation.scoring.
    paired_comparison`): a variant that gains 7 clips and loses 3 has p = 0.34, no
    evidence of a better setting.  Then top-1 per label.

    Parameters
    ----------
    clips : list of HeldOutClip
    outcomes : dict
        Run name → its answers, one per clip in ``clips``' order; the shipped run first.
    """
    names = list(outcomes)
    shipped = outcomes[names[0]]
    results = {name: scores(clips, answers) for name, answers in outcomes.items()}
    rows = []
    for name, answers in outcomes.items():
        row = [name]
        for k in (1, TOP_K):
            change = paired_comparison([o.hit(k) for o in shipped], [o.hit(k) for o in answers])
            row += [
                f"{change.after}/{change.n}",
                f"{change.after / max(change.before, 1):.2f}",
                f"+{change.gained} −{change.lost}" if name != names[0] else "—",
                f"{change.p_value:.2f}" if name != names[0] else "—",
            ]
        rows.append(row)
    header = ["setting"]
    for k in (1, TOP_K):
        header += [f"top-{k}", "÷ shipped", "clips gained, lost", "p (McNemar)"]
    print("\n".join(markdown_table(header, rows)))
    first = results[names[0]]
    print(
        f"\nshipped: top-1 {format_rate(sum(first['top1'].values()), len(clips))}, "
        f"top-{TOP_K} {format_rate(sum(first['topk'].values()), len(clips))}"
    )
    labels = sorted(first["n"])
    per_label = [
        [name, *(f"{s['top1'][label]}/{s['n'][label]}" for label in labels)]
        for name, s in results.items()
    ]
    print()
    print("\n".join(markdown_table(["top-1 per label", *labels], per_label)))


def composite_pairs(clips: list[HeldOutClip], seed: int = 0) -> list[tuple[int, int]]:
    """For each clip (by index), a partner of another label cut at the same size and
    rate, drawn with ``seed``: the two, one after the other, make a clip of two parts."""
    rng = random.Random(seed)
    pairs = []
    for i, first in enumerate(clips):
        others = [
            j for j, other in enumerate(clips)
            if other.label != first.label and other.masks.shape[1:] == first.masks.shape[1:]
            and other.fps == first.fps
        ]  # fmt: skip
        if others:
            pairs.append((i, rng.choice(others)))
    return pairs


def segment_all(
    db_path: Path, clips: list[HeldOutClip], pairs: list[tuple[int, int]]
) -> dict[str, list[SegmentAgreement]]:
    """The segments of each clip alone (``"alone"``) and of each pair one after the
    other (``"pairs"``), against the parts they show; the folds of the clips asked
    are out of the search."""
    found: dict[str, list[SegmentAgreement]] = {"alone": [], "pairs": []}
    asked = [([i], found["alone"]) for i in range(len(clips))]
    asked += [(list(pair), found["pairs"]) for pair in pairs]
    with MotionDatabase.open(db_path) as db:
        entries = EntryTable(db)
        for parts, into in asked:
            held = [name for i in parts for name in clips[i].held_out]
            entries.search_only(db, ~np.isin(entries.motion, held))
            result = db.query_masks(
                np.concatenate([clips[i].masks for i in parts]), clips[parts[0]].fps
            )
            ends = np.cumsum([len(clips[i].masks) for i in parts]).tolist()
            starts = [0, *ends[:-1]]
            truth = [(a, b, clips[i].label) for a, b, i in zip(starts, ends, parts, strict=True)]
            shown = [(s.start_frame, s.end_frame, s.label) for s in result.segments]
            into.append(segment_agreement(shown, truth, FILLER_LABELS))
    return found


def print_segments(segmented: dict[str, dict[str, list[SegmentAgreement]]]) -> None:
    """The ``--segments`` table: per run and kind of clip, the frames given their
    part's label and another specific action's, the segmental F1 and the segments per
    clip, each beside the first (shipped) run's as a ratio."""

    def figures(found: list[SegmentAgreement]) -> list[float]:
        frames = sum(a.frames for a in found)
        hits = sum(a.found for a in found)
        shown = hits + sum(a.extra for a in found)
        return [
            sum(a.right for a in found) / frames,
            sum(a.wrong for a in found) / frames,
            2 * hits / (shown + hits + sum(a.missed for a in found)),
            shown / len(found),
        ]

    shipped = next(iter(segmented.values()))
    rows = []
    for name, found in segmented.items():
        for kind, clips_of_kind in found.items():
            beside = zip(figures(clips_of_kind), figures(shipped[kind]), strict=True)
            cells = [f"{v:.3f} ({v / f:.2f})" if f else f"{v:.3f}" for v, f in beside]
            rows.append([name, f"{kind} ({len(clips_of_kind)})", *cells])
    header = ["setting", "clips", "frames right", "frames wrong", "F1@50", "segments per clip"]
    print("\nSegments (÷ shipped in brackets):\n")
    print("\n".join(markdown_table(header, rows)))


@dataclass(frozen=True)
class MaskAgreement:
    """How a clip's silhouettes cut without its empty-scene image agree with those cut
    with it (the reference), over all of its frames.

    ``iou``: intersection over union; ``missed``, ``added``: the reference's pixels
    the estimate lacks, and the estimate's pixels outside the reference, as fractions
    of the reference's; ``still``: pixels of the reference's still body (in its masks
    in at least :data:`STILL_FRAC` of the frames); ``still_missed``: how many of those
    the estimate shows in fewer than half of the frames.
    """

    iou: float
    missed: float
    added: float
    still: int
    still_missed: int


#: A pixel in the reference masks in at least this fraction of the frames is part of
#: the person's still body.
STILL_FRAC = 0.8


def mask_agreement(estimated: np.ndarray, given: np.ndarray) -> MaskAgreement:
    """Agreement of (F, H, W) bool silhouettes ``estimated`` with ``given`` (the same
    frames, cut with the empty-scene image)."""
    if estimated.shape != given.shape:
        raise InvalidParameterError(
            f"the two cuts differ in shape: {estimated.shape} and {given.shape}"
        )
    area = max(int(given.sum()), 1)
    union = int((estimated | given).sum())
    still = given.mean(axis=0) >= STILL_FRAC
    return MaskAgreement(
        int((estimated & given).sum()) / max(union, 1),
        int((given & ~estimated).sum()) / area,
        int((estimated & ~given).sum()) / area,
        int(still.sum()),
        int((still & (estimated.mean(axis=0) < 0.5)).sum()),
    )


def print_mask_agreement(clips: list[HeldOutClip]) -> None:
    """The ``--compare-cuts`` table: per label, the mean over its clips of
    :func:`mask_agreement`'s fractions, and the share of the still body missed
    (pooled over the clips)."""
    found = [(clip.label, mask_agreement(clip.masks, clip.given_masks)) for clip in clips]
    rows = []
    for label in [*sorted({label for label, _ in found}), "all"]:
        part = [a for name, a in found if label in (name, "all")]
        still = sum(a.still for a in part)
        rows.append(
            [label, str(len(part)), f"{np.mean([a.iou for a in part]):.2f}",
             f"{np.mean([a.missed for a in part]):.2f}", f"{np.mean([a.added for a in part]):.2f}",
             f"{sum(a.still_missed for a in part) / still:.2f}" if still else "—"]
        )  # fmt: skip
    header = ["label", "clips", "IoU", "missed", "added", "still body missed"]
    print("\nThe silhouettes cut without the empty-scene image against those cut with it:\n")
    print("\n".join(markdown_table(header, rows)))


def print_unknown(known: list[QueryOutcome], unknown: list[QueryOutcome], thresholds: dict):
    """The ``--unknown`` tables: rejection per label left out, then overall."""
    rows = []
    for label, threshold in thresholds.items():
        asked = [o for o in unknown if o.true_label == label]
        rejected = sum(not o.accepted for o in asked)
        answered = Counter(o.predicted for o in asked if o.accepted).most_common(2)
        rows.append(
            [label, f"{threshold:.3f}", f"{rejected}/{len(asked)}",
             ", ".join(f"{name} {count}" for name, count in answered)]
        )  # fmt: skip
    print()
    header = ["label left out", "threshold", "rejected", "accepted as (most often)"]
    print("\n".join(markdown_table(header, rows)))
    rates = rejection_rates(known + unknown)
    alone = separation(known + unknown)
    print(
        f"\nunknown motions rejected {format_rate(rates.rejected, rates.n_out_of_library)}; "
        f"known motions falsely rejected {format_rate(rates.false_rejected, rates.n_in_library)} "
        f"(at the whole database's threshold)\n"
        f"distance alone: AUC {alone.auc:.3f}; a threshold at the 95th percentile of the known "
        f"motions' distances ({alone.threshold:.3f}) rejects {alone.rejected}/"
        f"{alone.n_out_of_library} unknown ones"
    )
    if all(o.p_known is not None for o in known + unknown):
        print(
            "\nAt other shares of `eigmotion query --false-rejection` (each clip judged by "
            "its p_known against the calibration of the database it was asked of):\n"
        )
        print(format_operating_points(operating_points(known + unknown)))


if __name__ == "__main__":
    try:
        sys.exit(main())
    except EigmotionError as exc:
        print(f"bench_rerank: error: {exc}", file=sys.stderr)
        sys.exit(2)
