"""Scoring of retrieval queries: accuracy per label, confusion matrix, rejection rates.

A query of a clip whose true label is known becomes one :class:`QueryOutcome`: the
labels the database ranked (distinct, nearest first), whether it accepted the best
match, and whether the true label is one the database holds at all ("in library").
:func:`score` turns a list of them into a :class:`Score`:

* top-1 / top-3 accuracy, overall and per label, over the in-library queries only (an
  out-of-library query cannot be answered right);
* a confusion matrix of every query: true label rows × top-1 label columns;
* rejection rates: the fraction of out-of-library queries answered ``accepted:
  false`` (should be 1) and the fraction of in-library queries answered so (the false
  rejection rate, should be 0);
* the mean query time;
* how well the answer's distance alone separates out-of-library from in-library
  queries (:func:`separation`), whatever threshold the database stores.

Every overall rate comes with its 95 % confidence interval
(:func:`eigmotion.evaluation.statistics.proportion_interval`): on a few hundred clips a
rate is known to a few points only.  :func:`eigmotion.evaluation.statistics.
paired_comparison` tells whether a change answered the same queries better than chance
would (exact McNemar test).  :func:`eigmotion.evaluation.segments.segment_agreement`
scores a clip's segments against the parts it shows.  :func:`format_score` prints a
score as Markdown tables.  Nothing here runs a query.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from eigmotion.errors import InvalidParameterError
from eigmotion.evaluation.statistics import (
    CONFIDENCE,
    format_percent,
    format_rate,
    json_interval,
    json_rate,
    markdown_table,
    rate_or_nan,
)

#: Cell shown for a zero count in printed confusion matrices.
ZERO_CELL = "·"
#: Label given to a query the engine could not answer (e.g. no person found).
NO_ANSWER = "(no answer)"


@dataclass(frozen=True)
class QueryOutcome:
    """One answered query and its truth.

    Attributes
    ----------
    true_label : str
        What the clip shows.
    ranked_labels : tuple of str
        Distinct labels in the database's answer, likeliest first (a query's
        ``labels``); at least one.
    accepted : bool
        The database took the best match as known (distance under its threshold).
    in_library : bool
        ``true_label`` is a label the queried database holds.
    query_s : float
        Wall time of the query, seconds (>= 0).
    distance : float or None
        Distance of the best match, eigen-coordinate units (``inf`` for a query that
        got no answer); ``None`` when not known.
    p_known : float or None
        In [0, 1]: the query's ``p_known``, the share of new performances of library
        motions at least as far from the database; ``None`` when not known.
    """

    true_label: str
    ranked_labels: tuple[str, ...]
    accepted: bool
    in_library: bool
    query_s: float
    distance: float | None = None
    p_known: float | None = None

    def __post_init__(self):
        labels = tuple(self.ranked_labels)
        if not labels:
            raise InvalidParameterError(
                f"ranked_labels of a query of {self.true_label!r} must hold at least one label"
            )
        if len(set(labels)) != len(labels):
            raise InvalidParameterError(f"ranked_labels must be distinct, got {list(labels)}")
        if not (math.isfinite(self.query_s) and self.query_s >= 0):
            raise InvalidParameterError(f"query_s must be a finite time >= 0, got {self.query_s}")
        if self.distance is not None and not self.distance >= 0:
            raise InvalidParameterError(
                f"distance must be >= 0 (or inf, or None), got {self.distance}"
            )
        if self.p_known is not None and not 0.0 <= self.p_known <= 1.0:
            raise InvalidParameterError(f"p_known must be in [0, 1] (or None), got {self.p_known}")
        object.__setattr__(self, "ranked_labels", labels)

    @property
    def predicted(self) -> str:
        """The top-1 label."""
        return self.ranked_labels[0]

    def hit(self, k: int) -> bool:
        """The true label is among the first ``k`` ranked labels."""
        if k < 1:
            raise InvalidParameterError(f"k must be >= 1, got {k}")
        return self.true_label in self.ranked_labels[:k]


# -- confusion matrix ----------------------------------------------------------------


@dataclass(frozen=True)
class ConfusionMatrix:
    """Counts of (true label, predicted label) pairs.

    Attributes
    ----------
    counts : (T, P) int64
        ``counts[i, j]``: queries of ``true_labels[i]`` answered ``predicted_labels[j]``.
    true_labels : tuple of str
        Row labels (T).
    predicted_labels : tuple of str
        Column labels (P).
    """

    counts: np.ndarray
    true_labels: tuple[str, ...]
    predicted_labels: tuple[str, ...]

    def count(self, true_label: str, predicted_label: str) -> int:
        """One cell; 0 for labels the matrix does not hold."""
        if true_label not in self.true_labels or predicted_label not in self.predicted_labels:
            return 0
        i = self.true_labels.index(true_label)
        j = self.predicted_labels.index(predicted_label)
        return int(self.counts[i, j])

    def to_json(self) -> dict:
        return {
            "true_labels": list(self.true_labels),
            "predicted_labels": list(self.predicted_labels),
            "counts": self.counts.tolist(),
        }


def _ordered(found: Iterable[str], order: Sequence[str] | None) -> tuple[str, ...]:
    """``order``'s labels that were found, in that order, then the others sorted."""
    found = set(found)
    first = [label for label in (order or ()) if label in found]
    return tuple(first + sorted(found - set(first)))


def confusion_matrix(
    true: Sequence[str], predicted: Sequence[str], label_order: Sequence[str] | None = None
) -> ConfusionMatrix:
    """Count (true, predicted) label pairs.

    Parameters
    ----------
    true, predicted : sequence of str
        One label each per query, same length.
    label_order : sequence of str, optional
        Preferred order of rows and columns; labels not in it follow, sorted.  Only
        labels that occur get a row (as a true label) or a column (as a predicted one).

    Returns
    -------
    ConfusionMatrix
    """
    true, predicted = list(true), list(predicted)
    if len(true) != len(predicted):
        raise InvalidParameterError(
            f"true and predicted must have one label per query, got {len(true)} and "
            f"{len(predicted)}"
        )
    rows = _ordered(true, label_order)
    cols = _ordered(predicted, label_order)
    counts = np.zeros((len(rows), len(cols)), dtype=np.int64)
    row_of = {label: i for i, label in enumerate(rows)}
    col_of = {label: j for j, label in enumerate(cols)}
    for t, p in zip(true, predicted, strict=True):
        counts[row_of[t], col_of[p]] += 1
    return ConfusionMatrix(counts, rows, cols)


# -- scores --------------------------------------------------------------------------


@dataclass(frozen=True)
class LabelScore:
    """The queries of one true label.

    Attributes
    ----------
    label : str
    in_library : bool
        The queried database(s) held this label (for every query of it).
    n : int
        Queries.
    top1, topk : int
        Queries whose true label was ranked first / among the first ``k``.
    rejected : int
        Queries answered ``accepted: false``.
    """

    label: str
    in_library: bool
    n: int
    top1: int
    topk: int
    rejected: int

    @property
    def top1_rate(self) -> float:
        return rate_or_nan(self.top1, self.n)

    @property
    def topk_rate(self) -> float:
        return rate_or_nan(self.topk, self.n)

    @property
    def rejected_rate(self) -> float:
        return rate_or_nan(self.rejected, self.n)

    def to_json(self) -> dict:
        return {
            "label": self.label,
            "in_library": self.in_library,
            "n": self.n,
            "top1": self.top1,
            "topk": self.topk,
            "rejected": self.rejected,
            "top1_rate": json_rate(self.top1_rate),
            "topk_rate": json_rate(self.topk_rate),
            "rejected_rate": json_rate(self.rejected_rate),
        }


@dataclass(frozen=True)
class RejectionRates:
    """How often the database said "unknown".

    Attributes
    ----------
    n_in_library : int
        Queries of labels the database holds.
    false_rejected : int
        Of those, answered ``accepted: false``.
    n_out_of_library : int
        Queries of labels the database does not hold.
    rejected : int
        Of those, answered ``accepted: false``.
    """

    n_in_library: int
    false_rejected: int
    n_out_of_library: int
    rejected: int

    @property
    def false_rejection_rate(self) -> float:
        """Fraction of in-library queries rejected (NaN without any)."""
        return rate_or_nan(self.false_rejected, self.n_in_library)

    @property
    def rejection_rate(self) -> float:
        """Fraction of out-of-library queries rejected (NaN without any)."""
        return rate_or_nan(self.rejected, self.n_out_of_library)

    def to_json(self) -> dict:
        return {
            "n_in_library": self.n_in_library,
            "false_rejected": self.false_rejected,
            "false_rejection_rate": json_rate(self.false_rejection_rate),
            "false_rejection_interval": json_interval(self.false_rejected, self.n_in_library),
            "n_out_of_library": self.n_out_of_library,
            "rejected": self.rejected,
            "rejection_rate": json_rate(self.rejection_rate),
            "rejection_interval": json_interval(self.rejected, self.n_out_of_library),
        }


def rejection_rates(outcomes: Sequence[QueryOutcome]) -> RejectionRates:
    """Rejections of in-library and of out-of-library queries."""
    inside = [o for o in outcomes if o.in_library]
    outside = [o for o in outcomes if not o.in_library]
    return RejectionRates(
        len(inside),
        sum(not o.accepted for o in inside),
        len(outside),
        sum(not o.accepted for o in outside),
    )


@dataclass(frozen=True)
class Separation:
    """How well the best match's distance tells out-of-library queries apart.

    Attributes
    ----------
    auc : float
        Probability that an out-of-library query is farther than an in-library one
        (ties count half): 1 separates perfectly, 0.5 is chance.
    quantile : float
        The in-library distance quantile taken as threshold.
    threshold : float
        That quantile, eigen-coordinate units.
    rejected, n_out_of_library : int
        Out-of-library queries farther than ``threshold``, and all of them.
    """

    auc: float
    quantile: float
    threshold: float
    rejected: int
    n_out_of_library: int

    @property
    def rejection_rate(self) -> float:
        return rate_or_nan(self.rejected, self.n_out_of_library)

    def to_json(self) -> dict:
        return {
            "auc": round(self.auc, 6),
            "quantile": self.quantile,
            "threshold": round(self.threshold, 6),
            "rejected": self.rejected,
            "n_out_of_library": self.n_out_of_library,
            "rejection_rate": json_rate(self.rejection_rate),
        }


def separation(outcomes: Sequence[QueryOutcome], quantile: float = 0.95) -> Separation:
    """Out-of-library vs in-library queries, by the best match's distance alone.

    Parameters
    ----------
    outcomes : sequence of QueryOutcome
        With distances; at least one in the library and one out of it.
    quantile : float
        In (0, 1]: the threshold is this quantile of the in-library distances (so
        about ``1 - quantile`` of them would be rejected).

    Returns
    -------
    Separation

    Raises
    ------
    InvalidParameterError
        A distance missing, ``quantile`` out of range, or one group empty.
    """
    if not 0 < quantile <= 1:
        raise InvalidParameterError(f"quantile must be in (0, 1], got {quantile}")
    if any(o.distance is None for o in outcomes):
        raise InvalidParameterError("separation needs the distance of every query")
    inside = np.array([o.distance for o in outcomes if o.in_library], dtype=np.float64)
    outside = np.array([o.distance for o in outcomes if not o.in_library], dtype=np.float64)
    if not len(inside) or not len(outside):
        raise InvalidParameterError(
            f"separation needs in-library and out-of-library queries, got {len(inside)} "
            f"and {len(outside)}"
        )
    with np.errstate(invalid="ignore"):  # inf - inf for two unanswered queries: a tie
        diff = outside[:, None] - inside[None, :]
    auc = float(np.mean(np.where(np.isnan(diff), 0.5, (diff > 0) + 0.5 * (diff == 0))))
    finite = inside[np.isfinite(inside)]
    threshold = float(np.quantile(finite, quantile)) if len(finite) else float("inf")
    return Separation(auc, quantile, threshold, int(np.sum(outside > threshold)), len(outside))


#: Shares of new performances of library motions a user might let the query turn
#: away (``eigmotion query --false-rejection``), for :func:`operating_points`.
FALSE_REJECTION_SHARES = (0.01, 0.05, 0.1, 0.2, 0.3, 0.5)


@dataclass(frozen=True)
class OperatingPoint:
    """Rejection at one ``--false-rejection`` share (see :func:`operating_points`).

    Attributes
    ----------
    share : float
        The share asked for: a query is rejected when its ``p_known < share``.
    rates : RejectionRates
        What that rejected, in and out of the library.
    """

    share: float
    rates: RejectionRates


def operating_points(
    outcomes: Sequence[QueryOutcome], shares: Sequence[float] = FALSE_REJECTION_SHARES
) -> list[OperatingPoint]:
    """What each ``--false-rejection`` share would reject: the in-library queries it
    turns away (about ``share`` of them, if the database's calibration holds for these
    queries) and the out-of-library ones.

    Parameters
    ----------
    outcomes : sequence of QueryOutcome
        Every one with its ``p_known``.
    shares : sequence of float
        Each in (0, 1).

    Returns
    -------
    list of OperatingPoint
        One per share, in order.

    Raises
    ------
    InvalidParameterError
        A ``p_known`` missing, or a share out of range.
    """
    if any(o.p_known is None for o in outcomes):
        raise InvalidParameterError("operating points need the p_known of every query")
    points = []
    for share in shares:
        if not 0.0 < share < 1.0:
            raise InvalidParameterError(f"a false rejection share must be in (0, 1), got {share}")
        inside = [o.p_known < share for o in outcomes if o.in_library]
        outside = [o.p_known < share for o in outcomes if not o.in_library]
        rates = RejectionRates(len(inside), sum(inside), len(outside), sum(outside))
        points.append(OperatingPoint(share, rates))
    return points


def format_operating_points(points: Sequence[OperatingPoint]) -> str:
    """A Markdown table of :func:`operating_points`: the share asked for, the known
    queries it turned away and the unknown ones it rejected, with 95 % intervals."""
    rows = [
        [f"{p.share:.2f}",
         format_rate(p.rates.false_rejected, p.rates.n_in_library),
         format_rate(p.rates.rejected, p.rates.n_out_of_library)]
        for p in points
    ]  # fmt: skip
    header = ["--false-rejection", "known motions turned away", "unknown motions rejected"]
    return "\n".join(markdown_table(header, rows))


@dataclass(frozen=True)
class Score:
    """Everything :func:`score` measures over a list of queries.

    Attributes
    ----------
    k : int
        The ``k`` of the top-k accuracy (3 by default).
    n : int
        In-library queries (those the accuracies count).
    top1, topk : int
        In-library queries answered right at rank 1 / within the first ``k`` labels.
    top1_accepted : int
        In-library queries answered right at rank 1 AND accepted.
    per_label : tuple of LabelScore
        In-library labels first, then out-of-library ones.
    confusion : ConfusionMatrix
        Every query: true label × top-1 label.
    rejection : RejectionRates
    mean_query_s : float
        Mean wall time per query, seconds (NaN without queries).
    n_queries : int
        All queries, in and out of the library.
    separation : Separation or None
        See :func:`separation`; ``None`` unless every query has a distance and both
        in-library and out-of-library queries are present.
    """

    k: int
    n: int
    top1: int
    topk: int
    top1_accepted: int
    per_label: tuple[LabelScore, ...]
    confusion: ConfusionMatrix
    rejection: RejectionRates
    mean_query_s: float
    n_queries: int
    separation: Separation | None = None

    @property
    def top1_rate(self) -> float:
        return rate_or_nan(self.top1, self.n)

    @property
    def topk_rate(self) -> float:
        return rate_or_nan(self.topk, self.n)

    @property
    def top1_accepted_rate(self) -> float:
        return rate_or_nan(self.top1_accepted, self.n)

    def to_json(self) -> dict:
        return {
            "k": self.k,
            "n_queries": self.n_queries,
            "n_in_library": self.n,
            "top1": self.top1,
            "topk": self.topk,
            "top1_accepted": self.top1_accepted,
            "top1_rate": json_rate(self.top1_rate),
            "topk_rate": json_rate(self.topk_rate),
            "top1_accepted_rate": json_rate(self.top1_accepted_rate),
            "confidence": CONFIDENCE,
            "top1_interval": json_interval(self.top1, self.n),
            "topk_interval": json_interval(self.topk, self.n),
            "per_label": [s.to_json() for s in self.per_label],
            "confusion": self.confusion.to_json(),
            "rejection": self.rejection.to_json(),
            "mean_query_s": json_rate(self.mean_query_s),
            "separation": None if self.separation is None else self.separation.to_json(),
        }


def score(
    outcomes: Sequence[QueryOutcome], k: int = 3, label_order: Sequence[str] | None = None
) -> Score:
    """Accuracy, confusion and rejection of a list of queries.

    Parameters
    ----------
    outcomes : sequence of QueryOutcome
        At least one.
    k : int
        Rank for the top-k accuracy, >= 1.
    label_order : sequence of str, optional
        Order of labels in ``per_label`` and in the confusion matrix (others follow,
        sorted).

    Returns
    -------
    Score

    Raises
    ------
    InvalidParameterError
        No outcomes, ``k < 1``, or a label that is in the library for some queries and
        out of it for others (score those separately, one database each).
    """
    outcomes = list(outcomes)
    if not outcomes:
        raise InvalidParameterError("score needs at least one query outcome, got none")
    if k < 1:
        raise InvalidParameterError(f"k must be >= 1, got {k}")
    status: dict[str, bool] = {}
    for o in outcomes:
        if status.setdefault(o.true_label, o.in_library) != o.in_library:
            raise InvalidParameterError(
                f"label {o.true_label!r} is in the library for some queries and out of it "
                "for others; score each database separately"
            )
    labels = _ordered(status, label_order)
    per_label = []
    for inside in (True, False):
        for label in labels:
            if status[label] != inside:
                continue
            mine = [o for o in outcomes if o.true_label == label]
            per_label.append(
                LabelScore(
                    label,
                    inside,
                    len(mine),
                    sum(o.hit(1) for o in mine),
                    sum(o.hit(k) for o in mine),
                    sum(not o.accepted for o in mine),
                )
            )
    inside = [o for o in outcomes if o.in_library]
    separable = all(o.distance is not None for o in outcomes) and 0 < len(inside) < len(outcomes)
    return Score(
        k=k,
        n=len(inside),
        top1=sum(o.hit(1) for o in inside),
        topk=sum(o.hit(k) for o in inside),
        top1_accepted=sum(o.hit(1) and o.accepted for o in inside),
        per_label=tuple(per_label),
        confusion=confusion_matrix(
            [o.true_label for o in outcomes], [o.predicted for o in outcomes], label_order
        ),
        rejection=rejection_rates(outcomes),
        mean_query_s=float(np.mean([o.query_s for o in outcomes])),
        n_queries=len(outcomes),
        separation=separation(outcomes) if separable else None,
    )


# -- printing ------------------------------------------------------------------------


def format_confusion(confusion: ConfusionMatrix) -> str:
    """The matrix as a Markdown table (rows: true labels, columns: top-1 labels)."""
    header = ["true \\ top-1", *confusion.predicted_labels]
    rows = [
        [label, *(str(c) if c else ZERO_CELL for c in confusion.counts[i])]
        for i, label in enumerate(confusion.true_labels)
    ]
    return "\n".join(markdown_table(header, rows))


def format_score(result: Score) -> str:
    """A score as Markdown: per-label table, overall line, rejection, confusion matrix.

    Top-1 per label and every overall rate come with their 95 % confidence interval
    (:func:`format_rate`): a label's 20 clips pin its rate down to ±15 points or so."""
    k = result.k
    rows = []
    for s in result.per_label:
        if s.in_library:
            rows.append(
                [
                    s.label,
                    str(s.n),
                    format_rate(s.top1, s.n),
                    f"{s.topk}/{s.n} ({format_percent(s.topk_rate)})",
                    f"{s.rejected}/{s.n}",
                ]
            )
        else:
            rows.append([f"{s.label} (out of library)", str(s.n), "—", "—", f"{s.rejected}/{s.n}"])
    rej = result.rejection
    lines = markdown_table(["label", "n", "top-1", f"top-{k}", "rejected"], rows)
    lines += [
        "",
        f"overall (in-library queries): top-1 {format_rate(result.top1, result.n)}, "
        f"top-{k} {format_rate(result.topk, result.n)}, top-1 and accepted "
        f"{result.top1_accepted}/{result.n} ({format_percent(result.top1_accepted_rate)})",
        f"rejection: out-of-library rejected {format_rate(rej.rejected, rej.n_out_of_library)}; "
        f"in-library falsely rejected {format_rate(rej.false_rejected, rej.n_in_library)}",
        f"mean query time: {result.mean_query_s:.2f} s over {result.n_queries} queries",
        *_separation_lines(result.separation),
        "",
        format_confusion(result.confusion),
    ]
    return "\n".join(lines)


def _separation_lines(sep: Separation | None) -> list[str]:
    if sep is None:
        return []
    return [
        f"distance alone: AUC {sep.auc:.2f} (out-of-library farther than in-library); a "
        f"threshold at the {100 * sep.quantile:.0f}th percentile of in-library distances "
        f"({sep.threshold:.3f}) would reject {sep.rejected}/{sep.n_out_of_library} "
        f"out-of-library queries ({format_percent(sep.rejection_rate)})"
    ]
