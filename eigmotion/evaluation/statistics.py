"""Rates with their confidence intervals, the paired test of two runs, Markdown tables.

The statistics under :mod:`eigmotion.evaluation.scoring`: every rate comes with its
95 % confidence interval (:func:`proportion_interval`, Wilson score); on a few hundred
clips a rate is known to a few points only.  :func:`paired_comparison` tells whether a
change answered the same queries better than chance would (exact McNemar test).
:func:`format_rate` and :func:`markdown_table` print them.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.stats import binomtest

from eigmotion.errors import InvalidParameterError

#: Confidence level of the intervals given beside every rate.
CONFIDENCE = 0.95


def rate_or_nan(numerator: int, denominator: int) -> float:
    return numerator / denominator if denominator else float("nan")


def json_rate(value: float) -> float | None:
    return None if math.isnan(value) else round(value, 6)


def proportion_interval(
    successes: int, n: int, confidence: float = CONFIDENCE
) -> tuple[float, float]:
    """Confidence interval of a rate ``successes / n`` (Wilson score interval).

    The Wilson interval keeps its coverage near 0 and 1 (215/220, 0/8), where the
    normal approximation runs outside [0, 1] and the exact Clopper–Pearson interval is
    needlessly wide; computed by :func:`scipy.stats.binomtest`.

    Parameters
    ----------
    successes, n : int
        ``0 <= successes <= n``.
    confidence : float
        In (0, 1).

    Returns
    -------
    (low, high) : tuple of float
        Fractions in [0, 1]; ``(nan, nan)`` when ``n`` is 0.
    """
    if not 0.0 < confidence < 1.0:
        raise InvalidParameterError(f"confidence must be in (0, 1), got {confidence}")
    if not 0 <= successes <= n:
        raise InvalidParameterError(f"need 0 <= successes <= n, got {successes} of {n}")
    if n == 0:
        return float("nan"), float("nan")
    found = binomtest(successes, n).proportion_ci(confidence, method="wilson")
    return float(found.low), float(found.high)


def json_interval(successes: int, n: int) -> list[float] | None:
    low, high = proportion_interval(successes, n)
    return None if math.isnan(low) else [round(low, 6), round(high, 6)]


@dataclass(frozen=True)
class PairedComparison:
    """Two runs' right-or-wrong answers to the same queries, side by side.

    Attributes
    ----------
    n : int
        Queries both runs answered.
    before, after : int
        Right answers of each run.
    gained, lost : int
        Queries wrong before and right after, and right before and wrong after.
    p_value : float
        Two-sided exact McNemar test: the chance that ``gained`` and ``lost`` split at
        least this unevenly if the change made no difference (each changed query as
        likely to go either way); 1 when none changed.
    """

    n: int
    before: int
    after: int
    gained: int
    lost: int
    p_value: float


def paired_comparison(before: Sequence[bool], after: Sequence[bool]) -> PairedComparison:
    """Whether a change answered the same queries better or worse than chance would.

    Only the queries whose answer changed tell: with ``d`` of them, a split of
    ``gained`` to ``lost`` is compared with ``d`` fair coin tosses
    (:func:`scipy.stats.binomtest`).  Ten changed queries must split 9 to 1 for p <
    0.05; 7 to 3 (a net gain of four) has p = 0.34.

    Parameters
    ----------
    before, after : sequence of bool
        Per query, in the same order: right (True) or wrong, for each run.

    Returns
    -------
    PairedComparison
    """
    b = np.asarray(before, dtype=bool)
    a = np.asarray(after, dtype=bool)
    if b.ndim != 1 or b.shape != a.shape:
        raise InvalidParameterError(
            f"before and after must be 1-D and of one length, got shapes {b.shape} and {a.shape}"
        )
    gained, lost = int(np.sum(a & ~b)), int(np.sum(b & ~a))
    p_value = 1.0
    if gained + lost:
        p_value = float(binomtest(gained, gained + lost, 0.5).pvalue)
    return PairedComparison(len(b), int(b.sum()), int(a.sum()), gained, lost, p_value)


def format_percent(value: float) -> str:
    return "—" if math.isnan(value) else f"{100 * value:.1f}%"


def format_rate(successes: int, n: int) -> str:
    """``"194/220 (88.2%; 95% CI 83.2–91.8%)"``: a count, its rate and interval."""
    low, high = proportion_interval(successes, n)
    if math.isnan(low):
        return f"{successes}/{n} (—)"
    return (
        f"{successes}/{n} ({format_percent(successes / n)}; {100 * CONFIDENCE:.0f}% CI "
        f"{100 * low:.1f}–{100 * high:.1f}%)"
    )


def markdown_table(header: Sequence[str], rows: Iterable[Sequence[object]]) -> list[str]:
    """A Markdown table, columns padded to their widest cell.

    Parameters
    ----------
    header : sequence of str
    rows : iterable of sequences
        One cell per header column each (printed with ``str``).

    Returns
    -------
    list of str
        The lines: header, rule, one per row.
    """
    rows = [[str(c) for c in r] for r in rows]
    for i, r in enumerate(rows):
        if len(r) != len(header):
            raise InvalidParameterError(
                f"table row {i} has {len(r)} cells, expected {len(header)} (one per column)"
            )
    widths = [max([len(h), *(len(r[i]) for r in rows)]) for i, h in enumerate(header)]

    def line(cells):
        return "| " + " | ".join(c.ljust(w) for c, w in zip(cells, widths, strict=True)) + " |"

    rule = "|" + "|".join("-" * (w + 2) for w in widths) + "|"
    return [line(header), rule, *(line(r) for r in rows)]
