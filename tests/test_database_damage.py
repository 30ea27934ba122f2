"""Damaged, empty, foreign and crafted database files, on real ZODB files (and a real ZEO
server): reported in one line, never rewritten, never run; ``eigmotion check`` and
``eigmotion repair``; SIGKILL during ``index`` and ``build``."""

from __future__ import annotations

import os
import pickle
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import ZODB
from ZODB.Connection import TransactionMetaData
from ZODB.FileStorage import FileStorage

from eigmotion.cli.main import main
from eigmotion.errors import DatabaseError
from eigmotion.retrieval import storage as storage_module
from eigmotion.retrieval.database import MotionDatabase
from eigmotion.retrieval.library_views import BuildConfig
from eigmotion.retrieval.store import Store

REPO = Path(__file__).resolve().parents[1]
MOTIONS = ("walk_02_01", "kick_135_04", "wave_14_24", "pick_up_02_06_a")
CONFIG = BuildConfig(
    n_components=16, key_axes=3, key_sections=6, garments=((),), body_shapes=((None, 1.0),)
)
AUTHORED = REPO / "database" / "motions" / "authored" / "cover_head_crouching.bvh"


@pytest.fixture(scope="module")
def db_path(ring6_database):
    return ring6_database(MOTIONS, CONFIG)


def folder_state(folder: Path) -> dict[str, bytes]:
    """Every file in ``folder`` and its bytes."""
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file()}


def answers(path) -> tuple[np.ndarray, list[str]]:
    """The database's answers to every 5th stored point: the distances of the 3 nearest
    entries and the motion of the nearest."""
    with MotionDatabase.open(path) as db:
        db.store.check()
        queries = db.store.arrays().points[::5]
        found = db.index.search(queries, top_k=3)
        names = [
            db.motion_record(db._motion_of[int(i)])["metadata"]["name"] for i in found.ids[:, 0]
        ]
        return found.distances, names


def one_line(capsys) -> str:
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


def test_a_database_cut_at_its_end_is_reported_left_as_it_is_and_repaired(
    db_path, tmp_path, capsys
):
    expected = answers(db_path)
    data = db_path.read_bytes()
    for cut in (1, 20_000, len(data) // 3):
        folder = tmp_path / f"cut{cut}"
        folder.mkdir()
        work = folder / "db.fs"
        work.write_bytes(data[:-cut])
        before = folder_state(folder)
        assert main(["index", str(AUTHORED), "--label", "x", "--db", str(work)]) == 2
        line = one_line(capsys)
        assert "damaged at its end" in line and "eigmotion repair" in line
        with pytest.raises(DatabaseError):
            MotionDatabase.open(work, read_only=False)
        assert main(["check", str(work)]) == 1
        report = capsys.readouterr().out
        assert "damaged at its end" in report and "motions intact" in report
        out = tmp_path / f"repaired{cut}.fs"
        assert main(["repair", str(work), "--out", str(out)]) == 0
        capsys.readouterr()
        assert folder_state(folder) == before  # nothing written beside or into it
        assert main(["check", str(out)]) == 0
        capsys.readouterr()
        with MotionDatabase.open(out) as db:
            kept = db.store.n_motions
        if cut == 1:  # only the packed columns were cut: every motion is recovered
            assert kept == len(MOTIONS)
            got = answers(out)
            assert np.array_equal(got[0], expected[0]) and got[1] == expected[1]
        else:  # each motion was its own transaction: those before the cut are whole
            assert 1 <= kept <= len(MOTIONS)
            answers(out)


def test_a_database_damaged_in_its_middle_is_refused_and_repaired_without_that_motion(
    db_path, tmp_path, capsys
):
    data = bytearray(db_path.read_bytes())
    # the BVH text of the second motion: its pickled length made impossible
    at = data.find(b"HIERARCHY", data.find(b"HIERARCHY") + 1)
    data[at - 4 : at] = b"\xff\xff\xff\x7f"
    work = tmp_path / "db.fs"
    work.write_bytes(bytes(data))
    before = folder_state(tmp_path)
    assert main(["index", str(AUTHORED), "--label", "x", "--db", str(work)]) == 2
    assert "damaged" in one_line(capsys)
    assert main(["check", str(work)]) == 1
    assert f"{len(MOTIONS) - 1} of {len(MOTIONS)} motions intact" in capsys.readouterr().out
    assert folder_state(tmp_path) == before
    assert main(["repair", str(work), "--out", str(tmp_path / "new.fs")]) == 0
    with MotionDatabase.open(tmp_path / "new.fs") as db:
        assert db.store.n_motions == len(MOTIONS) - 1
    answers(tmp_path / "new.fs")


def _eigmotion(*args, **kwargs):
    return subprocess.run(
        [sys.executable, "-m", "eigmotion", *args],
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, "PYOPENGL_PLATFORM": "egl"},
        **kwargs,
    )


def test_a_damaged_index_file_is_ignored_by_readers_and_refused_by_writers(db_path, tmp_path):
    work = tmp_path / "db.fs"
    work.write_bytes(db_path.read_bytes())
    index = Path(f"{db_path}.index").read_bytes()
    Path(f"{work}.index").write_bytes(index[: len(index) // 2])
    before = folder_state(tmp_path)
    checked = _eigmotion("check", str(work))
    assert checked.returncode == 1 and checked.stderr == "", checked.stderr  # no ZODB log
    assert "index" in checked.stdout and "damaged" in checked.stdout
    got, expected = answers(work), answers(db_path)
    assert np.array_equal(got[0], expected[0]) and got[1] == expected[1]
    refused = _eigmotion("index", str(AUTHORED), "--label", "x", "--db", str(work), "--quiet")
    lines = refused.stderr.strip().splitlines()
    assert refused.returncode == 2 and len(lines) == 1 and ".index is damaged" in lines[0]
    assert folder_state(tmp_path) == before


class _Marker:
    """Pickles as a call of ``open(path, "w")``: were it unpickled, the file would exist."""

    def __init__(self, path):
        self.path = str(path)

    def __reduce__(self):
        return (open, (self.path, "w"))


def _crafted_database(path: Path, marker: Path, where: str) -> None:
    """A FileStorage file whose root record would call ``open(marker, "w")``: in its
    state, or as its class; or whose index would."""
    db = ZODB.DB(FileStorage(str(path)))
    db.close()
    if where == "index":  # ZODB unpickles DB.fs.index with no class hook at all
        Path(f"{path}.index").write_bytes(pickle.dumps(_Marker(marker), 3))
        return
    storage = FileStorage(str(path))
    root_oid = b"\0" * 8
    _, serial = storage.load(root_oid)
    if where == "state":
        record = pickle.dumps((("persistent.mapping", "PersistentMapping"), None), 3)
        record += pickle.dumps({"data": {"schema_version": _Marker(marker)}}, 3)
    else:
        record = pickle.dumps(((_Marker(marker), "x"), None), 3) + pickle.dumps({}, 3)
    txn = TransactionMetaData()
    storage.tpc_begin(txn)
    storage.store(root_oid, serial, record, "", txn)
    storage.tpc_vote(txn)
    storage.tpc_finish(txn)
    storage.close()
    for suffix in (".lock", ".tmp"):
        Path(f"{path}{suffix}").unlink(missing_ok=True)


@pytest.mark.parametrize("where", ["state", "class", "index"])
def test_a_crafted_database_is_refused_and_its_code_never_runs(tmp_path, where):
    evil = tmp_path / "evil.fs"
    marker = tmp_path / "ran"
    _crafted_database(evil, marker, where)
    assert not marker.exists()
    clip = tmp_path / "clip.npz"
    np.savez(clip, masks=np.zeros((10, 32, 32), bool), fps=30.0)
    for argv in (
        ["query", str(clip), "--db", str(evil)],
        ["index", str(AUTHORED), "--label", "x", "--db", str(evil)],
    ):
        done = _eigmotion(*argv)
        lines = done.stderr.strip().splitlines()
        assert done.returncode == 2 and len(lines) == 1, done.stderr
        assert "refused unread" in lines[0], lines[0]
        assert not marker.exists()
    done = _eigmotion("check", str(evil))
    assert done.returncode in (1, 2) and "Traceback" not in done.stderr
    assert "refused unread" in done.stdout + done.stderr
    assert not marker.exists()


def test_a_crafted_zeo_server_is_refused_and_its_code_never_runs(tmp_path):
    import ZEO

    evil = tmp_path / "evil.fs"
    marker = tmp_path / "ran"
    _crafted_database(evil, marker, "state")
    address, stop = ZEO.server(path=str(evil), port=0)
    try:
        uri = f"zeo://{address[0]}:{address[1]}"
        with pytest.raises(DatabaseError, match="refused unread"):
            Store.open(uri)
        assert not marker.exists()
    finally:
        stop()


@pytest.mark.parametrize(
    "content, message",
    [
        (b"", "empty file"),
        (b"hello, not a database\n" * 10, "not a ZODB FileStorage"),
        (None, "not an eigmotion database"),
    ],
)
def test_an_empty_or_foreign_file_is_refused_and_left_alone(tmp_path, capsys, content, message):
    work = tmp_path / "db.fs"
    if content is None:  # a ZODB file of some other program
        db = ZODB.DB(FileStorage(str(work)))
        with db.transaction() as conn:
            conn.root()["orders"] = 12
        db.close()
        for suffix in (".lock", ".tmp"):
            Path(f"{work}{suffix}").unlink(missing_ok=True)
        content = work.read_bytes()
        Path(f"{work}.index").unlink()
    work.write_bytes(content)
    for argv in (["index", str(AUTHORED), "--label", "x", "--db", str(work)],):
        assert main(argv) == 2
        assert message in one_line(capsys)
    assert folder_state(tmp_path) == {"db.fs": content}  # no lock, tmp, index or tr0


def _rewrite_root(path: Path, change) -> None:
    db = ZODB.DB(FileStorage(str(path)))
    with db.transaction() as conn:
        change(conn.root())
    db.close()


@pytest.mark.parametrize(
    "change",
    [
        lambda root: root.__delitem__("columns"),
        lambda root: root["columns"][0].__setitem__("ids", root["columns"][0]["ids"][:-3]),
        lambda root: root["columns"][0].__setitem__(
            "ids", (-1).to_bytes(8, "little", signed=True) + root["columns"][0]["ids"][8:]
        ),
        lambda root: root.__delitem__("eigenspace"),
    ],
    ids=["missing table", "odd packed column", "negative entry id", "missing eigenspace"],
)
def test_a_database_missing_tables_or_with_odd_columns_is_one_line(
    db_path, tmp_path, capsys, change
):
    work = tmp_path / "db.fs"
    work.write_bytes(db_path.read_bytes())
    _rewrite_root(work, change)
    before = folder_state(tmp_path)
    assert main(["index", str(AUTHORED), "--label", "x", "--db", str(work)]) == 2
    assert "db.fs" in one_line(capsys)
    assert folder_state(tmp_path) == before


@pytest.mark.parametrize("port", ["notaport", "70000", "0"])
def test_a_bad_zeo_port_is_one_line(tmp_path, capsys, port):
    assert main(["index", str(AUTHORED), "--label", "x", "--db", f"zeo://127.0.0.1:{port}"]) == 2
    assert "port" in one_line(capsys)


def test_build_finds_an_unreachable_zeo_server_before_rendering(monkeypatch, capsys):
    import socket

    monkeypatch.setattr(storage_module, "ZEO_WAIT_S", 0.5)
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    t0 = time.perf_counter()
    assert main(["build", "--db", f"zeo://127.0.0.1:{port}", "--quiet"]) == 2
    assert time.perf_counter() - t0 < 30  # rendering the library takes minutes
    assert "no ZEO server" in one_line(capsys)


def test_index_refuses_a_one_frame_motion_and_an_old_name_and_leaves_no_lock(
    db_path, tmp_path, capsys
):
    work = tmp_path / "db.fs"
    work.write_bytes(db_path.read_bytes())
    one = tmp_path / "one.bvh"
    assert main(["convert", str(AUTHORED), str(one), "--stop", "1"]) == 0
    capsys.readouterr()
    before = folder_state(tmp_path)
    assert main(["index", str(one), "--label", "x", "--db", str(work), "--quiet"]) == 2
    assert "no motion image" in one_line(capsys)
    assert folder_state(tmp_path) == before
    argv = ["index", str(AUTHORED), "--label", "cover", "--db", str(work), "--quiet"]
    assert main(argv) == 0
    capsys.readouterr()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["db.fs", "db.fs.index", "one.bvh"]
    assert main(argv) == 2
    assert "--name" in one_line(capsys)
    with MotionDatabase.open(work) as db:
        assert db.store.n_motions == len(MOTIONS) + 1


def _popen(*args):
    return subprocess.Popen(
        [sys.executable, "-m", "eigmotion", *args],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        env={**os.environ, "PYOPENGL_PLATFORM": "egl"},
    )


def _killed_at(args, delay_s: float) -> None:
    proc = _popen(*args)
    time.sleep(delay_s)
    proc.send_signal(signal.SIGKILL)
    proc.wait()


def test_sigkill_during_index_and_build_keeps_the_database(db_path, tmp_path):
    """Three seeded random moments each, in a real ``index`` and a real ``build``."""
    work = tmp_path / "db.fs"
    work.write_bytes(db_path.read_bytes())
    expected = answers(work)
    draw = random.Random(42)
    for delay_s in sorted(draw.uniform(0.5, 8.0) for _ in range(3)):
        _killed_at(["index", str(AUTHORED), "--label", "x", "--db", str(work), "--quiet"], delay_s)
        with MotionDatabase.open(work) as db:
            n_motions = db.store.n_motions
        got = answers(work)
        if n_motions == len(MOTIONS):
            assert np.array_equal(got[0], expected[0]) and got[1] == expected[1]
        else:  # committed before the kill: whole, never half
            assert n_motions == len(MOTIONS) + 1
            break
    manifest = tmp_path / "library.toml"
    manifest.write_text(
        "[[motion]]\n"
        f'name = "cover"\nlabel = "cover_head"\nsource = "{AUTHORED}"\n'
        'performer = "authored"\nvariation = "-"\nlicence = "-"\nattribution = "-"\n'
        "[[motion]]\n"
        f'name = "walk"\nlabel = "walk"\nsource = ["{REPO}/database/motions/cmu/amc/02_01.amc",'
        f' "{REPO}/database/motions/cmu/asf/02.asf"]\nframe_range = [0, 120]\n'
        'performer = "cmu_02"\nvariation = "-"\nlicence = "-"\nattribution = "-"\n'
    )
    built = tmp_path / "built.fs"
    build = ["build", "--motions", str(manifest), "--rig", str(REPO / "virtual_cameras/ring6.toml")]
    build += ["--db", str(built), "--workers", "1", "--components", "8", "--quiet"]
    assert _eigmotion(*build).returncode == 0
    expected = answers(built)
    for delay_s in sorted(draw.uniform(1.0, 12.0) for _ in range(3)):
        _killed_at(build, delay_s)
        got = answers(built)  # the old one, or the new one complete: the same answers
        assert np.array_equal(got[0], expected[0]) and got[1] == expected[1]
