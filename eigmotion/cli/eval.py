"""``eigmotion eval recognition|tracking|pose``: the independent development set.

Examples::

    eigmotion eval recognition                       # ../shared/eval/dev, default database
    eigmotion eval recognition --dev DIR --db my.fs --modes bg nobg --json-out dev.json
    eigmotion eval recognition --only walk_ wave_
    eigmotion eval tracking --json-out tracking.json # two cameras: MPJPE, swaps, speed
    eigmotion eval tracking --tracker-config travel_tolerance_deg=null   # a setting off
    eigmotion eval tracking --segmenter subtraction  # silhouettes by background subtraction
    eigmotion eval pose --db my.fs                   # one camera: PA-MPJPE

Every clip is answered in this process exactly as ``eigmotion query CLIP --json``
answers it (:mod:`eigmotion.evaluation.devset`), in each mode asked: ``bg`` (the video
with its empty-scene image), ``nobg`` (the video alone), ``masks`` (the true masks as
an ``.npz``: the representation's ceiling), ``masks_small`` (the same shrunk to the size
a video query cuts its silhouettes at: a video query's ceiling), ``real`` (the real
clips).  The tables
(:mod:`eigmotion.evaluation.devset_report`) are printed as Markdown; ``--json-out``
keeps every clip's answer and the summaries.

``tracking`` tracks every two-camera set as ``eigmotion track`` does (default
dictionary and settings) and ``pose`` asks every retrieval clip with its background
for its pose as ``eigmotion query --pose-out`` does
(:mod:`eigmotion.evaluation.devset_joints`): MPJPE per joint and set, the root's error,
left/right swaps and heading flips, estimates per second of CPU time; PA-MPJPE per frame
and per clip.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
import tempfile
from pathlib import Path

from tqdm import tqdm

from eigmotion.errors import InvalidParameterError
from eigmotion.evaluation.devset import (
    MODE_KIND,
    MODES,
    answer_mode,
    find_dev_set,
    load_dev_clips,
)
from eigmotion.evaluation.devset_joints import (
    format_pose,
    format_tracking,
    load_tracking_sets,
    pose_clip,
    summarise_pose,
    summarise_tracking,
    track_set,
)
from eigmotion.evaluation.devset_report import format_mode, format_overview, summarise
from eigmotion.retrieval.database import MotionDatabase
from eigmotion.retrieval.storage import DEFAULT_DB_PATH
from eigmotion.segmentation.learned import SEGMENTERS
from eigmotion.tracking.pipeline import dictionary_from_specs
from eigmotion.tracking.tracker import TrackerConfig


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "what",
        choices=["recognition", "tracking", "pose"],
        help="what to evaluate: recognition (query), tracking (track, two cameras), "
        "pose (query --pose-out, one camera)",
    )
    parser.add_argument(
        "--dev",
        type=Path,
        default=None,
        help="the development set's folder (default ../shared/eval/dev if it exists)",
    )
    parser.add_argument("--db", default=None, help="database (default database/eigmotion.fs)")
    parser.add_argument(
        "--modes",
        nargs="+",
        choices=MODES,
        default=list(MODES),
        help="recognition: bg: video and empty-scene image; nobg: video alone; masks: true "
        "masks; masks_small: true masks at the video query's working size; real: real clips "
        "(default all five)",
    )
    parser.add_argument(
        "--segmenter",
        choices=SEGMENTERS,
        default="auto",
        help="the front end for video, as for eigmotion query and eigmotion track "
        "(default auto: fused with the background image, learned without; learned in "
        "the bg mode and for tracking asks the video without its background image)",
    )
    parser.add_argument(
        "--only", nargs="+", metavar="SUBSTR", help="clips whose id contains any of these"
    )
    parser.add_argument(
        "--json-out", type=Path, help="write every clip's answer and the summaries as JSON"
    )
    parser.add_argument(
        "--dictionary",
        nargs="+",
        metavar="MOTION",
        help="tracking: the posture dictionary's motions (library names, .bvh, or one saved "
        ".npz), as eigmotion track --dictionary; default the command's",
    )
    parser.add_argument(
        "--tracker-config",
        nargs="+",
        default=[],
        metavar="NAME=VALUE",
        help="tracking: tracker settings other than the defaults (TrackerConfig fields, "
        "values as JSON), e.g. travel_tolerance_deg=null scale_from_top=true",
    )


def run(args: argparse.Namespace) -> int:
    if args.json_out is not None and not args.json_out.parent.is_dir():
        raise InvalidParameterError(
            f"{args.json_out}: folder {args.json_out.parent} does not exist"
        )
    dev = find_dev_set(args.dev)
    if args.what == "tracking":
        return _run_tracking(args, dev)
    if args.what == "pose":
        return _run_pose(args, dev)
    modes = list(dict.fromkeys(args.modes))
    clips = {kind: load_dev_clips(dev, kind, args.only) for kind in set(MODE_KIND.values())}
    if not any(clips[MODE_KIND[mode]] for mode in modes):
        raise InvalidParameterError(f"{dev}: no clips for the modes and --only asked")
    uri = args.db or DEFAULT_DB_PATH
    summaries = []
    report = {"dev": str(dev), "db": str(uri), "segmenter": args.segmenter, "modes": {}}
    with MotionDatabase.open(uri) as db, tempfile.TemporaryDirectory() as scratch:
        for mode in modes:
            asked = clips[MODE_KIND[mode]]
            if not asked:
                print(f"{mode}: no clips, skipped", file=sys.stderr)
                continue
            answers = answer_mode(
                db, asked, mode, Path(scratch), progress=True, segmenter=args.segmenter
            )
            summary = summarise(mode, answers)
            summaries.append(summary)
            print(format_mode(summary) + "\n", flush=True)
            report["modes"][mode] = {
                "summary": summary.to_json(),
                "clips": [a.to_json() for a in answers],
            }
    print("## all modes\n\n" + format_overview(summaries))
    print(f"\ndevelopment set {dev}, database {uri}, segmenter {args.segmenter}")
    _write_json(args.json_out, report)
    return 0


def _finite(value):
    """``value`` with every NaN or infinity (a clip that got no answer) made ``None``,
    so the file is strict JSON."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {key: _finite(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [_finite(item) for item in value]
    return value


def _write_json(path: Path | None, report: dict) -> None:
    if path is not None:
        path.write_text(json.dumps(_finite(report), indent=1, allow_nan=False))
        print(f"wrote {path}", file=sys.stderr)


def tracker_config(items: list[str]) -> TrackerConfig:
    """The :class:`~eigmotion.tracking.tracker.TrackerConfig` of ``NAME=VALUE`` items
    (values as JSON: numbers, ``null``, ``true``, lists).

    Raises
    ------
    InvalidParameterError
        An item without ``=``, a name that is no setting, a value that is not JSON or
        not valid for its setting.
    """
    known = {f.name for f in dataclasses.fields(TrackerConfig)}
    settings = {}
    for item in items:
        name, sep, text = item.partition("=")
        if not sep:
            raise InvalidParameterError(f"--tracker-config {item!r}: expected NAME=VALUE")
        if name not in known:
            raise InvalidParameterError(
                f"--tracker-config {item!r}: {name!r} is no tracker setting "
                f"(one of {', '.join(sorted(known))})"
            )
        try:
            value = json.loads(text)
        except json.JSONDecodeError:
            raise InvalidParameterError(
                f"--tracker-config {item!r}: the value is not JSON (a number, null, true, "
                "false, a list)"
            ) from None
        settings[name] = tuple(value) if isinstance(value, list) else value
    return TrackerConfig(**settings)


def _run_tracking(args: argparse.Namespace, dev: Path) -> int:
    config = tracker_config(args.tracker_config)
    sets = load_tracking_sets(dev, args.only)
    if not sets:
        raise InvalidParameterError(f"{dev}: no tracking sets (tracking/<id>/cams.json)")
    print("building the posture dictionary", file=sys.stderr, flush=True)
    dictionary = dictionary_from_specs(args.dictionary)
    tracked = [
        track_set(folder, dictionary, config, args.segmenter)
        for folder in tqdm(sets, desc="tracking", unit="set", leave=False)
    ]
    print(format_tracking(tracked))
    print(
        f"\ndevelopment set {dev}, dictionary of {len(dictionary)} postures, "
        f"segmenter {args.segmenter}"
    )
    if args.tracker_config:
        print(f"tracker settings: {' '.join(args.tracker_config)}")
    report = {
        "dev": str(dev),
        "tracker_config": dataclasses.asdict(config),
        "segmenter": args.segmenter,
        "summary": summarise_tracking(tracked),
        "sets": [s.to_json() for s in tracked],
    }
    _write_json(args.json_out, report)
    return 0


def _run_pose(args: argparse.Namespace, dev: Path) -> int:
    clips = load_dev_clips(dev, "retrieval", args.only)
    if not clips:
        raise InvalidParameterError(f"{dev}: no retrieval clips for the --only asked")
    uri = args.db or DEFAULT_DB_PATH
    with MotionDatabase.open(uri) as db:
        posed = [pose_clip(db, clip) for clip in tqdm(clips, desc="pose", unit="clip", leave=False)]
    print(format_pose(posed))
    print(f"\ndevelopment set {dev}, database {uri}")
    report = {
        "dev": str(dev),
        "db": str(uri),
        "summary": summarise_pose(posed),
        "clips": [c.to_json() for c in posed],
    }
    _write_json(args.json_out, report)
    return 0
