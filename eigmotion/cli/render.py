"""``eigmotion render``: what the database sees of a motion — masks and motion images.

Each motion is put on the avatar and filmed by every camera of a rig exactly as
``eigmotion build`` does (same body, same rig fitting, same motion-image settings);
the silhouettes go to ``DIR/<motion>/<view>.npz`` (key ``masks``, plus ``fps``), the
motion images to ``DIR/<motion>/<view>.png``, and one contact sheet of motion images
(motions × views) to ``DIR/motion_images.png``.

Examples::

    eigmotion render walk_02_01 --out out/walk
    eigmotion render all --rig virtual_cameras/ring6.toml --out out/library
"""

from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import numpy as np
from tqdm import tqdm

from eigmotion import resources
from eigmotion.errors import InvalidParameterError
from eigmotion.imaging.cameras import load_rig
from eigmotion.imaging.figures import contact_sheet, save_image
from eigmotion.imaging.silhouettes import render_masks
from eigmotion.mocap.library import find_motion, load_library
from eigmotion.retrieval.library_views import BuildConfig, build_body, pose_for_views
from eigmotion.retrieval.motion_image import motion_image, motion_image_picture

DEFAULT_RIG = resources.default_rig()


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "motions",
        nargs="+",
        help="library motion names, .bvh/.amc files, or 'all' for the whole library",
    )
    parser.add_argument("--asf", type=Path, help="the skeleton (.asf) of .amc motions")
    parser.add_argument("--rig", type=Path, default=DEFAULT_RIG, help="camera rig (.toml)")
    parser.add_argument("--out", type=Path, required=True, help="output folder")
    parser.add_argument(
        "--no-masks", action="store_true", help="write motion images only, not the masks"
    )


#: Longest name taken from a file for a file or folder written, characters.
MAX_NAME_CHARS = 200


def check_output_names(names: list[str], what: str) -> None:
    """InvalidParameterError unless every name, taken from an input file, can name a
    file or folder inside the output folder: not empty, ``.`` or ``..``, no path
    separator or control character, at most :data:`MAX_NAME_CHARS`, no two alike.

    Parameters
    ----------
    names : list of str
    what : str
        Whose names they are, for the message (``"camera"``, ``"motion"``).
    """
    seen = set()
    for name in names:
        if (
            name in ("", ".", "..")
            or len(name) > MAX_NAME_CHARS
            or any(sep in name for sep in ("/", "\\"))
            or not name.isprintable()
        ):
            raise InvalidParameterError(
                f"{what} name {name!r} cannot name a file in the output folder: it must be "
                f"1 to {MAX_NAME_CHARS} printable characters, not '.' or '..', without '/' or "
                "'\\'"
            )
        if name in seen:
            raise InvalidParameterError(f"two {what}s are named {name!r}: their files would clash")
        seen.add(name)


def run(args: argparse.Namespace) -> int:
    rig = load_rig(args.rig)
    check_output_names([camera.name for camera in rig], "camera")
    if args.motions == ["all"]:
        motions = [(m.name, m.motion) for m in load_library()]
    else:
        check_output_names([Path(n).stem for n in args.motions], "motion")
        motions = [(Path(n).stem, find_motion(n, asf=args.asf)) for n in args.motions]
    check_output_names([name for name, _ in motions], "motion")
    if not args.out.parent.is_dir():
        raise InvalidParameterError(f"{args.out}: folder {args.out.parent} does not exist")
    config = BuildConfig()
    body = build_body(config.body_shapes[0], config.low_poly_faces)
    pictures, labels = [], []
    bar = tqdm(total=len(motions) * len(rig), desc="rendering views", unit="view")
    try:
        for name, motion in motions:
            folder = args.out / name
            folder.mkdir(parents=True, exist_ok=True)
            vertices, fitted = pose_for_views(motion, body, rig, config.render_fps)
            for camera in fitted:
                masks = render_masks(vertices, body.faces, camera)
                vector = motion_image(masks, config.motion_image, clip_fps=config.render_fps)
                picture = motion_image_picture(vector, config.motion_image)
                if not args.no_masks:
                    np.savez_compressed(
                        folder / f"{camera.name}.npz", masks=masks, fps=config.render_fps
                    )
                save_image(picture, folder / f"{camera.name}.png")
                pictures.append(cv2.resize(picture, (128, 128), interpolation=cv2.INTER_NEAREST))
                labels.append(f"{name} {camera.azimuth_deg:.0f}/{camera.elevation_deg:.0f}")
                bar.update()
    except BaseException:
        bar.leave = False  # the error line is not written after a half-drawn bar
        raise
    finally:
        bar.close()
    sheet = contact_sheet(pictures, n_cols=len(rig), labels=labels)
    save_image(sheet, args.out / "motion_images.png")
    return 0
