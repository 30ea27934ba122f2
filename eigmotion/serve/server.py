"""The HTTP server of ``eigmotion serve``: the page, its static files and the API.

API (JSON answers; an error is ``{"error": "..."}`` with a 4xx status):

- ``POST /api/query``, ``multipart/form-data`` with ``clip`` (a video) and optionally
  ``background`` (an image of the empty scene, the size of the frames) and ``top``
  (ranked actions to list): ``202 {"id": ID, "status_url": ...}``;
- ``GET /api/jobs/ID``: ``{"id", "state": queued|running|done|failed, "progress" (0-1),
  "stage", "elapsed_s", "error" (failed), "answer" (done)}``;
- ``GET /api/jobs/ID/NAME``: an artefact of a finished job
  (:data:`~eigmotion.serve.answer.ARTEFACTS`);
- ``GET /api/info``: the database and the number of workers.

Every request is served on a thread of its own; the queries run in the
:class:`~eigmotion.serve.jobs.JobPool`.  Nothing is written outside the working folder:
uploads are saved in a job folder under generated names.
"""

from __future__ import annotations

import base64
import email.parser
import email.policy
import hashlib
import json
import re
import shutil
import threading
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from urllib.parse import urlsplit

import cv2
import numpy as np

from eigmotion.serve.answer import ARTEFACTS, first_frame_size
from eigmotion.serve.jobs import JobPool

#: The page and its scripts, shipped as package data.
STATIC_DIR = Path(__file__).resolve().parent / "static"

VIDEO_SUFFIXES = (".mp4", ".avi", ".mov", ".mkv", ".webm", ".m4v", ".mpg", ".mpeg", ".gif")
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp")

CONTENT_TYPES = {
    ".html": "text/html; charset=utf-8",
    ".js": "text/javascript; charset=utf-8",
    ".css": "text/css; charset=utf-8",
    ".png": "image/png",
    ".txt": "text/plain; charset=utf-8",
    "": "text/plain; charset=utf-8",  # LICENSE
}

#: Bytes of a refused body read (and dropped) so the client hears the answer; beyond
#: it the connection is closed.
DRAIN_LIMIT_BYTES = 1 << 30


class UploadError(Exception):
    """An upload refused: the message tells the user what is wrong."""

    def __init__(self, message: str, status: HTTPStatus = HTTPStatus.BAD_REQUEST):
        super().__init__(message)
        self.status = status


def _inline_script_hashes(page: str) -> list[str]:
    """CSP hashes of the page's inline scripts (its import map)."""
    scripts = re.findall(r"<script[^>]*>(.*?)</script>", page, flags=re.S)
    return [
        "'sha256-" + base64.b64encode(hashlib.sha256(s.encode()).digest()).decode() + "'"
        for s in scripts
        if s.strip()
    ]


def parse_multipart(content_type: str, body: bytes) -> dict[str, tuple[str, bytes]]:
    """Form fields of a ``multipart/form-data`` body: name → (file name, bytes)."""
    head = f"Content-Type: {content_type}\r\nMIME-Version: 1.0\r\n\r\n".encode()
    message = email.parser.BytesParser(policy=email.policy.HTTP).parsebytes(head + body)
    if not message.is_multipart():
        raise UploadError("the request is not multipart/form-data")
    fields = {}
    for part in message.iter_parts():
        name = part.get_param("name", header="content-disposition")
        if name:
            fields[name] = (part.get_filename() or "", part.get_payload(decode=True) or b"")
    return fields


def _suffix(filename: str, allowed: tuple[str, ...], what: str) -> str:
    suffix = Path(filename).suffix.lower()
    if suffix not in allowed:
        raise UploadError(
            f"{what} {filename!r} is not a {'video' if what == 'clip' else 'image'} "
            f"(expected one of {', '.join(allowed)})"
        )
    return suffix


class EigmotionServer(ThreadingHTTPServer):
    """A threading HTTP server holding the job pool and the limits.

    Parameters
    ----------
    address : (host, port)
    pool : JobPool
    db_name : str
        The database, as the page names it.
    max_upload_bytes : int
    """

    daemon_threads = True

    def __init__(self, address, pool: JobPool, db_name: str, max_upload_bytes: int):
        super().__init__(address, Handler)
        self.pool = pool
        self.db_name = db_name
        self.max_upload_bytes = max_upload_bytes
        page = (STATIC_DIR / "index.html").read_text(encoding="utf-8")
        hashes = " ".join(_inline_script_hashes(page))
        self.csp = (
            f"default-src 'self'; script-src 'self' {hashes}; img-src 'self' data: blob:; "
            "media-src 'self' blob:; connect-src 'self'; style-src 'self'"
        )
        self._submit_lock = threading.Lock()

    @property
    def url(self) -> str:
        host, port = self.server_address[:2]
        return f"http://{host}:{port}/"


class Handler(BaseHTTPRequestHandler):
    server: EigmotionServer
    protocol_version = "HTTP/1.1"

    def log_message(self, format, *args):  # noqa: A002 - the base class's name
        pass  # the page and the API are quiet; errors reach the client

    # -- answers -----------------------------------------------------------------------

    def _send(self, status: int, body: bytes, content_type: str, extra=()) -> None:
        self.send_response(status)
        self.send_header("Content-Type", content_type)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Content-Security-Policy", self.server.csp)
        self.send_header("X-Content-Type-Options", "nosniff")
        self.send_header("Cache-Control", "no-store")
        for key, value in extra:
            self.send_header(key, value)
        self.end_headers()
        if self.command != "HEAD":
            self.wfile.write(body)

    def _json(self, status: int, value: dict) -> None:
        self._send(status, json.dumps(value).encode(), "application/json")

    def _error(self, status: int, message: str) -> None:
        self._json(status, {"error": message})

    def _file(self, path: Path, content_type: str) -> None:
        data = path.read_bytes()
        extra = [("Accept-Ranges", "bytes")]
        match = re.fullmatch(r"bytes=(\d*)-(\d*)", self.headers.get("Range", ""))
        if match and (match[1] or match[2]):
            size = len(data)
            start, end = (int(match[1]), int(match[2] or size - 1)) if match[1] else (
                max(size - int(match[2]), 0), size - 1)  # fmt: skip
            end = min(end, size - 1)
            if start > end:
                self._send(416, b"", content_type, [("Content-Range", f"bytes */{size}")])
                return
            extra.append(("Content-Range", f"bytes {start}-{end}/{size}"))
            self._send(206, data[start : end + 1], content_type, extra)
            return
        self._send(200, data, content_type, extra)

    # -- GET ---------------------------------------------------------------------------

    def do_HEAD(self):  # noqa: N802 - the base class's name
        self.do_GET()

    def do_GET(self):  # noqa: N802 - the base class's name
        path = urlsplit(self.path).path
        if path in ("/", "/index.html"):
            self._file(STATIC_DIR / "index.html", CONTENT_TYPES[".html"])
        elif path == "/favicon.ico":
            self._send(204, b"", "image/x-icon")
        elif path.startswith("/static/"):
            self._static(path[len("/static/") :])
        elif path == "/api/info":
            self._json(200, {"database": self.server.db_name, "workers": self.server.pool.workers,
                             "max_upload_bytes": self.server.max_upload_bytes})  # fmt: skip
        elif match := re.fullmatch(r"/api/jobs/([^/]+)", path):
            status = self.server.pool.status(match[1])
            if status is None:
                self._error(404, f"no job {match[1]!r}")
            else:
                self._json(200, status)
        elif match := re.fullmatch(r"/api/jobs/([^/]+)/([^/]+)", path):
            self._artefact(match[1], match[2])
        else:
            self._error(404, f"nothing at {path}")

    def _static(self, relative: str) -> None:
        target = (STATIC_DIR / relative).resolve()
        if not target.is_relative_to(STATIC_DIR) or not target.is_file():
            self._error(404, f"no file {relative!r}")
            return
        self._file(target, CONTENT_TYPES.get(target.suffix, "application/octet-stream"))

    def _artefact(self, job_id: str, name: str) -> None:
        folder = self.server.pool.folder(job_id)
        if folder is None:
            self._error(404, f"no job {job_id!r}")
        elif name not in ARTEFACTS:
            self._error(404, f"a job has no {name!r}; it has {', '.join(ARTEFACTS)}")
        elif not (folder / name).is_file():
            self._error(404, f"{name} is not ready: the job has not finished")
        else:
            self._file(folder / name, ARTEFACTS[name])

    # -- POST --------------------------------------------------------------------------

    def do_POST(self):  # noqa: N802 - the base class's name
        path = urlsplit(self.path).path
        if path != "/api/query":
            self._drain(int(self.headers.get("Content-Length") or 0))
            self._error(404, f"nothing to POST at {path}; POST clips to /api/query")
            return
        try:
            job_id = self._accept_query()
        except UploadError as exc:
            self._error(exc.status, str(exc))
            return
        except Exception as exc:  # noqa: BLE001 - the client hears of it, the server goes on
            self._error(500, f"internal error: {type(exc).__name__}: {exc}")
            return
        self._json(202, {"id": job_id, "status_url": f"/api/jobs/{job_id}"})

    def _drain(self, length: int) -> None:
        """Read and drop a refused body, so that the client reads the answer."""
        if length > DRAIN_LIMIT_BYTES:
            self.close_connection = True
            return
        while length > 0:
            chunk = self.rfile.read(min(length, 1 << 20))
            if not chunk:
                break
            length -= len(chunk)

    def _accept_query(self) -> str:
        length = self.headers.get("Content-Length")
        if length is None or not length.isdigit():
            self.close_connection = True
            raise UploadError("the upload has no Content-Length", HTTPStatus.LENGTH_REQUIRED)
        length = int(length)
        limit = self.server.max_upload_bytes
        if length > limit:
            self._drain(length)
            raise UploadError(
                f"the upload is too large: {length / 1e6:.1f} MB, at most {limit / 1e6:.1f} MB",
                HTTPStatus.REQUEST_ENTITY_TOO_LARGE,
            )
        content_type = self.headers.get("Content-Type", "")
        body = self.rfile.read(length)
        if not content_type.startswith("multipart/form-data"):
            raise UploadError("send the clip as multipart/form-data (form field 'clip')")
        fields = parse_multipart(content_type, body)
        clip_name, clip = fields.get("clip", ("", b""))
        if not clip:
            raise UploadError("no clip: send the video in the form field 'clip'")
        top = fields.get("top", ("", b"3"))[1].decode(errors="replace").strip() or "3"
        if not top.isdigit() or not 1 <= int(top) <= 20:
            raise UploadError(f"top must be a whole number from 1 to 20, got {top!r}")
        clip_suffix = _suffix(clip_name or "clip.mp4", VIDEO_SUFFIXES, "clip")
        background_name, background = fields.get("background", ("", b""))
        if background:
            background_suffix = _suffix(background_name, IMAGE_SUFFIXES, "empty-scene image")
        else:
            background, background_suffix = None, None
        return self._save_and_submit(clip, clip_suffix, background, background_suffix, int(top))

    def _save_and_submit(self, clip, clip_suffix, background, background_suffix, top) -> str:
        pool = self.server.pool
        job_id, folder = pool.new_job()
        try:
            clip_file = folder / f"upload{clip_suffix}"
            clip_file.write_bytes(clip)
            size = first_frame_size(clip_file)
            if size is None:
                raise UploadError("the clip is not a video: no frame of it can be read")
            background_file = None
            if background is not None:
                image = cv2.imdecode(np.frombuffer(background, np.uint8), cv2.IMREAD_COLOR)
                if image is None:
                    raise UploadError("the empty-scene image is not an image that can be read")
                if (image.shape[1], image.shape[0]) != size:
                    raise UploadError(
                        f"the empty-scene image is {image.shape[1]}×{image.shape[0]} pixels, "
                        f"the clip's frames {size[0]}×{size[1]}: they must be the same size"
                    )
                background_file = folder / f"background{background_suffix}"
                background_file.write_bytes(background)
        except UploadError:
            shutil.rmtree(folder, ignore_errors=True)
            raise
        with self.server._submit_lock:
            pool.submit(job_id, clip_file.name,
                        background_file.name if background_file else None, top)  # fmt: skip
        return job_id
