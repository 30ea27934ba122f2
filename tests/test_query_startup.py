"""The start-up of an ``eigmotion query`` process: what it sets before NumPy loads."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

#: Runs the ``eigmotion`` command (:func:`~eigmotion.cli.main.entry`) on ``--help`` of a
#: command in a fresh process, then prints how many threads the BLAS library NumPy
#: loaded will use.
_BLAS_THREADS_AFTER = """
import json, sys
from eigmotion.cli.main import entry
sys.argv = ["eigmotion", sys.argv[1], "--help"]
try:
    entry()
except SystemExit:
    pass
import numpy
from threadpoolctl import threadpool_info
print(json.dumps([p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"]))
"""

#: What tells OpenBLAS how many threads to start, besides the command.
_THREAD_SETTINGS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "GOTO_NUM_THREADS")


def _blas_threads(command: str, **env: str) -> list[int]:
    environ = {k: v for k, v in os.environ.items() if k not in _THREAD_SETTINGS}
    environ.update(env, PYTHONPATH=str(REPO))
    done = subprocess.run(
        [sys.executable, "-c", _BLAS_THREADS_AFTER, command],
        capture_output=True, text=True, env=environ, check=True,
    )  # fmt: skip
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_a_query_keeps_blas_on_the_calling_thread_unless_the_user_says_otherwise():
    assert set(_blas_threads("query")) == {1}
    assert set(_blas_threads("query", OPENBLAS_NUM_THREADS="2")) == {2}


@pytest.mark.skipif((os.cpu_count() or 1) < 2, reason="one core: BLAS has one thread anyway")
def test_other_commands_leave_blas_its_threads():
    assert max(_blas_threads("build")) > 1


def test_main_called_in_a_process_leaves_its_environment_alone():
    from eigmotion.cli.main import main

    before = os.environ.get("OPENBLAS_NUM_THREADS")
    with pytest.raises(SystemExit):
        main(["query", "--help"])
    assert os.environ.get("OPENBLAS_NUM_THREADS") == before


#: Runs the ``eigmotion`` command on ``query … --help`` with the arguments given, then
#: prints whether the colour-table thread was started (and waits for it).
_COLOUR_TABLES_STARTED = """
import json, sys, threading
from eigmotion.cli.main import entry
started, start = [], threading.Thread.start
def noted(thread):
    started.append(thread)
    start(thread)
threading.Thread.start = noted
sys.argv = ["eigmotion", "query", *sys.argv[1:], "--help"]
try:
    entry()
except SystemExit:
    pass
tables = [t for t in started if t.name == "colour tables"]
for thread in tables:
    thread.join()
print(json.dumps(bool(tables)))
"""


@pytest.mark.parametrize(
    ("arguments", "started"),
    [
        (["clip.mp4", "--background", "empty.png"], True),
        (["clip.mp4", "--background=empty.png"], True),
        (["clip.mp4", "--segmenter", "subtraction"], True),
        (["clip.mp4", "--segmenter=subtraction"], True),
        (["clip.mp4"], False),
        (["clip.mp4", "--segmenter", "learned"], False),
    ],
)
def test_a_query_that_compares_colours_builds_the_colour_tables_while_it_loads(arguments, started):
    done = subprocess.run(
        [sys.executable, "-c", _COLOUR_TABLES_STARTED, *arguments],
        capture_output=True, text=True, env={**os.environ, "PYTHONPATH": str(REPO)}, check=True,
    )  # fmt: skip
    assert json.loads(done.stdout.strip().splitlines()[-1]) is started
