"""Variants of the query's decision stage, asked of the holdout clips already cut out.

A variant sets query-time constants of :mod:`eigmotion.retrieval.sequences` and
:mod:`eigmotion.retrieval.database` (:data:`QUERY_CONSTANTS`) for the length of a
``with`` block (:class:`Variant`); each :class:`HeldOutClip` is then asked of a
database with its fold's motions out of the search (:class:`EntryTable`,
:func:`answer_all`), with its label out (:func:`unknown_all`), or cut into segments
(:func:`segment_all`), and the runs are printed side by side, each against the first
(shipped) one.  ``benchmarks/accuracy/bench_rerank.py`` is the command line.
"""

from __future__ import annotations

import json
import math
import random
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import eigmotion.retrieval.database as database_module
import eigmotion.retrieval.motion_cues as motion_cues_module
import eigmotion.retrieval.query_windows as query_windows_module
import eigmotion.retrieval.sequences as sequences_module
from eigmotion.errors import InvalidParameterError, VideoError
from eigmotion.evaluation.query_clips import TOP_K
from eigmotion.evaluation.scoring import (
    NO_ANSWER,
    QueryOutcome,
    format_operating_points,
    format_rate,
    markdown_table,
    operating_points,
    rejection_rates,
    separation,
)
from eigmotion.evaluation.segments import SegmentAgreement, segment_agreement
from eigmotion.evaluation.statistics import paired_comparison
from eigmotion.mocap.library import FILLER_LABELS
from eigmotion.retrieval.brute_force import BruteForceIndex
from eigmotion.retrieval.calibration import (
    THRESHOLD_QUANTILE,
    calibration_quantiles,
    leave_one_motion_out_distances,
)
from eigmotion.retrieval.database import QUERY_SILHOUETTE_CONFIG, MotionDatabase
from eigmotion.segmentation.config import SilhouetteConfig

#: The constants a variant may set: those read while a query is answered, never
#: those a database was built with.
QUERY_CONSTANTS = {
    "sequences": (
        "PACE_WEIGHT", "PACE_FLOOR", "PACE_SMOOTHING_PASSES", "SEQUENCE_WEIGHT",
        "VIEW_REACH_DEG", "CANDIDATE_MOTIONS", "WARP_BAND",
    ),
    "database": ("CANDIDATE_ENTRIES", "CANDIDATE_MOTIONS", "STILL_CHANGE_SHARE"),
    "query_windows": (
        "WINDOW_CANDIDATES", "FILLER_CANDIDATES", "SPECIFIC_MARGIN", "MIN_SPECIFIC_WINDOWS",
        "SEGMENT_SWITCH_COST",
    ),
    "motion_cues": (
        "WALK_MAX_HEIGHTS_PER_S", "RUN_MIN_HEIGHTS_PER_S", "TRAVEL_MIN_HEIGHTS_PER_S",
        "ASSUMED_FIELD_OF_VIEW_DEG", "TURN_MIN_DEG", "TURN_MIN_HEIGHTS_PER_S",
    ),
}  # fmt: skip


MODULES = {
    "sequences": sequences_module,
    "database": database_module,
    "query_windows": query_windows_module,
    "motion_cues": motion_cues_module,
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


def cut_config(settings: list[tuple[str, object]]) -> SilhouetteConfig:
    """The query's silhouette configuration with ``settings`` (from ``--silhouettes``)
    in place of its fields (InvalidParameterError naming a field or value that is wrong)."""
    return SilhouetteConfig.from_dict({**QUERY_SILHOUETTE_CONFIG.to_dict(), **dict(settings)})


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
                    answers[i] = query_outcome(db, clip, in_library=True)
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
                None if body is None else body[without], db.config.alike_bodies(),
            )  # fmt: skip
            quantiles = calibration_quantiles(distances)
            thresholds[label] = float(np.quantile(distances, THRESHOLD_QUANTILE))
            for held in sorted({c.held_out for c in clips if c.label == label}):
                entries.search_only(db, without & ~np.isin(entries.motion, held))
                db.threshold = thresholds[label]
                db.calibration_quantiles = np.asarray(quantiles)
                for i, clip in enumerate(clips):
                    if clip.label == label and clip.held_out == held:
                        answers[i] = query_outcome(db, clip, in_library=False)
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


def query_outcome(db: MotionDatabase, clip: HeldOutClip, in_library: bool) -> QueryOutcome:
    """The answer to one clip; a clip the query refuses (no person, no motion) is
    answered :data:`~eigmotion.evaluation.scoring.NO_ANSWER`, not accepted."""
    try:
        result = db.query_masks(clip.masks, clip.fps)
    except VideoError:
        return QueryOutcome(clip.label, (NO_ANSWER,), False, in_library, 0.0, math.inf, 0.0)
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


def runs_report(clips: list[HeldOutClip], outcomes: dict[str, list[QueryOutcome]]) -> str:
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

    Returns
    -------
    str
        The tables, as printed.
    """
    lines: list[str] = []
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
    lines.append("\n".join(markdown_table(header, rows)))
    first = results[names[0]]
    lines.append(
        f"\nshipped: top-1 {format_rate(sum(first['top1'].values()), len(clips))}, "
        f"top-{TOP_K} {format_rate(sum(first['topk'].values()), len(clips))}"
    )
    labels = sorted(first["n"])
    per_label = [
        [name, *(f"{s['top1'][label]}/{s['n'][label]}" for label in labels)]
        for name, s in results.items()
    ]
    lines.append("")
    lines.append("\n".join(markdown_table(["top-1 per label", *labels], per_label)))
    return "\n".join(lines)


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
            try:
                segments = db.query_masks(
                    np.concatenate([clips[i].masks for i in parts]), clips[parts[0]].fps
                ).segments
            except VideoError:  # refused (no person, no motion): no part shown
                segments = []
            ends = np.cumsum([len(clips[i].masks) for i in parts]).tolist()
            starts = [0, *ends[:-1]]
            truth = [(a, b, clips[i].label) for a, b, i in zip(starts, ends, parts, strict=True)]
            shown = [(s.start_frame, s.end_frame, s.label) for s in segments]
            into.append(segment_agreement(shown, truth, FILLER_LABELS))
    return found


def segments_report(segmented: dict[str, dict[str, list[SegmentAgreement]]]) -> str:
    """The ``--segments`` table: per run and kind of clip, the frames given their
    part's label and another specific action's, the segmental F1 and the segments per
    clip, each beside the first (shipped) run's as a ratio."""
    lines: list[str] = []

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
    lines.append("\nSegments (÷ shipped in brackets):\n")
    lines.append("\n".join(markdown_table(header, rows)))
    return "\n".join(lines)


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


def mask_agreement_report(clips: list[HeldOutClip]) -> str:
    """The ``--compare-cuts`` table: per label, the mean over its clips of
    :func:`mask_agreement`'s fractions, and the share of the still body missed
    (pooled over the clips)."""
    lines: list[str] = []
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
    lines.append("\nThe silhouettes cut without the empty-scene image against those cut with it:\n")
    lines.append("\n".join(markdown_table(header, rows)))
    return "\n".join(lines)


def unknown_report(known: list[QueryOutcome], unknown: list[QueryOutcome], thresholds: dict) -> str:
    """The ``--unknown`` tables: rejection per label left out, then overall."""
    lines: list[str] = []
    rows = []
    for label, threshold in thresholds.items():
        asked = [o for o in unknown if o.true_label == label]
        rejected = sum(not o.accepted for o in asked)
        answered = Counter(o.predicted for o in asked if o.accepted).most_common(2)
        rows.append(
            [label, f"{threshold:.3f}", f"{rejected}/{len(asked)}",
             ", ".join(f"{name} {count}" for name, count in answered)]
        )  # fmt: skip
    lines.append("")
    header = ["label left out", "threshold", "rejected", "accepted as (most often)"]
    lines.append("\n".join(markdown_table(header, rows)))
    rates = rejection_rates(known + unknown)
    alone = separation(known + unknown)
    lines.append(
        f"\nunknown motions rejected {format_rate(rates.rejected, rates.n_out_of_library)}; "
        f"known motions falsely rejected {format_rate(rates.false_rejected, rates.n_in_library)} "
        f"(at the whole database's threshold)\n"
        f"distance alone: AUC {alone.auc:.3f}; a threshold at the 95th percentile of the known "
        f"motions' distances ({alone.threshold:.3f}) rejects {alone.rejected}/"
        f"{alone.n_out_of_library} unknown ones"
    )
    if all(o.p_known is not None for o in known + unknown):
        lines.append(
            "\nAt other shares of `eigmotion query --false-rejection` (each clip judged by "
            "its p_known against the calibration of the database it was asked of):\n"
        )
        lines.append(format_operating_points(operating_points(known + unknown)))
    return "\n".join(lines)
