"""How well "unknown" could be told at best: the database's own renderings as queries.

A query of a library action done by someone new should lie nearer the database than a
query of an action the library does not hold, or no threshold can reject the one and
accept the other.  This asks the question where it is easiest: every whole-motion
entry of the database (its own bodies, one of its own cameras, perfect silhouettes)
is asked twice, by its eigenspace point against the stored entries —

- as a **new performance** of a known action: its own performance (the motion and its
  mirror image) left out, so its nearest entry is another performance, most often of
  its own label;
- as an **unknown action**: every entry of its label left out.

Each time only the entries rendered on the *other* bodies are searched, as the
threshold's calibration does (every body for a database of one; ``--own-body``
searches every body, the easier case of a query on one of the database's own
bodies).  Printed: per label, the median nearest distance both ways and how well it
separates them (AUC); overall, the AUC and the unknown actions rejected where 5 % of
the new performances are turned away — by one threshold over all, and by a threshold
per answer label (the answer's label's own 95th percentile).  The goal beside it:
>= 90 % rejected at <= 5 % false rejection.

Usage::

    python benchmarks/bench_rejection_ceiling.py [--db database/eigmotion.fs] [--own-body]

About 8 s on the default database (49,236 entries).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from sklearn.metrics import roc_auc_score

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_rerank import EntryTable  # noqa: E402

from eigmotion.errors import EigmotionError, InvalidParameterError  # noqa: E402
from eigmotion.evaluation.scoring import format_rate, markdown_table  # noqa: E402
from eigmotion.retrieval.database import MotionDatabase  # noqa: E402
from eigmotion.retrieval.storage import DEFAULT_DB_PATH  # noqa: E402

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


def ask_both_ways(table: EntryTable, whole: np.ndarray, body: np.ndarray, own_body: bool):
    """Every whole-motion entry asked as a new performance and as an unknown action.

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
            searched = np.ones(len(points), bool) if own_body else body != own
            for key, kept in (("known", ~mine), ("unknown", table.label != label)):
                candidates = np.flatnonzero(searched & kept)
                distance, index = nearest(queries, points[candidates])
                out[key].append(distance)
                out[f"{key}_answer"].append(table.label[candidates[index]])
            out["label"].append(np.full(len(queries), label))
    return tuple(np.concatenate(out[k]) for k in out)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--db", type=Path, default=DEFAULT_DB_PATH)
    parser.add_argument(
        "--own-body", action="store_true", help="search every body, the query's own too"
    )
    args = parser.parse_args(argv)
    with MotionDatabase.open(args.db) as db:
        table = EntryTable(db)
        whole, body = table.calibration(db)
    if body is None:
        body = np.zeros(len(table.points), np.int64)
    if len(np.unique(table.label)) < 2:
        raise InvalidParameterError(f"{args.db}: one label only, nothing to leave out")
    label, known, unknown, known_answer, unknown_answer = ask_both_ways(
        table, whole, body, args.own_body
    )
    searched = "every body" if args.own_body else "the other bodies"
    print(
        f"{len(label)} whole-motion entries of {args.db}, each asked against {searched}: "
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
    print("\n".join(markdown_table(header, rows)))
    right = float(np.mean(known_answer == label))
    print(f"\nnew performances answered with their own label: {right:.1%}")
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
        print(
            f"{rule}: AUC {auc(a, b):.3f}; at {FALSE_REJECTION:.0%} of new performances "
            f"turned away ({int((a > cut).sum())}/{len(a)}), unknown actions rejected "
            f"{format_rate(rejected, len(b))} ({goal}: {rejected / len(b) / GOAL_REJECTED:.2f} "
            f"of it)"
        )
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except EigmotionError as exc:
        print(f"bench_rejection_ceiling: error: {exc}", file=sys.stderr)
        sys.exit(2)
