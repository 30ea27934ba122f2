"""Cold start of ``eigmotion query``: a new process per run, as a user runs it.

Runs ``python -m eigmotion query CLIP --background IMAGE --db DB --json`` ``--repeat``
times, with the default front end (``--segmenter auto``) and with ``--segmenter
subtraction`` asked for explicitly (the figure that holds whatever ``auto`` picks), and
prints the median wall time beside the previous code's, measured in the same run,
interleaved run by run: the package as it was at ``--previous`` (a git revision, by
default the last one that built the search tree at every database open and walked it
for every query), taken out of the repository into a temporary folder.  The ratio is
previous / ours.  Both copies are byte-compiled first, as an installed package is.
Beside them, the floor: the interpreter with NumPy and OpenCV alone, with ZODB too,
and with NumPy and numba's first cached loop (what a compiled search costs a new
process).  Wall and CPU time (user + system, every thread) are printed: on a busy
machine the CPU time moves less.  Then, in one more process per run and copy, where
the time goes: the command's imports, opening the database, the query's own stages
(its ``timing_ms``), and whether numba was imported.  The machine's load average is
printed with the figures.

    python benchmarks/speed/bench_cold_query.py [--db database/eigmotion.fs] [--repeat 5]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from io import BytesIO
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
SAMPLES = REPO / "database" / "samples"

#: The last revision that built the search tree at every database open and walked it
#: (numba's compiled loop) for every query.
PREVIOUS_REVISION = "e463ba8"

_STAGES = """
import json, os, sys, time
import eigmotion.cli.main as command_line
if "query" in getattr(command_line, "ONE_BLAS_THREAD", ()):  # as the command sets it
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
t0 = time.perf_counter()
import eigmotion.cli.query
t1 = time.perf_counter()
from eigmotion.retrieval.database import MotionDatabase
with MotionDatabase.open(sys.argv[1]) as db:
    t2 = time.perf_counter()
    result, _ = db.query_clip(
        sys.argv[2], sys.argv[3], 3, progress=False, segmenter="subtraction"
    )
    t3 = time.perf_counter()
stages = {"imports": t1 - t0, "open database": t2 - t1, "query": t3 - t2}
stages = {name: 1e3 * seconds for name, seconds in stages.items()}
stages.update({f"  query: {k}": v for k, v in result.timing_ms.items() if k != "total"})
stages["numba imported (0/1)"] = float("numba" in sys.modules)
print(json.dumps(stages))
"""

FLOORS = {
    "python + numpy + cv2": "import numpy, cv2",
    "python + numpy + cv2 + ZODB": "import numpy, cv2, ZODB.FileStorage, BTrees.LOBTree",
    # what the tree search's compiled walk costs a new process before its first query
    "python + numpy + numba's first cached loop": (
        "import numpy as np\nfrom eigmotion.retrieval.neighbours import kernels\n"
        "kernels().pair_sq_distances(np.zeros((1, 1), np.float32), "
        "np.zeros((1, 1), np.float32), np.zeros(1, np.float32))"
    ),
}


def previous_package(revision: str, into: Path) -> Path:
    """The ``eigmotion`` package as it was at ``revision``, written under ``into``."""
    archive = subprocess.run(
        ["git", "archive", "--format=tar", revision, "eigmotion"],
        cwd=REPO, capture_output=True, check=True,
    ).stdout  # fmt: skip
    with tarfile.open(fileobj=BytesIO(archive)) as tar:
        tar.extractall(into, filter="data")
    return into


def _children_cpu_s() -> float:
    used = resource.getrusage(resource.RUSAGE_CHILDREN)
    return used.ru_utime + used.ru_stime


def run_s(command: list[str], path: Path) -> tuple[float, float, str]:
    """Wall and CPU seconds (user + system) of ``command`` run in ``path`` (so that
    ``-m`` and ``-c`` import the package found there) with it first on PYTHONPATH, and
    its stdout."""
    env = dict(os.environ, PYTHONPATH=str(path))
    cpu0, t0 = _children_cpu_s(), time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True, cwd=path, env=env)
    seconds, cpu = time.perf_counter() - t0, _children_cpu_s() - cpu0
    if done.returncode:
        raise SystemExit(f"{' '.join(command)} failed:\n{done.stderr}")
    return seconds, cpu, done.stdout


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--db", default=str(REPO / "database" / "eigmotion.fs"))
    parser.add_argument("--clip", type=Path, default=SAMPLES / "walk_3s.mp4")
    parser.add_argument("--background", type=Path, default=SAMPLES / "walk_3s_background.png")
    parser.add_argument("--previous", default=PREVIOUS_REVISION, help="git revision")
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    args.db, args.clip = str(Path(args.db).resolve()), args.clip.resolve()
    args.background = args.background.resolve()
    query = ["query", str(args.clip), "--background", str(args.background)]
    query += ["--db", args.db, "--json"]
    commands = {
        "": [sys.executable, "-m", "eigmotion", *query],
        ", --segmenter subtraction": [
            sys.executable, "-m", "eigmotion", *query, "--segmenter", "subtraction"
        ],
    }  # fmt: skip
    staged = [sys.executable, "-c", _STAGES, args.db, str(args.clip), str(args.background)]
    with tempfile.TemporaryDirectory(prefix="eigmotion-previous-") as tmp:
        copies = {"ours": REPO, "previous": previous_package(args.previous, Path(tmp))}
        for path in copies.values():
            compile_all = [sys.executable, "-m", "compileall", "-q", str(path / "eigmotion")]
            subprocess.run(compile_all, check=True, capture_output=True)
            for command in commands.values():  # numba's disk cache, the OS file cache
                run_s(command, path)
        load_before = os.getloadavg()
        runs = [
            (f"{name}{flag}", command, path)
            for flag, command in commands.items()
            for name, path in copies.items()
        ]
        runs += [(name, [sys.executable, "-c", code], REPO) for name, code in FLOORS.items()]
        times: dict[str, list[float]] = {name: [] for name, _, _ in runs}
        cpu: dict[str, list[float]] = {name: [] for name in times}
        stages: dict[str, list[dict]] = {name: [] for name in copies}
        for _ in range(args.repeat):
            for name, what, path in runs:
                wall, used, _ = run_s(what, path)
                times[name].append(wall)
                cpu[name].append(used)
            for name, path in copies.items():
                stages[name].append(json.loads(run_s(staged, path)[2]))
        load_after = os.getloadavg()
    median = {name: 1e3 * statistics.median(values) for name, values in times.items()}
    cpu_median = {name: 1e3 * statistics.median(values) for name, values in cpu.items()}
    print(f"cold `eigmotion {' '.join(query)}`, median of {args.repeat} runs")
    print(f"load average before {load_before[0]:.2f}, after {load_after[0]:.2f} (1 min)")
    print("| start-up path | wall ms | CPU ms (user + system) | wall ms of each run |")
    print("| --- | --- | --- | --- |")
    for name, values in times.items():
        each = " ".join(f"{1e3 * v:.0f}" for v in values)
        label = name.replace("previous", f"previous ({args.previous})")
        print(f"| {label} | {median[name]:.0f} | {cpu_median[name]:.0f} | {each} |")
    for flag in commands:
        ours, previous = f"ours{flag}", f"previous{flag}"
        print(
            f"previous / ours{flag}: {median[previous] / median[ours]:.2f}× wall, "
            f"{cpu_median[previous] / cpu_median[ours]:.2f}× CPU"
        )
    print("\nwhere a cold query's time goes, --segmenter subtraction (median ms):")
    print(f"  {'stage':<28} {'ours':>8} {'previous':>9} {'ratio':>6}")
    for stage in stages["ours"][0]:
        ours = statistics.median(s[stage] for s in stages["ours"])
        previous = statistics.median(s.get(stage, float("nan")) for s in stages["previous"])
        ratio = previous / ours if ours else float("nan")
        print(f"  {stage:<28} {ours:8.1f} {previous:9.1f} {ratio:6.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
