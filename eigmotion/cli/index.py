"""``eigmotion index``: add a basic motion to an existing database.

Examples::

    eigmotion index my_wave.bvh --label wave
    eigmotion index 86_02.amc --asf 86.asf --label jump --name jump_86_02 --refit
    eigmotion index my_wave.bvh --label wave --scheduler tcp://10.0.0.5:8786
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from eigmotion.cli.build import add_scheduler_argument
from eigmotion.errors import InvalidParameterError
from eigmotion.mocap.library import LibraryMotion, find_motion
from eigmotion.retrieval.build import build_database
from eigmotion.retrieval.database import MotionDatabase
from eigmotion.retrieval.library_views import render_views
from eigmotion.retrieval.storage import DEFAULT_DB_PATH


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("motion", type=Path, help="the motion: FILE.bvh, or FILE.amc with --asf")
    parser.add_argument("--label", required=True, help="what the motion is, e.g. 'wave'")
    parser.add_argument("--name", help="unique name in the database (default the file stem)")
    parser.add_argument("--asf", type=Path, help="the ASF skeleton of an AMC motion")
    parser.add_argument("--start", type=int, default=0, help="first frame to keep")
    parser.add_argument("--stop", type=int, default=None, help="frame to stop before")
    parser.add_argument("--db", default=None, help="database (default database/eigmotion.fs)")
    parser.add_argument(
        "--refit", action="store_true", help="rebuild the eigenspace with the new motion"
    )
    add_scheduler_argument(parser)
    parser.add_argument("--quiet", action="store_true", help="no progress bars")


def run(args: argparse.Namespace) -> int:
    label = args.label.strip()
    if not label:
        raise InvalidParameterError("--label must not be empty")
    motion = find_motion(args.motion, asf=args.asf).trim(args.start, args.stop)
    name = args.name or args.motion.stem
    item = LibraryMotion(
        name=name,
        label=label,
        motion=motion.replace(name=name),
        source=(args.motion,),
        performer="",
        variation="",
        licence="",
        role="basic",
    )
    uri = args.db or DEFAULT_DB_PATH
    if args.refit:
        with MotionDatabase.open(uri) as db:
            library = db.stored_library()
            rig, config = db.rig, db.config
        if name in {m.name for m in library}:
            raise InvalidParameterError(
                f"a motion named {name!r} is already in the database; give it another name "
                "with --name"
            )
        library = library + [item]
        views = None
        if args.scheduler:
            views = render_views(
                library, rig, config, progress=not args.quiet, scheduler=args.scheduler
            )
        report = build_database(library, rig, uri, config, progress=not args.quiet, views=views)
        print(
            f"rebuilt {report.uri} with {name!r}: {report.n_entries} entries, "
            f"k = {report.n_components}",
            file=sys.stderr,
        )
        return 0
    with MotionDatabase.open(uri, read_only=False) as db:
        report = db.index_motion(item, progress=not args.quiet, scheduler=args.scheduler)
    print(
        f"indexed {report.name!r} as {label!r}: {report.n_entries} entries",
        file=sys.stderr,
    )
    if report.badly_represented:
        print(
            f"warning: the eigenspace represents {report.name!r} badly (reconstruction "
            f"error {report.reconstruction_error:.3f} > {report.reference_error:.3f} of the "
            "library); rebuild with --refit",
            file=sys.stderr,
        )
    return 0
