"""Two runs of ``bench_accuracy.py`` compared clip by clip: did the change help?

Each run's ``--json-out`` holds every query with its answer.  The clips both runs
asked (the same video asked of the database of the same name) are paired, and for each
measure — top-1 and top-k of the in-library clips, their false rejections, the
rejection of out-of-library ones — this prints both counts, the clips the second run
gained and lost, and the exact McNemar test's p-value of that split
(:func:`eigmotion.evaluation.statistics.paired_comparison`): the chance of a split at least as
uneven from a change that made no difference.  Then the clips whose top-1 answer
changed, by name.  On the holdout suite's 220 in-library clips a single run's top-1 is
known to about ±4 points; two runs on the same clips tell far finer differences apart,
but only those the p-value backs::

    python benchmarks/accuracy/bench_accuracy.py holdout --clips-dir DIR --json-out before.json
    (change something)
    python benchmarks/accuracy/bench_accuracy.py holdout --clips-dir DIR --json-out after.json
    python benchmarks/accuracy/compare_runs.py before.json after.json [--suite holdout]

A run made before each answer recorded whether its label is in the library takes it
from the suite's scores (a label any of them counts out of the library is out).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from eigmotion.errors import EigmotionError
from eigmotion.evaluation.compare import compare_runs


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("before", type=Path, help="the first run's --json-out")
    parser.add_argument("after", type=Path, help="the second run's --json-out")
    parser.add_argument("--suite", action="append", help="compare only this suite (repeatable)")
    args = parser.parse_args(argv)
    print("\n".join(compare_runs(args.before, args.after, args.suite)))
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except EigmotionError as exc:
        print(f"compare_runs: error: {exc}", file=sys.stderr)
        sys.exit(2)
