"""Cold start of ``eigmotion query``: a new process per run, as a user runs it.

Runs ``python -m eigmotion query CLIP --background IMAGE --db DB --json`` ``--repeat``
times and prints the median wall time beside the previous start-up path's, measured in
the same run, interleaved run by run: the same command with the modules the query
command used to import at its top whatever was asked (the 3D output's
``eigmotion.pose.continuous_pose`` and ``eigmotion.pose.replay``, which load retargeting
and scipy.spatial) imported first.  The ratio is previous / ours.  Then, in one more
process each, where the time goes: the interpreter with numpy alone, the command's
imports, opening the database, and the query's own stages (its ``timing_ms``), medians
over the runs.

    python benchmarks/speed/bench_cold_query.py [--db database/eigmotion.fs] [--repeat 5]
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
SAMPLES = REPO / "database" / "samples"

#: The modules ``eigmotion.cli.query`` imported at its top before they were moved into
#: the function that writes the 3D output.
PREVIOUS_TOP_IMPORTS = ("eigmotion.pose.continuous_pose", "eigmotion.pose.replay")

_RUN_MAIN = "import sys\nfrom eigmotion.cli.main import main\nsys.exit(main(sys.argv[1:]))"

_STAGES = """
import json, sys, time
t0 = time.perf_counter()
import eigmotion.cli.query
t1 = time.perf_counter()
from eigmotion.retrieval.database import MotionDatabase
with MotionDatabase.open(sys.argv[1]) as db:
    t2 = time.perf_counter()
    result, _ = db.query_clip(sys.argv[2], sys.argv[3], 3, progress=False)
    t3 = time.perf_counter()
stages = {"imports": t1 - t0, "open database": t2 - t1, "query": t3 - t2}
stages = {name: 1e3 * seconds for name, seconds in stages.items()}
stages.update({f"  query: {k}": v for k, v in result.timing_ms.items() if k != "total"})
print(json.dumps(stages))
"""


def wall_s(command: list[str]) -> float:
    t0 = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True, cwd=REPO)
    seconds = time.perf_counter() - t0
    if done.returncode:
        raise SystemExit(f"{' '.join(command)} failed:\n{done.stderr}")
    return seconds


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--db", default=str(REPO / "database" / "eigmotion.fs"))
    parser.add_argument("--clip", type=Path, default=SAMPLES / "walk_3s.mp4")
    parser.add_argument("--background", type=Path, default=SAMPLES / "walk_3s_background.png")
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    query = ["query", str(args.clip), "--background", str(args.background)]
    query += ["--db", args.db, "--json"]
    ours = [sys.executable, "-m", "eigmotion", *query]
    previous_code = "".join(f"import {name}\n" for name in PREVIOUS_TOP_IMPORTS) + _RUN_MAIN
    previous = [sys.executable, "-c", previous_code, *query]
    wall_s(ours)  # the numba cache and the OS file cache filled: every run below is "cold"
    times: dict[str, list[float]] = {"ours": [], "previous": [], "python + numpy": []}
    stages: list[dict] = []
    for _ in range(args.repeat):
        times["ours"].append(wall_s(ours))
        times["previous"].append(wall_s(previous))
        times["python + numpy"].append(wall_s([sys.executable, "-c", "import numpy"]))
        staged = [sys.executable, "-c", _STAGES, args.db, str(args.clip), str(args.background)]
        out = subprocess.run(staged, capture_output=True, text=True, cwd=REPO, check=True)
        stages.append(json.loads(out.stdout))
    median = {name: statistics.median(values) for name, values in times.items()}
    print(f"cold `eigmotion {' '.join(query)}`, median of {args.repeat} runs (wall ms):")
    print("| start-up path | wall ms | runs |\n| --- | --- | --- |")
    for name, values in times.items():
        runs = " ".join(f"{1e3 * v:.0f}" for v in values)
        print(f"| {name} | {1e3 * median[name]:.0f} | {runs} |")
    print(f"previous / ours: {median['previous'] / median['ours']:.2f}×")
    print("\nwhere a cold query's time goes (median ms, one process per run):")
    for name in stages[0]:
        print(f"  {name:<28} {statistics.median(s[name] for s in stages):8.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
