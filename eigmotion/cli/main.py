"""The ``eigmotion`` command line.

Each sub-command lives in :mod:`eigmotion.cli` as a module with
``add_arguments(parser)`` and ``run(args) -> int``; its one-line help is in
:data:`COMMANDS`.  Only the module of the sub-command asked for is imported, so that
``eigmotion --help`` and one command's run do not load every other command's work.
Any :class:`~eigmotion.errors.EigmotionError` (or a file that cannot be read or
written, a full disk included) becomes one short line on stderr and exit code 2, never
a traceback: control characters are escaped and long values cut (:func:`one_line`).
"""

from __future__ import annotations

import argparse
import importlib
import logging
import os
import re
import sys
import threading
from types import ModuleType

from eigmotion.errors import EigmotionError
from eigmotion.limits import MAX_FRAME_PIXELS

# A video that cannot be read is reported once, by the command, naming the file: the
# lines FFmpeg and OpenCV print about it themselves would come before that one, so they
# are silenced (read when cv2 is first imported; a setting of the user's own wins).
os.environ.setdefault("OPENCV_LOG_LEVEL", "ERROR")
os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")  # AV_LOG_QUIET
# OpenCV's own bound on the pixels of an image it decodes (its default is 2**30).
os.environ.setdefault("OPENCV_IO_MAX_IMAGE_PIXELS", str(MAX_FRAME_PIXELS))

#: Sub-commands whose process keeps the BLAS library (NumPy's matrix products) on the
#: thread that calls it, unless the user sets ``OPENBLAS_NUM_THREADS``: a query's
#: products are small and already run side by side on its worker threads, and the
#: library's own threads on top of them only contend for the same cores (the time
#: warping's product of a 3 s clip took 16 ms on two BLAS threads against 2.2 ms on
#: one on a busy two-core machine, ``docs/database.md``, "Cold").  Read when NumPy is
#: first imported, so set by :func:`entry` before the command's module is.
ONE_BLAS_THREAD = frozenset({"query"})

#: Sub-commands whose process, run as the ``eigmotion`` command (:func:`entry`), ends as
#: soon as the command has returned and its output is flushed, without Python's teardown
#: of every loaded module: for a query that teardown (NumPy, OpenCV, ZODB) took about
#: 60 ms of a cold run on a busy two-core machine, against 8 ms without it
#: (``docs/database.md``, "Cold").  Every file such a command writes is closed, and
#: its temporary files removed, before it returns.
QUICK_EXIT = frozenset({"query"})

#: Sub-commands whose process, run as the ``eigmotion`` command (:func:`entry`) with an
#: empty-scene image or the subtraction front end asked for, has OpenCV build its 8-bit
#: L*a*b* tables on another thread from the start: about 70 ms of CPU that a cold query
#: otherwise waited for after opening the database (see
#: :func:`eigmotion.segmentation.evidence.start_colour_tables`), now done while the
#: command's modules are imported.
EARLY_COLOUR_TABLES = frozenset({"query"})

#: Sub-commands in the order ``--help`` lists them, each with its one-line help.
COMMANDS = {
    "build": "build a motion database from a basic-motion library and a camera rig",
    "query": "answer a single-camera clip with the nearest basic motion and its view",
    "index": "index a new basic motion into an existing database (no rebuild unless --refit)",
    "track": "track a person's posture in 2+ calibrated videos against a posture dictionary",
    "calibrate": (
        "calibrate cameras from chessboard images (one folder per camera) into a JSON file"
    ),
    "convert": "convert a BVH or CMU ASF/AMC motion to BVH (resample, trim, rename joints)",
    "list": "list the motions a database holds: label, performer, role, entries (--json)",
    "show": "render a motion on the avatar: a contact sheet (.png) or a replay (.gif, .mp4)",
    "render": "render a motion's silhouettes and motion images from every camera of a rig",
    "serve": "a web page on this machine: upload a clip, see the answer, replay and 3D motion",
    "eval": "score recognition, tracking or pose on the independent development set",
    "check": "check a database file: readable or not, what is damaged, what is intact",
    "repair": "copy every intact motion of a damaged database file into a new file",
}

EXIT_BAD_INPUT = 2
#: Longest error line printed, characters, and longest single value in it.
MAX_ERROR_CHARS = 400
MAX_VALUE_CHARS = 120

_LONG_VALUE = re.compile(rf"\S{{{MAX_VALUE_CHARS + 1},}}")


def _cut(text: str, keep: int) -> str:
    half = keep // 2
    return f"{text[:half]}…[{len(text) - 2 * half:,} characters cut]…{text[-half:]}"


def one_line(message: object) -> str:
    """``message`` as one short line: control characters escaped, any value longer
    than :data:`MAX_VALUE_CHARS` and the whole beyond :data:`MAX_ERROR_CHARS` cut in
    the middle (a file of NUL bytes or a huge joint name is not echoed in full)."""
    text = str(message).replace("\n", " ")
    text = "".join(c if c.isprintable() else ascii(c)[1:-1] for c in text)
    text = _LONG_VALUE.sub(lambda m: _cut(m.group(), MAX_VALUE_CHARS // 2), text)
    return text if len(text) <= MAX_ERROR_CHARS else _cut(text, MAX_ERROR_CHARS - 40)


#: Libraries whose own log lines would reach stderr beside the command's one line (a
#: damaged database is reported by the command, naming what to do).
QUIET_LOGGERS = ("ZODB", "ZEO", "txn", "transaction", "persistent", "BTrees", "zc.lockfile")


def quiet_library_logs() -> None:
    """Keep the log lines of :data:`QUIET_LOGGERS` off stderr (Python's last-resort
    handler prints warnings of an unconfigured logger there)."""
    for name in QUIET_LOGGERS:
        logger = logging.getLogger(name)
        logger.addHandler(logging.NullHandler())
        logger.propagate = False


def requested_command(argv: list[str]) -> str | None:
    """The sub-command named on a command line, ``None`` without a known one.

    The top-level parser takes no option with a value, so the command is the first
    argument that is not an option.
    """
    for arg in argv:
        if arg == "--":
            return None
        if not arg.startswith("-"):
            return arg if arg in COMMANDS else None
    return None


class _OneLineParser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (no usage block) and exit 2."""

    def error(self, message: str):
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {one_line(message)} (see --help)\n")


def build_parser(command: str | None = None) -> tuple[argparse.ArgumentParser, ModuleType | None]:
    """The parser, with the arguments of ``command`` only, and that command's module.

    Every sub-command is listed (with its help); only ``command``'s module is imported
    and its arguments added.
    """
    parser = _OneLineParser(
        prog="eigmotion",
        description="3D human motion from one uncalibrated camera.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    module = None
    for name, help_line in COMMANDS.items():
        p = sub.add_parser(name, help=help_line, description=help_line)
        if name == command:
            module = importlib.import_module(f"eigmotion.cli.{name}")
            module.add_arguments(p)
    return parser, module


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    quiet_library_logs()
    parser, module = build_parser(requested_command(argv))
    args = parser.parse_args(argv)
    if not args.command:
        parser.print_help()
        return EXIT_BAD_INPUT
    try:
        return int(module.run(args) or 0)
    except EigmotionError as exc:
        print(f"eigmotion {args.command}: error: {one_line(exc)}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except OSError as exc:  # a missing or unreadable file, a full disk …
        where = f": {exc.filename}" if getattr(exc, "filename", None) else ""
        message = one_line(f"{exc.strerror or exc}{where}")
        print(f"eigmotion {args.command}: error: {message}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print(f"eigmotion {args.command}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # The reader went away (``eigmotion list | head``): stop quietly, as Unix tools do.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0


def _asks_for_colour_tables(argv: list[str]) -> bool:
    """Whether a command line passes an empty-scene image or asks for the subtraction
    front end (the two that compare colours in L*a*b*)."""
    pairs = zip(argv, argv[1:] + [""], strict=True)
    return any(
        arg == "--background" or arg.startswith("--background=")
        or (arg == "--segmenter" and value == "subtraction")
        or arg == "--segmenter=subtraction"
        for arg, value in pairs
    )  # fmt: skip


def _build_colour_tables() -> None:
    """Have OpenCV build its RGB → L*a*b* tables (imports NumPy and OpenCV only, so
    that it cannot wait on a module the main thread is importing)."""
    import cv2
    import numpy as np

    cv2.cvtColor(np.zeros((1, 1, 3), np.uint8), cv2.COLOR_RGB2Lab)


def entry() -> None:
    """The ``eigmotion`` command (and ``python -m eigmotion``): :func:`main` on the
    process's arguments, then its exit status.  For a command of
    :data:`ONE_BLAS_THREAD` the BLAS library is first kept to the calling thread, for
    one of :data:`EARLY_COLOUR_TABLES` OpenCV's colour tables are built on another
    thread while the command loads, and for one of :data:`QUICK_EXIT` the process ends
    as soon as its output is flushed; :func:`main` itself, called in a process of its
    own, changes none of these."""
    argv = sys.argv[1:]
    command = requested_command(argv)
    if command in ONE_BLAS_THREAD:  # the process's own setting, before NumPy loads
        os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    if command in EARLY_COLOUR_TABLES and _asks_for_colour_tables(argv):
        threading.Thread(target=_build_colour_tables, name="colour tables", daemon=True).start()
    status = main(argv)
    if command not in QUICK_EXIT:
        sys.exit(status)
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (BrokenPipeError, ValueError):  # the reader went away, or it is closed
            pass
    os._exit(status)


if __name__ == "__main__":  # pragma: no cover
    entry()
