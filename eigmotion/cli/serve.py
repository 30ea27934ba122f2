"""``eigmotion serve``: the query as a web page on this machine, and its HTTP API.

Examples::

    eigmotion serve                                  # http://127.0.0.1:8000/
    eigmotion serve --db my.fs --port 8080 --workers 2 --work-dir /tmp/eigmotion-jobs

Open the address it prints in a browser, upload a clip (and, if you have one, an image
of the empty scene) and the page shows the answer, the parts of the clip on a timeline,
the side-by-side replay and the 3D motion; see docs/serve.md for the page and the API.
Uploads and answers are kept under the working folder (a new temporary folder, removed
at exit, unless ``--work-dir`` is given).  Ctrl-C or SIGTERM (``kill``, ``docker
stop``) stops the server.
"""

from __future__ import annotations

import argparse
import shutil
import signal
import tempfile
from pathlib import Path

from eigmotion.errors import InvalidParameterError
from eigmotion.retrieval.database import MotionDatabase
from eigmotion.retrieval.storage import DEFAULT_DB_PATH
from eigmotion.serve.jobs import JobPool
from eigmotion.serve.server import EigmotionServer


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--db", default=None, help="database (default database/eigmotion.fs)")
    parser.add_argument(
        "--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1: "
        "this machine only)"
    )  # fmt: skip
    parser.add_argument(
        "--port", type=int, default=8000, help="port (default 8000; 0: any free port)"
    )
    parser.add_argument(
        "--workers",
        type=int,
        default=2,
        help="queries answered at once, each by a process holding the database open "
        "(default 2); more wait in a queue",
    )
    parser.add_argument(
        "--work-dir",
        type=Path,
        help="folder for uploads and answers (made if missing; default a temporary "
        "folder removed at exit)",
    )
    parser.add_argument(
        "--max-upload-mb", type=float, default=200.0, help="largest upload, MB (default 200)"
    )


def _stop(signum, frame) -> None:
    """SIGTERM handler: stop as Ctrl-C does."""
    raise KeyboardInterrupt


def run(args: argparse.Namespace) -> int:
    if args.workers < 1:
        raise InvalidParameterError(f"--workers must be >= 1, got {args.workers}")
    if not 0 <= args.port <= 65535:
        raise InvalidParameterError(f"--port must be 0-65535, got {args.port}")
    if args.max_upload_mb <= 0:
        raise InvalidParameterError(f"--max-upload-mb must be > 0, got {args.max_upload_mb}")
    db_uri = str(args.db or DEFAULT_DB_PATH)
    if args.work_dir is not None and args.work_dir.exists() and not args.work_dir.is_dir():
        raise InvalidParameterError(f"--work-dir {args.work_dir} is not a folder")
    with MotionDatabase.open(db_uri) as db:  # a bad database is told before anything starts
        summary = f"{db.n_entries} entries of {len(db.store.motion_ids())} motions"
        temporary = args.work_dir is None
        work_dir = Path(tempfile.mkdtemp(prefix="eigmotion-serve-")) if temporary else (
            args.work_dir)  # fmt: skip
        jobs_dir = work_dir / "jobs"
        jobs_dir.mkdir(parents=True, exist_ok=True)
        pool = JobPool(db_uri, jobs_dir, args.workers)
        try:
            print(f"starting {args.workers} worker(s) on {db_uri} ({summary})...", flush=True)
            pool.warm_up()
            server = EigmotionServer(
                (args.host, args.port), pool, db_uri, int(args.max_upload_mb * 1e6)
            )
            print(f"serving on {server.url}  (work folder {work_dir}; Ctrl-C stops)", flush=True)
            signal.signal(signal.SIGTERM, _stop)
            try:
                server.serve_forever()
            except KeyboardInterrupt:
                print("stopping", flush=True)
            finally:
                server.server_close()
        finally:
            pool.close()
            if temporary:
                shutil.rmtree(work_dir, ignore_errors=True)
    return 0
