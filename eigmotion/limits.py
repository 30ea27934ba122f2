"""Size limits on what the readers accept, checked before any large allocation.

Every file a user hands over (a motion, a clip, a frame, stored masks) and every
option that multiplies work (a resampling rate) is measured from its header or its
options first; beyond these limits the reader raises one
:class:`~eigmotion.errors.InvalidParameterError` naming the limit, instead of
allocating gigabytes.  The limits are far above any real motion capture or clip (see
``docs/motion-formats.md``, "Size limits").
"""

from __future__ import annotations

from eigmotion.errors import InvalidParameterError

#: Largest motion file (BVH, ASF, AMC) read, bytes.
MAX_MOTION_FILE_BYTES = 256 * 2**20
#: Most joints in a skeleton (CMU's has 31, a full-hand rig a few hundred).
MAX_JOINTS = 1000
#: Most frames in a motion (over 2 hours at 120 frames/s).
MAX_FRAMES = 1_000_000
#: Most frames × joints in a motion (22 minutes of a 31-joint skeleton at 120 frames/s).
MAX_FRAME_JOINTS = 5_000_000
#: Frame rates a motion may have, frames/s (frame times from 0.1 ms to 10 s).
MIN_MOTION_FPS = 0.1
MAX_MOTION_FPS = 10_000.0
#: Longest motion, seconds (2 hours).
MAX_MOTION_DURATION_S = 7200.0
#: Largest text written for one BVH file, bytes.
MAX_BVH_OUTPUT_BYTES = 1 * 2**30
#: Most pixels in one frame or image (8K UHD is 33.2 million).
MAX_FRAME_PIXELS = 40_000_000
#: Most frames taken from one clip (20 minutes at 30 frames/s).
MAX_CLIP_FRAMES = 36_000
#: Largest clip held decoded in memory at once, bytes.
MAX_CLIP_BYTES = 1 * 2**30
#: Most frames of a motion rendered on the avatar at once (2 minutes at 30 frames/s).
MAX_RENDERED_FRAMES = 3600
#: Largest array read from an ``.npz`` file, bytes.
MAX_NPZ_ARRAY_BYTES = 512 * 2**20


def _size(n_bytes: float) -> str:
    return f"{n_bytes / 2**20:,.0f} MiB"


def check_file_size(size_bytes: int, limit_bytes: int, what: str) -> None:
    """InvalidParameterError when a file is larger than ``limit_bytes``.

    Parameters
    ----------
    size_bytes, limit_bytes : int
        The file's size and the most accepted, bytes.
    what : str
        The file, for the message.
    """
    if size_bytes > limit_bytes:
        raise InvalidParameterError(
            f"{what} is {_size(size_bytes)}; at most {_size(limit_bytes)} is read"
        )


def check_motion_size(n_frames: int, n_joints: int, frame_time_s: float, what: str) -> None:
    """InvalidParameterError when a motion is beyond the limits above.

    Parameters
    ----------
    n_frames, n_joints : int
        The motion's frames and joints.
    frame_time_s : float
        Seconds per frame.
    what : str
        The file or operation, for the message (e.g. ``"walk.bvh"``).
    """
    if n_joints > MAX_JOINTS:
        raise InvalidParameterError(
            f"{what}: {n_joints:,} joints; at most {MAX_JOINTS:,} are supported"
        )
    if not frame_time_s * MAX_MOTION_FPS >= 1.0 or not frame_time_s * MIN_MOTION_FPS <= 1.0:
        raise InvalidParameterError(
            f"{what}: a frame time of {frame_time_s:.6g} s ({1 / frame_time_s:.6g} frames/s) "
            f"is outside {1 / MAX_MOTION_FPS:g}..{1 / MIN_MOTION_FPS:g} s"
            if frame_time_s > 0
            else f"{what}: the frame time must be > 0 s, got {frame_time_s!r}"
        )
    if n_frames > MAX_FRAMES:
        raise InvalidParameterError(
            f"{what}: {n_frames:,} frames; at most {MAX_FRAMES:,} are supported"
        )
    if n_frames * n_joints > MAX_FRAME_JOINTS:
        raise InvalidParameterError(
            f"{what}: {n_frames:,} frames × {n_joints:,} joints; at most "
            f"{MAX_FRAME_JOINTS:,} joint poses are supported (trim the motion)"
        )
    duration_s = n_frames * frame_time_s
    if duration_s > MAX_MOTION_DURATION_S:
        raise InvalidParameterError(
            f"{what}: {n_frames:,} frames of {frame_time_s:.6g} s last {duration_s:,.0f} s; "
            f"at most {MAX_MOTION_DURATION_S:,.0f} s are supported"
        )


def check_frame_pixels(width: int, height: int, what: str) -> None:
    """InvalidParameterError when a frame holds more than :data:`MAX_FRAME_PIXELS`."""
    if width * height > MAX_FRAME_PIXELS:
        raise InvalidParameterError(
            f"{what}: a frame of {width:,}×{height:,} pixels; at most "
            f"{MAX_FRAME_PIXELS / 1e6:g} million pixels per frame are read"
        )


def check_clip_size(n_frames: int, frame_bytes: int, what: str) -> None:
    """InvalidParameterError when a clip holds more frames, or more decoded bytes, than
    :data:`MAX_CLIP_FRAMES` and :data:`MAX_CLIP_BYTES` allow."""
    if n_frames > MAX_CLIP_FRAMES:
        raise InvalidParameterError(
            f"{what}: more than {MAX_CLIP_FRAMES:,} frames; trim the clip or sample it "
            "at a lower rate"
        )
    if n_frames * frame_bytes > MAX_CLIP_BYTES:
        raise InvalidParameterError(
            f"{what}: {n_frames:,} frames of {_size(frame_bytes)} exceed the "
            f"{_size(MAX_CLIP_BYTES)} held in memory at once; trim the clip or use a "
            "video file"
        )


def check_rendered_frames(n_frames: int, what: str) -> None:
    """InvalidParameterError when more than :data:`MAX_RENDERED_FRAMES` frames of a
    motion would be rendered (checked before the avatar is posed)."""
    if n_frames > MAX_RENDERED_FRAMES:
        raise InvalidParameterError(
            f"{what}: {n_frames:,} frames to render; at most {MAX_RENDERED_FRAMES:,} are "
            "rendered (trim the motion or lower the frame rate)"
        )
