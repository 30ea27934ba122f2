"""``eigmotion convert``: a BVH or CMU ASF/AMC motion → a BVH file.

Examples::

    eigmotion convert 02_01.amc --asf 02.asf 02_01.bvh
    eigmotion convert walk.bvh walk_30fps.bvh --fps 30 --start 120 --stop 480
    eigmotion convert 02_01.amc --asf 02.asf 02_01.bvh --canonical-names
"""

from __future__ import annotations

import argparse
from pathlib import Path

from eigmotion.errors import InvalidParameterError
from eigmotion.mocap.amc import read_amc
from eigmotion.mocap.bvh import read_bvh, write_bvh
from eigmotion.mocap.naming import canonical_names, load_joint_map


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("input", type=Path, help="input motion: FILE.bvh or FILE.amc (with --asf)")
    parser.add_argument("output", type=Path, help="output BVH file")
    parser.add_argument("--asf", type=Path, help="the ASF skeleton of an AMC input")
    parser.add_argument(
        "--amc-fps",
        type=float,
        default=120.0,
        help="frame rate of an AMC input, which the file does not state (default 120, CMU's)",
    )
    parser.add_argument("--fps", type=float, help="resample to this many frames per second")
    parser.add_argument(
        "--start", type=int, default=0, help="first input frame to keep (0-based, default 0)"
    )
    parser.add_argument(
        "--stop", type=int, help="input frame to stop before (exclusive, default the end)"
    )
    parser.add_argument(
        "--canonical-names",
        action="store_true",
        help="rename joints to the canonical CMU names (every joint must map one-to-one)",
    )
    parser.add_argument(
        "--joint-map",
        type=Path,
        metavar="FILE.toml",
        help="joint names map for --canonical-names: a [joints] table, source = canonical",
    )
    parser.add_argument(
        "--precision", type=int, default=6, help="digits after the decimal point (default 6)"
    )


def run(args: argparse.Namespace) -> int:
    suffix = args.input.suffix.lower()
    if suffix == ".amc":
        if args.asf is None:
            raise InvalidParameterError(
                f"{args.input}: an AMC input needs its skeleton: --asf FILE"
            )
        if not args.amc_fps > 0:
            raise InvalidParameterError(f"--amc-fps must be > 0, got {args.amc_fps:g}")
        motion = read_amc(args.input, args.asf, frame_time_s=1.0 / args.amc_fps)
    elif suffix == ".bvh":
        if args.asf is not None:
            raise InvalidParameterError("--asf is only for AMC inputs")
        motion = read_bvh(args.input)
    else:
        raise InvalidParameterError(
            f"{args.input}: unknown motion format {suffix or '(no extension)'!r}; "
            "expected .bvh or .amc"
        )
    if args.output.suffix.lower() != ".bvh":
        raise InvalidParameterError(f"{args.output}: the output must be a .bvh file")
    if args.start != 0 or args.stop is not None:
        motion = motion.trim(args.start, args.stop)
    if args.fps is not None:
        motion = motion.resample(args.fps)
    if args.joint_map is not None and not args.canonical_names:
        raise InvalidParameterError("--joint-map is used with --canonical-names")
    if args.canonical_names:
        mapping = load_joint_map(args.joint_map) if args.joint_map is not None else None
        names = canonical_names(motion.skeleton, mapping)
        motion = motion.replace(skeleton=motion.skeleton.renamed(names))
    write_bvh(motion, args.output, precision=args.precision)
    print(
        f"{args.output}: {motion.skeleton.n_joints} joints, {motion.n_frames} frames "
        f"at {motion.fps:g} fps"
    )
    return 0
