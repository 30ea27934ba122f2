"""``eigmotion show MOTION --out FILE``: a motion on the default avatar, rendered.

The output's extension picks the product:

* ``.png`` / ``.jpg`` — a contact sheet of ``--frames`` evenly spaced frames (the first
  and the last included; the middle one alone for ``--frames 1``), each labelled with
  its time;
* ``.gif`` / ``.mp4`` / ``.mov`` / ``.avi`` — the whole motion, resampled to ``--fps``.

Framing (``--framing``, see :func:`eigmotion.imaging.framing.frame_cameras`): ``fixed`` is one
camera in the ``--view`` direction framing the whole clip; ``follow`` slides a camera
along with the body; ``auto`` (default) follows when the body travels more than
:data:`eigmotion.imaging.framing.FOLLOW_TRAVEL_M`.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from eigmotion.body.avatar import load_default_avatar
from eigmotion.body.retarget import animate_avatar, retarget
from eigmotion.errors import InvalidParameterError
from eigmotion.imaging.figures import contact_sheet, save_image
from eigmotion.imaging.framing import frame_cameras
from eigmotion.imaging.media import write_video
from eigmotion.imaging.render import Renderer
from eigmotion.limits import check_clip_size, check_frame_pixels, check_rendered_frames
from eigmotion.mocap.library import find_motion

SHEET_EXTENSIONS = (".png", ".jpg", ".jpeg")
VIDEO_EXTENSIONS = (".gif", ".mp4", ".mov", ".avi")

#: Front-three-quarter view: azimuth and elevation of the default camera, degrees.
DEFAULT_VIEW_DEG = (35.0, 10.0)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("motion", help="a library motion name, or a .bvh / .amc file")
    parser.add_argument("--asf", type=Path, help="the skeleton (.asf) of an .amc motion")
    parser.add_argument(
        "--out",
        type=Path,
        required=True,
        help="output: .png/.jpg (contact sheet) or .gif/.mp4/.mov/.avi (replay)",
    )
    parser.add_argument(
        "--view",
        nargs=2,
        type=float,
        metavar=("AZ", "EL"),
        default=DEFAULT_VIEW_DEG,
        help="camera azimuth (from the body's front towards its left) and elevation, "
        "degrees (default: %(default)s)",
    )
    parser.add_argument(
        "--fps", type=float, default=30.0, help="replay frame rate (default: %(default)s)"
    )
    parser.add_argument(
        "--size",
        nargs=2,
        type=int,
        metavar=("W", "H"),
        help="image size in pixels (default: 480 480 for a replay, 320 320 per sheet panel)",
    )
    parser.add_argument(
        "--frames", type=int, default=8, help="frames on a contact sheet (default: %(default)s)"
    )
    parser.add_argument(
        "--cols", type=int, default=4, help="contact sheet columns (default: %(default)s)"
    )
    parser.add_argument(
        "--framing",
        choices=("auto", "fixed", "follow"),
        default="auto",
        help="fixed camera, or following the body (default: %(default)s)",
    )
    parser.add_argument(
        "--floor",
        choices=("checker", "plain", "none"),
        default="checker",
        help="floor at y = 0 (default: %(default)s)",
    )
    parser.add_argument("--shadows", action="store_true", help="cast shadows (slower)")


def run(args: argparse.Namespace) -> int:
    out = Path(args.out)
    suffix = out.suffix.lower()
    if suffix not in SHEET_EXTENSIONS + VIDEO_EXTENSIONS:
        raise InvalidParameterError(
            f"--out {out}: unknown output type {suffix or '(no extension)'!r}; expected "
            f"one of {', '.join(SHEET_EXTENSIONS + VIDEO_EXTENSIONS)}"
        )
    if not (np.isfinite(args.fps) and args.fps > 0):
        raise InvalidParameterError(f"--fps must be > 0, got {args.fps}")
    if args.frames < 1 or args.cols < 1:
        raise InvalidParameterError(
            f"--frames and --cols must be >= 1, got {args.frames} and {args.cols}"
        )
    az, el = (float(v) for v in args.view)
    if not -89.0 <= el <= 89.0:
        raise InvalidParameterError(f"--view elevation must be within [-89, 89] degrees, got {el}")
    sheet = suffix in SHEET_EXTENSIONS
    width, height = args.size if args.size else ((320, 320) if sheet else (480, 480))
    if width < 16 or height < 16:
        raise InvalidParameterError(f"--size must be at least 16×16 pixels, got {width}×{height}")
    check_frame_pixels(width, height, "--size")

    motion = find_motion(args.motion, asf=args.asf)
    if sheet:
        n_images = min(args.frames, motion.n_frames)
    else:
        end_s = (motion.n_frames - 1) * motion.frame_time_s
        n_images = int(min(end_s * args.fps, 2**62)) + 1
    check_rendered_frames(n_images, f"--out {out}")
    check_clip_size(n_images, width * height * 3, f"--out {out}")
    avatar = load_default_avatar()
    if sheet:
        anim = retarget(motion, avatar)  # the whole clip: it sets the floor contact
        if args.frames == 1:  # one frame: the middle one
            frames = np.array([motion.n_frames // 2])
        else:
            frames = np.linspace(0, motion.n_frames - 1, args.frames)
            frames = np.unique(np.round(frames).astype(int))
        vertices = avatar.skin(anim.joint_rotations[frames], anim.joint_positions[frames])
        times_s = frames * motion.frame_time_s
    else:
        motion = motion.resample(args.fps)
        anim, vertices = animate_avatar(avatar, motion)
        times_s = np.arange(motion.n_frames) * motion.frame_time_s

    cameras = frame_cameras(vertices, times_s, az, el, width, height, args.framing)

    with Renderer() as renderer:
        images = renderer.render_shaded(
            vertices,
            avatar.faces,
            cameras,
            floor=args.floor != "none",
            checker=args.floor == "checker",
            shadows=args.shadows,
            progress=len(vertices) > 20,
        )
    name = motion.name or Path(args.motion).stem
    if sheet:
        labels = [f"{t:.2f} s" for t in times_s]
        title = f"{name}: {motion.n_frames} frames at {motion.fps:g} fps, view az {az:g} el {el:g}"
        save_image(contact_sheet(list(images), args.cols, labels, title), out)
        print(f"wrote {out}: {_frames(len(images))} of {name} on a contact sheet")
    else:
        write_video(images, out, args.fps)
        print(
            f"wrote {out}: {_frames(len(images))} of {name}, {width}×{height} at {args.fps:g} fps",
        )
    return 0


def _frames(n: int) -> str:
    return f"{n} frame" if n == 1 else f"{n} frames"
