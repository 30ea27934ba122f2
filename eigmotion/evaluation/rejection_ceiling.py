"""How well "unknown" could be told at best: the database's own renderings as queries.

Every whole-motion entry of a database is asked twice by its eigenspace point, as a
new performance of a known action (its own performance left out) and as an unknown
action (its whole label left out) (:func:`ask_both_ways`);
:func:`rejection_ceiling_report` tables how well the two are told apart.
``benchmarks/studies/bench_rejection_ceiling.py`` is the command line and says more.
"""

from __future__ import annotations

import os

import numpy as np
from sklearn.metrics import roc_auc_score

from eigmotion.errors import InvalidParameterError
from eigmotion.evaluation.query_variants import EntryTable
from eigmotion.evaluation.statistics import format_rate, markdown_table
from eigmotion.retrieval.database import MotionDatabase

#: Share of new performances turned away at the operating point compared.
FALSE_REJECTION = 0.05


#: The goal the operating point is held against: share of unknown actions rejected.
GOAL_REJECTED = 0.90


def nearest(queries: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(Q,) distance from each of ``queries`` (Q, k) to its nearest of ``points`` (N, k),
    and (Q,) the index of that nearest."""
    q, p = queries.astype(np.float64), points.astype(np.float64)
    squared = (q**2).sum(1)[:, None] - 2.0 * q @ p.T + (p**2).sum(1)[None, :]
    index = squared.argmin(axis=1)
    return np.sqrt(np.maximum(squared[np.arange(len(q)), index], 0.0)), index


def auc(known: np.ndarray, unknown: np.ndarray) -> float:
    """Probability that an unknown query lies farther than a known one (ties half)."""
    truth = np.r_[np.zeros(len(known)), np.ones(len(unknown))]
    return float(roc_auc_score(truth, np.r_[known, unknown]))


def ask_both_ways(
    table: EntryTable, whole: np.ndarray, body: np.ndarray, own_body: bool, alike: np.ndarray
):
    """Every whole-motion entry asked as a new performance and as an unknown action,
    against the bodies unlike its own (``alike``, (B, B) bool, as the calibration
    takes them) or, with ``own_body``, every body.

    Returns
    -------
    label : (M,) str
        The entry's label.
    known, unknown : (M,) float
        Its nearest distance without its own performance, and without its label.
    known_answer, unknown_answer : (M,) str
        The label of that nearest entry each time.
    """
    points = table.points
    own_body = own_body or len(np.unique(body)) == 1  # as the calibration does
    out = {"label": [], "known": [], "unknown": [], "known_answer": [], "unknown_answer": []}
    for performance in np.unique(table.performance[whole]):
        mine = table.performance == performance
        label = table.label[mine][0]
        for own in np.unique(body[whole & mine]):
            queries = points[whole & mine & (body == own)]
            searched = np.ones(len(points), bool) if own_body else ~alike[own][body]
            for key, kept in (("known", ~mine), ("unknown", table.label != label)):
                candidates = np.flatnonzero(searched & kept)
                distance, index = nearest(queries, points[candidates])
                out[key].append(distance)
                out[f"{key}_answer"].append(table.label[candidates[index]])
            out["label"].append(np.full(len(queries), label))
    return tuple(np.concatenate(out[k]) for k in out)


def rejection_ceiling_report(db_path: str | os.PathLike, own_body: bool = False) -> str:
    """The tables of :func:`ask_both_ways` on the database at ``db_path``: per label, the
    median nearest distance both ways and their AUC; overall, the unknown actions
    rejected where :data:`FALSE_REJECTION` of the new performances are turned away, by
    one threshold and by a threshold per answer label.

    Parameters
    ----------
    db_path : str or PathLike
    own_body : bool
        Search every body, the query's own too (else only the bodies unlike its own in
        build and outfit, as the threshold's calibration does).

    Returns
    -------
    str
        The report, as printed.

    Raises
    ------
    InvalidParameterError
        The database holds one label only.
    """
    lines: list[str] = []
    with MotionDatabase.open(db_path) as db:
        table = EntryTable(db)
        whole, body = table.calibration(db)
        alike = db.config.alike_bodies()
    if body is None:
        body = np.zeros(len(table.points), np.int64)
    if len(np.unique(table.label)) < 2:
        raise InvalidParameterError(f"{db_path}: one label only, nothing to leave out")
    label, known, unknown, known_answer, unknown_answer = ask_both_ways(
        table, whole, body, own_body, alike
    )
    searched = "every body" if own_body else "the bodies unlike its own"
    lines.append(
        f"{len(label)} whole-motion entries of {db_path}, each asked against {searched}: "
        f"as a new performance (its own left out) and as an unknown action (its label "
        f"left out)\n"
    )
    limit = np.quantile(known, 1.0 - FALSE_REJECTION)
    rows = []
    for name in np.unique(label):
        of = label == name
        rows.append(
            [name, int(of.sum()), f"{np.median(known[of]):.3f}", f"{np.median(unknown[of]):.3f}",
             f"{auc(known[of], unknown[of]):.2f}", format_rate(int((unknown[of] > limit).sum()),
                                                              int(of.sum()))]
        )  # fmt: skip
    header = ["label", "entries", "new performance: median", "unknown: median", "AUC",
              "unknown rejected at one threshold"]  # fmt: skip
    lines.append("\n".join(markdown_table(header, rows)))
    right = float(np.mean(known_answer == label))
    lines.append(f"\nnew performances answered with their own label: {right:.1%}")
    per_label = {a: np.quantile(known[known_answer == a], 1.0 - FALSE_REJECTION)
                 for a in np.unique(known_answer)}  # fmt: skip
    known_over = known / np.array([per_label[a] for a in known_answer])
    unknown_over = unknown / np.array([per_label.get(a, limit) for a in unknown_answer])
    goal = f"goal >= {GOAL_REJECTED:.0%} at <= {FALSE_REJECTION:.0%}"
    for rule, a, b in (
        ("one threshold", known, unknown),
        ("a threshold per answer label", known_over, unknown_over),
    ):
        cut = np.quantile(a, 1.0 - FALSE_REJECTION)
        rejected = int((b > cut).sum())
        lines.append(
            f"{rule}: AUC {auc(a, b):.3f}; at {FALSE_REJECTION:.0%} of new performances "
            f"turned away ({int((a > cut).sum())}/{len(a)}), unknown actions rejected "
            f"{format_rate(rejected, len(b))} ({goal}: {rejected / len(b) / GOAL_REJECTED:.2f} "
            f"of it)"
        )
    return "\n".join(lines)
