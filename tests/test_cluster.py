"""Builds rendered on a real Dask distributed cluster: a ``dask scheduler`` and two
``dask worker`` processes on 127.0.0.1, started and stopped here, store what a local
build stores, to the last bit.

Needs the ``cluster`` extra (``pip install -e '.[cluster]'``); skipped without it, except
in CI (``CI`` set), where a missing extra fails.
"""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
import ZODB
import ZODB.FileStorage

from eigmotion.cli.main import main
from eigmotion.imaging.cameras import load_rig
from eigmotion.mocap.library import load_library
from eigmotion.retrieval.build import build_database
from eigmotion.retrieval.library_views import BuildConfig, render_views

if os.environ.get("CI"):
    import distributed  # noqa: F401  (CI installs the cluster extra: no skipping there)
else:
    pytest.importorskip("distributed", reason="the cluster extra is not installed")

REPO = Path(__file__).resolve().parents[1]
RIG = REPO / "virtual_cameras" / "ring6.toml"
#: The motions and configuration of tests/test_database.py: its local build is shared.
MOTIONS = ("walk_02_01", "kick_135_04", "wave_14_24", "pick_up_02_06_a")
CONFIG = BuildConfig(
    n_components=16, key_axes=3, key_sections=6, garments=((),), body_shapes=((None, 1.0),)
)


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def _stop(processes: list[subprocess.Popen]) -> None:
    for process in reversed(processes):
        if process.poll() is None:
            process.terminate()
    for process in reversed(processes):
        try:
            process.wait(timeout=20)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    """The address of a running local cluster: one scheduler, two one-thread workers that
    import this checkout's eigmotion."""
    from distributed import Client

    logs = tmp_path_factory.mktemp("dask")
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")])),
    }
    address = f"tcp://127.0.0.1:{_free_port()}"
    dask = [sys.executable, "-m", "dask"]
    processes = []

    def start(name: str, *args: str) -> None:
        log = open(logs / f"{name}.log", "w")  # noqa: SIM115  (closed with the process)
        processes.append(
            subprocess.Popen(
                [*dask, *args],
                env=env,
                cwd=logs,
                stdout=log,
                stderr=subprocess.STDOUT,
                stdin=subprocess.DEVNULL,
            )
        )
        log.close()

    try:
        port = address.rsplit(":", 1)[1]
        start("scheduler", "scheduler", "--host", "127.0.0.1", "--port", port, "--no-dashboard")
        for i in range(2):
            start(
                f"worker{i}",
                "worker",
                address,
                "--nthreads",
                "1",
                "--host",
                "127.0.0.1",
                "--no-dashboard",
                "--local-directory",
                str(logs / f"worker{i}"),
            )
        deadline = time.monotonic() + 120
        while True:
            try:
                with Client(address, timeout=5, set_as_default=False) as client:
                    client.wait_for_workers(2, timeout=max(1, deadline - time.monotonic()))
                break
            except OSError:
                dead = [p.args[3] for p in processes if p.poll() is not None]
                if dead or time.monotonic() > deadline:
                    raise RuntimeError(
                        f"the local Dask cluster did not start ({dead} exited); logs in {logs}"
                    ) from None
        yield address
    finally:
        _stop(processes)


def _stored(path: Path) -> dict:
    """The ZODB root of a database as plain values: mappings and B-trees as dicts, tree
    sets as lists (any other stored object compares by identity, so never equal)."""

    def plain(value):
        if hasattr(value, "items"):
            return {key: plain(item) for key, item in value.items()}
        if hasattr(value, "keys"):
            return list(value.keys())
        if isinstance(value, list | tuple):
            return [plain(item) for item in value]
        return value

    db = ZODB.DB(ZODB.FileStorage.FileStorage(str(path), read_only=True))
    try:
        connection = db.open()
        root = connection.root()
        stored = {key: plain(root[key]) for key in root.keys()}
        connection.close()
        return stored
    finally:
        db.close()


def test_stored_contents_compare_every_stored_value(ring6_database, tmp_path):
    """The comparison below sees a difference of one stored number."""
    path = tmp_path / "copy.fs"
    shutil.copy(ring6_database(MOTIONS, CONFIG), path)
    before = _stored(path)
    db = ZODB.DB(ZODB.FileStorage.FileStorage(str(path)))
    with db.transaction() as connection:
        root = connection.root()
        key = next(k for k in root.keys() if hasattr(root[k], "items"))
        root[key]["__changed__"] = 1
    db.close()
    assert _stored(path) != before


def test_a_cluster_build_stores_what_a_local_build_stores(cluster, ring6_database, tmp_path):
    local = ring6_database(MOTIONS, CONFIG)  # two local processes
    by_name = {m.name: m for m in load_library()}
    library = [by_name[name] for name in MOTIONS]
    rig = load_rig(RIG)
    views = render_views(library, rig, CONFIG, progress=False, scheduler=cluster)
    remote = tmp_path / "cluster.fs"
    report = build_database(library, rig, remote, CONFIG, progress=False, views=views)
    assert report.n_entries > 6 * len(MOTIONS)
    assert _stored(remote) == _stored(local)


def test_index_on_the_cluster_stores_what_a_local_index_stores(cluster, ring6_database, tmp_path):
    source = ring6_database(MOTIONS, CONFIG)
    motion = REPO / "database" / "motions" / "authored" / "fall_down_backwards.bvh"
    paths = {}
    for where in ("local", "cluster"):
        paths[where] = tmp_path / f"{where}.fs"
        shutil.copy(source, paths[where])
        argv = ["index", str(motion), "--label", "extra", "--name", "extra"]
        argv += ["--db", str(paths[where]), "--quiet"]
        if where == "cluster":
            argv += ["--scheduler", cluster]
        assert main(argv) == 0
    assert _stored(paths["cluster"]) == _stored(paths["local"]) != _stored(source)


def test_an_unreachable_scheduler_is_one_line_before_any_rendering(tmp_path, capsys):
    address = f"tcp://127.0.0.1:{_free_port()}"  # nothing listens there
    db = tmp_path / "never.fs"
    argv = ["build", "--rig", str(RIG), "--db", str(db), "--scheduler", address]
    t0 = time.perf_counter()
    assert main(argv) == 2
    seconds = time.perf_counter() - t0
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and address in err and "Dask scheduler" in err, err
    assert "rendering" not in err and "Traceback" not in err
    assert not db.exists() and seconds < 60
