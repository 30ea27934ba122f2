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

    python benchmarks/studies/bench_rejection_ceiling.py [--db database/eigmotion.fs] [--own-body]

About 8 s on the default database (49,236 entries).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from eigmotion.errors import EigmotionError
from eigmotion.evaluation.rejection_ceiling import rejection_ceiling_report
from eigmotion.retrieval.storage import DEFAULT_DB_PATH


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--db", type=Path, default=DEFAULT_DB_PATH)
    parser.add_argument(
        "--own-body", action="store_true", help="search every body, the query's own too"
    )
    args = parser.parse_args(argv)
    print(rejection_ceiling_report(args.db, args.own_body))
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except EigmotionError as exc:
        print(f"bench_rejection_ceiling: error: {exc}", file=sys.stderr)
        sys.exit(2)
