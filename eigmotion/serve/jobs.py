"""Queries as jobs in a pool of worker processes, each holding the database open.

A job is a folder under the server's working folder, named by a random id; its
``status.json`` (written by the worker, read by the server) says where it stands. The
workers are processes, not threads: a query is mostly Python and NumPy work that holds
the interpreter lock, and a ZODB connection serves one thread at a time, so each worker
opens the database once, read-only, and keeps it open for every job it runs.
"""

from __future__ import annotations

import json
import multiprocessing
import re
import secrets
import threading
import time
from concurrent.futures import Future, ProcessPoolExecutor, wait
from pathlib import Path

from eigmotion.errors import EigmotionError
from eigmotion.retrieval.database import MotionDatabase
from eigmotion.segmentation.networks import set_network_threads
from eigmotion.serve.answer import answer_clip, write_json

#: A job id: 32 lower-case hex digits.
JOB_ID = re.compile(r"[0-9a-f]{32}")

_worker_db: MotionDatabase | None = None


def _open_worker_database(db_path: str) -> None:
    """Pool initializer: open the database once per worker process (whose person
    networks run on one thread: the workers share the cores)."""
    global _worker_db
    set_network_threads(1)
    _worker_db = MotionDatabase.open(db_path)


def _worker_ready() -> bool:
    time.sleep(0.2)  # held a moment, so that every worker gets one of these
    return _worker_db is not None


def _run_job(job_dir: str, clip_name: str, background_name: str | None, top_k: int) -> None:
    """Run one job in a worker: answer the clip, keeping ``status.json`` up to date."""
    folder = Path(job_dir)
    started = time.monotonic()

    def report(progress: float, stage: str) -> None:
        write_json(folder / "status.json", {
            "state": "running", "progress": round(progress, 3), "stage": stage,
            "elapsed_s": round(time.monotonic() - started, 2),
        })  # fmt: skip

    report(0.0, "starting")
    clip = folder / clip_name
    background = folder / background_name if background_name else None
    try:
        answer_clip(_worker_db, clip, background, folder, report, top_k)
    except EigmotionError as exc:
        # the user knows the upload as "the clip", not by the name it was saved under
        message = str(exc).replace(str(clip), "the clip")
        if background is not None:
            message = message.replace(str(background), "the empty-scene image")
        status = {"state": "failed", "error": message}
    except Exception as exc:  # noqa: BLE001 - reported to the page, the server goes on
        status = {"state": "failed", "error": f"internal error: {type(exc).__name__}: {exc}"}
    else:
        status = {"state": "done", "progress": 1.0, "stage": "done"}
    status["elapsed_s"] = round(time.monotonic() - started, 2)
    write_json(folder / "status.json", status)


class JobPool:
    """Jobs run by ``workers`` processes that keep the database at ``db_path`` open.

    Parameters
    ----------
    db_path : str
        The database (a path or a ``zeo://`` URI), opened read-only by every worker.
    jobs_dir : Path
        Where the job folders are made (it exists).
    workers : int
        Worker processes (jobs answered at once; more wait in a queue).
    """

    def __init__(self, db_path: str, jobs_dir: Path, workers: int):
        self.jobs_dir = jobs_dir
        self.workers = workers
        context = multiprocessing.get_context("spawn")  # no forked GL or thread state
        self._executor = ProcessPoolExecutor(
            workers, mp_context=context, initializer=_open_worker_database, initargs=(db_path,)
        )
        self._futures: dict[str, Future] = {}
        self._lock = threading.Lock()

    def warm_up(self) -> None:
        """Start every worker and wait until each has opened the database (so that a
        database a worker cannot open is told at start, and the first query waits for
        no start-up)."""
        futures = [self._executor.submit(_worker_ready) for _ in range(self.workers)]
        for future in futures:
            future.result()

    def new_job(self) -> tuple[str, Path]:
        """A fresh job id and its (new, empty) folder."""
        job_id = secrets.token_hex(16)
        folder = self.jobs_dir / job_id
        folder.mkdir()
        return job_id, folder

    def submit(self, job_id: str, clip_name: str, background_name: str | None, top_k: int):
        """Queue a job whose uploads are saved in its folder."""
        folder = self.jobs_dir / job_id
        write_json(folder / "status.json", {"state": "queued", "progress": 0.0,
                                            "stage": "waiting for a free worker"})  # fmt: skip
        future = self._executor.submit(_run_job, str(folder), clip_name, background_name, top_k)
        with self._lock:
            self._futures[job_id] = future

    def folder(self, job_id: str) -> Path | None:
        """The folder of a known job, None for an id that is not one."""
        if not JOB_ID.fullmatch(job_id):
            return None
        folder = self.jobs_dir / job_id
        return folder if (folder / "status.json").is_file() else None

    def status(self, job_id: str) -> dict | None:
        """The job's status (``state``: queued, running, done or failed; ``progress``,
        ``stage``; ``error`` when failed; ``answer`` when done), None for an unknown id."""
        folder = self.folder(job_id)
        if folder is None:
            return None
        status = json.loads((folder / "status.json").read_text(encoding="utf-8"))
        with self._lock:
            future = self._futures.get(job_id)
        if future is not None and future.done() and future.exception() is not None:
            # the worker process itself died (killed, out of memory)
            status = {"state": "failed", "error": f"the worker stopped: {future.exception()}"}
        if status["state"] == "done":
            status["answer"] = json.loads((folder / "answer.json").read_text(encoding="utf-8"))
        status["id"] = job_id
        return status

    def close(self, exit_timeout_s: float = 30.0) -> None:
        """Stop the workers: jobs still queued are dropped, running ones get
        ``exit_timeout_s`` to finish; a worker not gone by then is terminated with the
        job it was running, so Ctrl-C stops the server within about ``exit_timeout_s``
        however long a job would take."""
        with self._lock:
            running = [future for future in self._futures.values() if future.running()]
        processes = list((getattr(self._executor, "_processes", None) or {}).values())
        self._executor.shutdown(wait=False, cancel_futures=True)
        deadline = time.monotonic() + exit_timeout_s
        wait(running, timeout=exit_timeout_s)
        for process in processes:
            process.join(max(0.0, deadline - time.monotonic()))
            if process.is_alive():
                process.terminate()
                process.join(5.0)
