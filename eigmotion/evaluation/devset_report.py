"""Scores of the development set's answers (:mod:`eigmotion.evaluation.devset`), as
Markdown tables and JSON.

Per mode (:func:`summarise`): top-1 and top-3 over the distinct ranked labels, per
label and overall, with counts (:func:`eigmotion.evaluation.scoring.score`: clips of the
label ``unknown`` are out of the library and count only as rejected or not), the
confusion matrix (truth × answer), where the true label stands among the ranked labels
(:func:`truth_ranks`), the median and 90th percentile of the query time,
the queries that raised (wrong, listed with their message), for the unknown clips how
many came back ``accepted: false`` and their ``p_known``, and for ``bg``/``nobg`` the
mean intersection over union of the query's silhouettes with the true masks, per label
and overall (the mean of the per-clip means).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from eigmotion.errors import InvalidParameterError
from eigmotion.evaluation.devset import ERROR_LABEL, MODE_TITLES, ClipAnswer
from eigmotion.evaluation.query_clips import TOP_K
from eigmotion.evaluation.scoring import QueryOutcome, Score, format_score, score
from eigmotion.evaluation.statistics import format_percent, json_rate, markdown_table

#: Off-diagonal cells of the confusion matrix the summary names, most frequent first.
CONFUSIONS_LISTED = 6
#: Ranks of the true label counted one by one in the summary; lower ranks are counted
#: together.
RANKS_LISTED = 3


def outcome(answer: ClipAnswer) -> QueryOutcome:
    """The answer as :mod:`eigmotion.evaluation.scoring` scores it."""
    distance = math.inf if answer.distance is None else answer.distance
    return QueryOutcome(
        answer.true_label,
        answer.labels,
        answer.accepted,
        answer.in_library,
        answer.query_s,
        distance,
        answer.p_known,
    )


@dataclass(frozen=True)
class ModeSummary:
    """The scores of one mode's answers.

    Attributes
    ----------
    mode : str
    score : Score
        Top-1/top-3 per label and overall, confusion, rejection.
    median_s, p90_s : float
        Median and 90th percentile of the query wall time, seconds.
    errors : tuple of (str, str)
        (clip id, message) of each query that raised.
    unknown : tuple of ClipAnswer
        The answers to clips of actions outside the label set.
    iou_per_label : dict of str to (float, int)
        Mean over the label's clips of each clip's mean IoU, and the clips; empty when
        the mode has no IoU.
    iou : float
        The mean over every clip with an IoU (NaN without any).
    ranks : dict of str to int
        :func:`truth_ranks` of the answers.
    """

    mode: str
    score: Score
    median_s: float
    p90_s: float
    errors: tuple[tuple[str, str], ...]
    unknown: tuple[ClipAnswer, ...]
    iou_per_label: dict[str, tuple[float, int]]
    iou: float
    ranks: dict[str, int]

    @property
    def unknown_rejected(self) -> int:
        return sum(not a.accepted and a.error is None for a in self.unknown)

    def to_json(self) -> dict:
        return {
            "mode": self.mode,
            "title": MODE_TITLES.get(self.mode, self.mode),
            **self.score.to_json(),
            "median_query_s": round(self.median_s, 4),
            "p90_query_s": round(self.p90_s, 4),
            "errors": [{"id": i, "error": e} for i, e in self.errors],
            "unknown": {
                "n": len(self.unknown),
                "rejected": self.unknown_rejected,
                "p_known": {a.clip_id: a.p_known for a in self.unknown},
            },
            "truth_ranks": dict(self.ranks),
            "iou": json_rate(self.iou),
            "iou_per_label": {k: {"iou": json_rate(v), "n": n} for k, (v, n) in
                              self.iou_per_label.items()},
        }  # fmt: skip


def truth_ranks(answers: Sequence[ClipAnswer]) -> dict[str, int]:
    """How many in-library answers ranked their true label first, second, …, lower.

    Parameters
    ----------
    answers : sequence of ClipAnswer

    Returns
    -------
    dict of str to int
        ``"1"`` … ``str(RANKS_LISTED)``: the answers whose ranked labels hold the true
        label at that place (:attr:`ClipAnswer.truth_rank`); ``"lower"``: further down;
        ``"not ranked"``: not among them, or the query raised.  Every key is present.
    """
    counts = dict.fromkeys([str(r) for r in range(1, RANKS_LISTED + 1)], 0)
    counts.update({"lower": 0, "not ranked": 0})
    for answer in answers:
        if not answer.in_library:
            continue
        rank = answer.truth_rank
        if rank is None:
            counts["not ranked"] += 1
        else:
            counts[str(rank) if rank <= RANKS_LISTED else "lower"] += 1
    return counts


def summarise(mode: str, answers: Sequence[ClipAnswer]) -> ModeSummary:
    """Score one mode's answers (at least one).

    Raises
    ------
    InvalidParameterError
        No answers.
    """
    answers = list(answers)
    if not answers:
        raise InvalidParameterError(f"no answers to score in mode {mode!r}")
    times = np.array([a.query_s for a in answers])
    with_iou = [a for a in answers if a.iou is not None]
    per_label: dict[str, tuple[float, int]] = {}
    for label in sorted({a.true_label for a in with_iou}):
        mine = [a.iou for a in with_iou if a.true_label == label]
        per_label[label] = (float(np.mean(mine)), len(mine))
    return ModeSummary(
        mode,
        score([outcome(a) for a in answers], k=TOP_K),
        float(np.median(times)),
        float(np.percentile(times, 90)),
        tuple((a.clip_id, a.error) for a in answers if a.error is not None),
        tuple(a for a in answers if not a.in_library),
        per_label,
        float(np.mean([a.iou for a in with_iou])) if with_iou else float("nan"),
        truth_ranks(answers),
    )


def top_confusions(summary: ModeSummary, n: int = CONFUSIONS_LISTED) -> list[tuple[str, str, int]]:
    """The ``n`` largest off-diagonal cells (truth, answer, count), largest first, of
    the in-library clips."""
    confusion = summary.score.confusion
    cells = [
        (-int(count), truth, answer)
        for i, truth in enumerate(confusion.true_labels)
        for j, answer in enumerate(confusion.predicted_labels)
        if (count := confusion.counts[i, j]) and truth != answer
        and any(s.label == truth and s.in_library for s in summary.score.per_label)
    ]  # fmt: skip
    return [(truth, answer, -count) for count, truth, answer in sorted(cells)[:n]]


def format_mode(summary: ModeSummary) -> str:
    """One mode as Markdown: the score's tables, then time, IoU, unknown clips, errors."""
    title = MODE_TITLES.get(summary.mode, summary.mode)
    lines = [f"## {summary.mode}: {title}", "", format_score(summary.score), ""]
    confused = top_confusions(summary)
    if confused:
        lines.append(
            "most confused (truth → answer): " + ", ".join(f"{t} → {a} {c}" for t, a, c in confused)
        )
    if any(summary.ranks.values()):
        lines.append(
            "true label ranked (of the in-library clips): "
            + ", ".join(f"{place} {count}" for place, count in summary.ranks.items())
        )
    lines.append(
        f"query time: median {summary.median_s:.2f} s, 90th percentile {summary.p90_s:.2f} s"
    )
    if summary.unknown:
        p_known = ", ".join(
            f"{a.clip_id} {'—' if a.p_known is None else f'{a.p_known:.3f}'}"
            + ("" if a.accepted else " (rejected)")
            for a in summary.unknown
        )
        lines.append(
            f"not in the library ({summary.unknown[0].true_label}): "
            f"{summary.unknown_rejected}/{len(summary.unknown)} answered accepted: false; "
            f"p_known: {p_known}"
        )
    if summary.iou_per_label:
        rows = [[k, n, f"{v:.3f}"] for k, (v, n) in summary.iou_per_label.items()]
        n_all = sum(n for _, n in summary.iou_per_label.values())
        rows.append(["all", n_all, f"{summary.iou:.3f}"])
        lines += [
            "",
            "silhouettes against the true masks (IoU, mean of the per-clip means):",
            "",
            *markdown_table(["label", "clips", "IoU"], rows),
        ]
    if summary.errors:
        lines += ["", f"errors ({len(summary.errors)}, counted as wrong, {ERROR_LABEL}):"]
        lines += [f"- {clip_id}: {message}" for clip_id, message in summary.errors]
    return "\n".join(lines)


def format_overview(summaries: Sequence[ModeSummary]) -> str:
    """One row per mode: top-1, top-3, IoU, query times, errors."""
    rows = []
    for s in summaries:
        rows.append(
            [
                s.mode,
                f"{s.score.top1}/{s.score.n} ({format_percent(s.score.top1_rate)})",
                f"{s.score.topk}/{s.score.n} ({format_percent(s.score.topk_rate)})",
                "—" if math.isnan(s.iou) else f"{s.iou:.3f}",
                f"{s.median_s:.2f}",
                f"{s.p90_s:.2f}",
                f"{s.unknown_rejected}/{len(s.unknown)}" if s.unknown else "—",
                str(len(s.errors)),
            ]
        )
    header = ["mode", "top-1", f"top-{TOP_K}", "IoU", "median s", "p90 s", "unknown rejected",
              "errors"]  # fmt: skip
    return "\n".join(markdown_table(header, rows))
