"""Build time on a Dask cluster with 1, 2, … workers, beside the local process pool.

Starts a ``dask scheduler`` and N ``dask worker`` processes (one thread each) on
127.0.0.1 for each N of ``--workers``, builds the first ``--motions`` motions of the
bundled library on ``--rig`` with the default build configuration (every outfit),
rendered on that cluster, and times the whole build; then the same build with the local
process pool of ``--local-workers`` processes.  Every cluster-built database is checked
to store the same keys and entries as the local one (exit 1 otherwise).  Needs the
``cluster`` extra.

    python benchmarks/speed/bench_cluster_build.py --motions 40 --workers 1 2
"""

from __future__ import annotations

import argparse
import os
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from eigmotion.imaging.cameras import load_rig
from eigmotion.mocap.library import load_library
from eigmotion.retrieval.build import build_database
from eigmotion.retrieval.database import MotionDatabase
from eigmotion.retrieval.library_views import BuildConfig, render_views

REPO = Path(__file__).resolve().parents[2]


def start_cluster(n_workers: int, folder: Path) -> tuple[str, list[subprocess.Popen]]:
    """A local scheduler and ``n_workers`` one-thread workers; their address and processes."""
    from distributed import Client

    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")])),
    }
    dask = [sys.executable, "-m", "dask"]
    commands = [[*dask, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"]]
    commands += [
        [*dask, "worker", address, "--nthreads", "1", "--host", "127.0.0.1", "--no-dashboard"]
        + ["--local-directory", str(folder / f"worker{i}")]
        for i in range(n_workers)
    ]
    processes = []
    for i, command in enumerate(commands):
        with open(folder / f"process{i}.log", "w") as log:
            processes.append(subprocess.Popen(command, env=env, cwd=folder, stdout=log, stderr=log))
    deadline = time.monotonic() + 120
    while True:
        try:
            with Client(address, timeout=5, set_as_default=False) as client:
                client.wait_for_workers(n_workers, timeout=max(1, deadline - time.monotonic()))
            return address, processes
        except OSError:
            if time.monotonic() > deadline:
                stop(processes)
                raise


def stop(processes: list[subprocess.Popen]) -> None:
    for process in reversed(processes):
        process.terminate()
    for process in reversed(processes):
        process.wait(timeout=30)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--motions", type=int, default=40, help="first N library motions")
    parser.add_argument("--rig", type=Path, default=REPO / "virtual_cameras" / "ring6.toml")
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--local-workers", type=int, default=2)
    args = parser.parse_args()
    library = load_library()[: args.motions]
    rig = load_rig(args.rig)
    config = BuildConfig()
    n_views = len(library) * len(config.bodies) * len(rig)
    print(f"{len(library)} motions × {len(config.bodies)} bodies × {len(rig)} views = {n_views}")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        t0 = time.perf_counter()
        local = folder / "local.fs"
        build_database(library, rig, local, config, workers=args.local_workers, progress=True)
        rows.append(
            (f"local process pool, {args.local_workers} processes", time.perf_counter() - t0)
        )
        with MotionDatabase.open(local) as db:
            reference = db.store.arrays()
        same = True
        for n in args.workers:
            address, processes = start_cluster(n, folder)
            try:
                path = folder / f"cluster{n}.fs"
                t0 = time.perf_counter()
                views = render_views(library, rig, config, scheduler=address)
                build_database(library, rig, path, config, views=views)
                rows.append((f"Dask cluster, {n} worker(s) × 1 thread", time.perf_counter() - t0))
            finally:
                stop(processes)
            with MotionDatabase.open(path) as db:
                arrays = db.store.arrays()
            same &= all(
                np.array_equal(getattr(arrays, name), getattr(reference, name))
                for name in ("points", "ids", "motions")
            )
    print(f"\n| build of {n_views} views | wall s | views/s |\n| --- | --- | --- |")
    for name, seconds in rows:
        print(f"| {name} | {seconds:.1f} | {n_views / seconds:.1f} |")
    print("cluster databases equal to the local one:", same)
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
