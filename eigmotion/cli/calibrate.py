"""``eigmotion calibrate IMAGES… --pattern 9x6 --square-m 0.025 --out cams.json``.

Calibrates one or more cameras from photographs of a printed chessboard and writes the
calibration JSON that ``eigmotion track --calib`` reads.

What it expects:

* the images of each camera in a folder of their own; the folder's name becomes the
  camera's name (``cam0/*.png cam1/*.png`` → cameras ``cam0`` and ``cam1``, in sorted
  order — the order videos must be given to ``track``);
* per camera, several views of the board (tilted, in different parts of the image:
  they fix the focal length and principal point) — at least 3 are advised;
* per camera, exactly one image whose file name starts with ``--floor`` (default
  ``floor``, e.g. ``cam0/floor.png``) showing the board lying flat on the floor, at
  the same place for every camera, seen in full: it defines the shared world frame —
  origin at the board's inner corner next to its dark corner square, X along its rows
  of ``pattern[0]`` corners, Z along its columns, Y up, metres;
* a board with one even and one odd number of inner corners (``--pattern`` counts
  inner corners, e.g. 9x6 for a board of 10 × 7 squares), ``--square-m`` the side of
  one square in metres;
* no strong lens distortion: the camera model is a pinhole without distortion
  (undistort the images and the videos beforehand if needed).

Prints the reprojection error per camera (pixels).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from eigmotion.errors import InvalidParameterError
from eigmotion.imaging.still_images import IMAGE_EXTENSIONS
from eigmotion.tracking.calibration import (
    calibrate_cameras,
    group_images_by_camera,
    parse_pattern,
    save_calibration,
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "images",
        nargs="+",
        type=Path,
        help="chessboard images, one folder per camera (a folder is taken whole)",
    )
    parser.add_argument(
        "--pattern",
        default="9x6",
        help="inner corners per row x rows, one even and one odd (default: %(default)s)",
    )
    parser.add_argument(
        "--square-m",
        type=float,
        default=0.025,
        help="side of one square, metres (default: %(default)s)",
    )
    parser.add_argument(
        "--floor",
        default="floor",
        help="file-name prefix of each camera's image of the board on the floor "
        "(default: %(default)s)",
    )
    parser.add_argument("--out", type=Path, required=True, help="calibration JSON to write")


def _expand(paths: list[Path]) -> list[Path]:
    out = []
    for p in paths:
        if p.is_dir():
            out.extend(q for q in sorted(p.iterdir()) if q.suffix.lower() in IMAGE_EXTENSIONS)
        elif p.is_file():
            out.append(p)
        else:
            raise InvalidParameterError(f"{p}: no such image or folder")
    return out


def run(args: argparse.Namespace) -> int:
    pattern = parse_pattern(args.pattern)
    groups = group_images_by_camera(_expand(list(args.images)))
    calibration, errors = calibrate_cameras(groups, pattern, args.square_m, args.floor)
    save_calibration(calibration, args.out)
    for cam in calibration.cameras:
        x, y, z = cam.center
        print(
            f"{cam.name}: {len(groups[cam.name])} images, reprojection error "
            f"{errors[cam.name]:.3f} px, focal {cam.fx:.1f} px, centre at "
            f"({x:.3f}, {y:.3f}, {z:.3f}) m",
            file=sys.stdout,
        )
    print(f"wrote {args.out}", file=sys.stdout)
    return 0
