"""Build time of the default configuration, ours beside the previous code's in one run.

Builds the first ``--motions`` motions of the bundled library on the default rig with
the default build configuration (every body in every outfit, ``--workers`` rendering
processes) into a temporary database, with this checkout's package and with the
package as it was at ``--previous`` (a git revision, by default the last one before
the build's camera fitting was solved in closed form), taken out of the repository
into a temporary folder beside links to this checkout's ``database/`` and
``virtual_cameras/``.  The two alternate, ``--repeat`` times each, each build a new
process.  Prints the median wall and CPU time (user + system, the rendering
processes included) of each, the ratio previous / ours, the machine's load average,
and whether the two databases store the same ids, keys, points and threshold (exit 1
if not).

    python benchmarks/speed/bench_build.py [--motions 12] [--workers 2] [--repeat 1]

The whole library takes ``eigmotion build`` itself; see docs/database.md.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_cold_query import REPO, previous_package, run_s  # noqa: E402

#: The last revision whose build fitted every camera by bisection.
PREVIOUS_REVISION = "9c622d5"

_BUILD = """
import json, sys
from eigmotion.imaging.cameras import load_rig
from eigmotion.mocap.library import load_library
from eigmotion.resources import default_rig
from eigmotion.retrieval.build import build_database
report = build_database(
    load_library()[: int(sys.argv[1])], load_rig(default_rig()), sys.argv[2],
    workers=int(sys.argv[3]), progress=False,
)
print(json.dumps({"entries": report.n_entries}))
"""

_COMPARE = """
import json, sys
import numpy as np
from eigmotion.retrieval.database import MotionDatabase
with MotionDatabase.open(sys.argv[1]) as a, MotionDatabase.open(sys.argv[2]) as b:
    x, y = a.store.arrays(), b.store.arrays()
    same = all(np.array_equal(getattr(x, f), getattr(y, f)) for f in ("ids", "keys", "points"))
    print(json.dumps({"same": bool(same and a.threshold == b.threshold)}))
"""


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--motions", type=int, default=12, help="first N library motions")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--previous", default=PREVIOUS_REVISION, help="git revision")
    args = parser.parse_args()
    if args.motions < 1 or args.workers < 1 or args.repeat < 1:
        parser.error("--motions, --workers and --repeat must be at least 1")
    os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
    wall: dict[str, list[float]] = {"ours": [], "previous": []}
    cpu: dict[str, list[float]] = {"ours": [], "previous": []}
    with tempfile.TemporaryDirectory(prefix="eigmotion-build-") as tmp:
        tmp = Path(tmp)
        previous = previous_package(args.previous, tmp / "previous")
        for shipped in ("database", "virtual_cameras"):
            (previous / shipped).symlink_to(REPO / shipped)
        copies = {"ours": REPO, "previous": previous}
        entries = {}
        for run in range(args.repeat):
            for name, path in copies.items():
                db = tmp / f"{name}.fs"
                for stale in tmp.glob(f"{name}.fs*"):
                    stale.unlink()
                command = [sys.executable, "-c", _BUILD, str(args.motions), str(db)]
                seconds, used, out = run_s([*command, str(args.workers)], path)
                wall[name].append(seconds)
                cpu[name].append(used)
                entries[name] = json.loads(out)["entries"]
                print(f"run {run + 1} {name:<8} {seconds:7.1f} s wall, {used:7.1f} s CPU")
        compare = [sys.executable, "-c", _COMPARE, str(tmp / "ours.fs"), str(tmp / "previous.fs")]
        same = json.loads(run_s(compare, REPO)[2])["same"]
    ours, before = statistics.median(wall["ours"]), statistics.median(wall["previous"])
    ours_cpu, before_cpu = statistics.median(cpu["ours"]), statistics.median(cpu["previous"])
    print(
        f"\nbuild of the first {args.motions} motions ({entries['ours']:,} entries), "
        f"{args.workers} workers, load average {os.getloadavg()[0]:.1f}"
    )
    print(f"  {'':<22} {'ours':>8} {'previous':>9} {'previous / ours':>16}")
    print(f"  {'wall s (median)':<22} {ours:8.1f} {before:9.1f} {before / ours:15.2f}×")
    ratio_cpu = before_cpu / ours_cpu
    print(f"  {'CPU s (median)':<22} {ours_cpu:8.1f} {before_cpu:9.1f} {ratio_cpu:15.2f}×")
    print(f"  previous = {args.previous}; same ids, keys, points and threshold: {same}")
    return 0 if same else 1


if __name__ == "__main__":
    raise SystemExit(main())
