"""``eigmotion build``: a motion database from a library and a rig of virtual cameras.

Examples::

    eigmotion build                                   # bundled library and rig
    eigmotion build --motions my_library.toml --rig virtual_cameras/ring6.toml --db my.fs
    eigmotion build --girth 1 --db plain.fs           # the avatar's own build alone
    eigmotion build --scheduler tcp://10.0.0.5:8786   # rendered by a Dask cluster's workers
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

from eigmotion import resources
from eigmotion.errors import InvalidParameterError
from eigmotion.imaging.cameras import load_rig
from eigmotion.mocap.library import load_library
from eigmotion.retrieval.build import build_database
from eigmotion.retrieval.library_views import BuildConfig, render_views
from eigmotion.retrieval.storage import DEFAULT_DB_PATH

DEFAULT_RIG = resources.default_rig()


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--motions",
        type=Path,
        help="a library manifest (.toml) or a folder holding library.toml "
        "(default: the bundled library)",
    )
    parser.add_argument("--rig", type=Path, default=DEFAULT_RIG, help="camera rig (.toml)")
    parser.add_argument(
        "--db",
        default=None,
        help="database to write: a path, file://, or zeo://host:port "
        "(default database/eigmotion.fs)",
    )
    parser.add_argument("--workers", type=int, default=None, help="rendering processes")
    parser.add_argument(
        "--components", type=int, default=None, help="eigen-dimensions k (default from config)"
    )
    parser.add_argument(
        "--girth",
        type=float,
        action="append",
        help="a body girth factor: every motion is rendered, in every outfit, on a body of "
        "each girth given (repeatable; 0.7-1.8; default 1.0, 0.85 and 1.25: the avatar's own "
        "build, a slimmer and a stouter one)",
    )
    add_scheduler_argument(parser)
    parser.add_argument("--quiet", action="store_true", help="no progress bars")


def add_scheduler_argument(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="render on the Dask cluster of this scheduler (tcp://host:8786); its workers "
        "need eigmotion installed, this machine the cluster extra (pip install "
        "'eigmotion[cluster]')",
    )


def manifest_path(motions: Path | None) -> Path | None:
    if motions is not None and motions.is_dir():
        return motions / "library.toml"
    return motions


def run(args: argparse.Namespace) -> int:
    if args.workers is not None and args.workers < 1:
        raise InvalidParameterError(f"--workers must be >= 1, got {args.workers}")
    if args.workers is not None and args.scheduler:
        raise InvalidParameterError(
            "--workers and --scheduler exclude each other: the cluster's workers render"
        )
    library = load_library(manifest_path(args.motions))
    rig = load_rig(args.rig)
    config = BuildConfig()
    if args.components is not None:
        config = replace(config, n_components=args.components)
    if args.girth:
        config = replace(config, body_shapes=tuple((None, girth) for girth in args.girth))
    uri = args.db or DEFAULT_DB_PATH
    views = None
    if args.scheduler:
        views = render_views(
            library, rig, config, progress=not args.quiet, scheduler=args.scheduler
        )
    report = build_database(
        library, rig, uri, config, workers=args.workers, progress=not args.quiet, views=views
    )
    renderings = report.n_motions * len(rig) * len(config.bodies)
    print(
        f"built {report.uri}: {report.n_motions} motions × {len(rig)} views × "
        f"{len(config.bodies)} bodies = {renderings:,} renderings → "
        f"{report.n_entries:,} entries (each rendering's whole clip and windows), "
        f"k = {report.n_components} "
        f"({report.explained_variance:.1%} of the variance), unknown threshold "
        f"{report.threshold:.3f}, {report.seconds:.1f} s",
        file=sys.stderr,
    )
    return 0
