"""The command line on fuzzed input files and options (see :mod:`cli_fuzz`): every
case exits 0 or 2 with at most 3 stderr lines, no traceback, bounded time and memory,
and a database a failed command was given is byte-identical afterwards."""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import cli_fuzz
import pytest
from cli_fuzz import COMMANDS, MAX_STDERR_LINES, campaign, make_case, stderr_lines

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def small_db(four_motion_database) -> Path:
    """A real database of four motions (the one tests/test_database.py builds)."""
    return four_motion_database


def test_in_process_cases(tmp_path, small_db):
    outcomes = campaign(120, seed=7, database=small_db, work=tmp_path)
    assert {o.case.command for o in outcomes} == set(COMMANDS)
    problems = [(o.case.command, o.case.argv, o.problems(), o.stderr[-300:])
                for o in outcomes if o.problems()]  # fmt: skip
    assert not problems


def _limit_memory():  # the subprocess may not map more than this
    resource.setrlimit(resource.RLIMIT_AS, (6 * 2**30, 6 * 2**30))


@pytest.mark.parametrize("index", range(12))
def test_subprocess_cases(tmp_path, small_db, index):
    """A sample through real processes: exit code, stderr lines, time and memory."""
    import random

    rng = random.Random(1000 + index)
    case = make_case(rng, COMMANDS[index % len(COMMANDS)])
    folder = tmp_path / "case"
    folder.mkdir()
    for name, data in case.files.items():
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_bytes(data)
    os.symlink("/dev/full", folder / "full.bvh")
    if case.db:
        (folder / "db.fs").write_bytes(small_db.read_bytes())
        before = cli_fuzz._hash(folder / "db.fs")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    start = time.perf_counter()
    proc = subprocess.Popen(
        [sys.executable, "-m", "eigmotion", case.command, *case.argv],
        cwd=folder, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
        preexec_fn=_limit_memory,
    )  # fmt: skip
    _, stderr = proc.communicate(timeout=cli_fuzz.MAX_SECONDS)
    seconds = time.perf_counter() - start
    assert proc.returncode in (0, 2), stderr
    assert "Traceback" not in stderr
    assert len(stderr_lines(stderr)) <= MAX_STDERR_LINES, stderr
    assert seconds < cli_fuzz.MAX_SECONDS
    if case.db and proc.returncode != 0:
        assert cli_fuzz._hash(folder / "db.fs") == before
