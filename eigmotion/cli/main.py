"""The ``eigmotion`` command line.

Each sub-command lives in :mod:`eigmotion.cli` as a module with
``add_arguments(parser)`` and ``run(args) -> int``; its one-line help is in
:data:`COMMANDS`.  Only the module of the sub-command asked for is imported, so that
``eigmotion --help`` and one command's run do not load every other command's work.
Any :class:`~eigmotion.errors.EigmotionError` (or an unreadable file) becomes one line
on stderr and exit code 2, never a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import os
import sys
from types import ModuleType

from eigmotion.errors import EigmotionError

# A video that cannot be read is reported once, by the command, naming the file: the
# lines FFmpeg and OpenCV print about it themselves would come before that one, so they
# are silenced (read when cv2 is first imported; a setting of the user's own wins).
os.environ.setdefault("OPENCV_LOG_LEVEL", "ERROR")
os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")  # AV_LOG_QUIET

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
    "eval": "score recognition on the independent development set (accuracy, IoU, time)",
    "check": "check a database file: readable or not, what is damaged, what is intact",
    "repair": "copy every intact motion of a damaged database file into a new file",
}

EXIT_BAD_INPUT = 2

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


def build_parser(command: str | None = None) -> tuple[argparse.ArgumentParser, ModuleType | None]:
    """The parser, with the arguments of ``command`` only, and that command's module.

    Every sub-command is listed (with its help); only ``command``'s module is imported
    and its arguments added.
    """
    parser = argparse.ArgumentParser(
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
        print(f"eigmotion {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except (FileNotFoundError, IsADirectoryError, PermissionError) as exc:
        where = f": {exc.filename}" if getattr(exc, "filename", None) else ""
        print(f"eigmotion {args.command}: error: {exc.strerror or exc}{where}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print(f"eigmotion {args.command}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # The reader went away (``eigmotion list | head``): stop quietly, as Unix tools do.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
