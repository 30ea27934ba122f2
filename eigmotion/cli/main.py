"""The ``eigmotion`` command line.

Each sub-command lives in :mod:`eigmotion.cli` as a module with ``HELP`` (one
line), ``add_arguments(parser)`` and ``run(args) -> int``.  Any
:class:`~eigmotion.errors.EigmotionError` (or an unreadable file) becomes one line on
stderr and exit code 2, never a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys

from eigmotion.errors import EigmotionError

# A video that cannot be read is reported once, by the command, naming the file: the
# lines FFmpeg and OpenCV print about it themselves would come before that one, so they
# are silenced (read when cv2 is first imported; a setting of the user's own wins).
os.environ.setdefault("OPENCV_LOG_LEVEL", "ERROR")
os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")  # AV_LOG_QUIET

#: Sub-commands in the order ``--help`` lists them.
COMMANDS = (
    "build",
    "query",
    "index",
    "track",
    "calibrate",
    "convert",
    "show",
    "render",
)

EXIT_BAD_INPUT = 2


def _load_commands() -> dict:
    modules = {}
    for name in COMMANDS:
        qualified = f"eigmotion.cli.{name}"
        try:
            modules[name] = importlib.import_module(qualified)
        except ModuleNotFoundError as exc:
            if exc.name != qualified:
                raise
    return modules


def build_parser() -> tuple[argparse.ArgumentParser, dict]:
    parser = argparse.ArgumentParser(
        prog="eigmotion",
        description="3D human motion from one uncalibrated camera.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    modules = _load_commands()
    for name, module in modules.items():
        p = sub.add_parser(name, help=module.HELP, description=module.HELP)
        module.add_arguments(p)
    return parser, modules


def main(argv: list[str] | None = None) -> int:
    parser, modules = build_parser()
    args = parser.parse_args(argv)
    if not args.command:
        parser.print_help()
        return EXIT_BAD_INPUT
    try:
        return int(modules[args.command].run(args) or 0)
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


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
