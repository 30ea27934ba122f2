"""Warm query time of this code beside a previous revision's, in the same run.

Runs ``walk_3s.mp4`` (or ``--clip``) in process, with its background image and without,
``--repeat`` times after one query to warm the caches, in one process for this
package and one for the package as it was at ``--previous`` (taken out of the
repository into a temporary folder), alternating ``--rounds`` times; prints the
medians of each query's wall time, the process's CPU time (every thread; it moves less
than the wall time on a busy machine) and the query's stages (``timing_ms``), ours
beside the previous revision's, with the ratio previous / ours.

    python benchmarks/speed/bench_query_previous.py [--db database/eigmotion.fs] \\
        [--previous f762e63] [--repeat 7] [--rounds 3]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_cold_query import PREVIOUS_REVISION, REPO, SAMPLES, previous_package  # noqa: E402

_WARM = """
import json, statistics, sys, time
from eigmotion.retrieval.database import MotionDatabase
db_path, clip, background, repeat = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
out = {}
with MotionDatabase.open(db_path) as db:
    for name, bg in (("with background", background), ("without background", None)):
        db.query_clip(clip, bg, 3, progress=False)
        runs = []
        for _ in range(repeat):
            wall, cpu = time.perf_counter(), time.process_time()
            result, _ = db.query_clip(clip, bg, 3, progress=False)
            run = {"wall": time.perf_counter() - wall, "CPU": time.process_time() - cpu}
            run = {key: 1e3 * seconds for key, seconds in run.items()}
            run.update({f"  {k}": v for k, v in result.timing_ms.items() if k != "total"})
            runs.append(run)
        out[name] = {key: statistics.median(r[key] for r in runs) for key in runs[0]}
        out[name]["answer"] = result.best.label
print(json.dumps(out))
"""


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--db", default=str(REPO / "database" / "eigmotion.fs"))
    parser.add_argument("--clip", type=Path, default=SAMPLES / "walk_3s.mp4")
    parser.add_argument("--background", type=Path, default=SAMPLES / "walk_3s_background.png")
    parser.add_argument("--previous", default=PREVIOUS_REVISION, help="git revision")
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    given = (Path(args.db).resolve(), args.clip.resolve(), args.background.resolve())
    command = [sys.executable, "-c", _WARM, *map(str, given)]
    command.append(str(args.repeat))
    results: dict[str, list[dict]] = {"ours": [], "previous": []}
    with tempfile.TemporaryDirectory(prefix="eigmotion-previous-") as tmp:
        copies = {"ours": REPO, "previous": previous_package(args.previous, Path(tmp))}
        load_before = os.getloadavg()
        for _ in range(args.rounds):
            for name, path in copies.items():
                # run in the copy's folder: ``-c`` imports the package found there first
                env = dict(os.environ, PYTHONPATH=str(path))
                done = subprocess.run(
                    command, capture_output=True, text=True, cwd=path, env=env, check=True
                )
                results[name].append(json.loads(done.stdout.splitlines()[-1]))
        load_after = os.getloadavg()
    print(f"warm queries of {args.clip.name}, medians of {args.repeat} per round, ms;")
    print(f"the median of {args.rounds} rounds; previous = {args.previous}")
    print(f"load average before {load_before[0]:.2f}, after {load_after[0]:.2f} (1 min)")
    for mode in results["ours"][0]:
        print(f"{mode}:\n  {'':<22} {'ours':>8} {'previous':>9} {'ratio':>6}")
        for key in results["ours"][0][mode]:
            if key == "answer":
                answers = [results[n][0][mode]["answer"] for n in ("ours", "previous")]
                print(f"  {'answer':<22} {answers[0]:>8} {answers[1]:>9}")
                continue
            ours = statistics.median(r[mode][key] for r in results["ours"])
            previous = statistics.median(r[mode][key] for r in results["previous"])
            print(f"  {key:<22} {ours:8.1f} {previous:9.1f} {previous / ours:6.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
