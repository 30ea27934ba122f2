"""3D replay of a retrieved motion: BVH out and a side-by-side video.

The database answers a clip with a basic motion, the window of it that matched and
the virtual camera that saw it as the clip's camera sees the person.  Replaying it
means putting that window on the avatar, turning it so that the clip's camera would
stand at azimuth 0 (on +Z, looking at the body's front side as the virtual camera at
the matched azimuth did), and stretching it over the clip's duration.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from eigmotion.body.avatar import Avatar, load_default_avatar
from eigmotion.body.retarget import animation_to_motion, pose_avatar, retarget
from eigmotion.errors import InvalidParameterError
from eigmotion.imaging.figures import side_by_side, stretched_frames, with_captions
from eigmotion.imaging.framing import frame_cameras
from eigmotion.imaging.media import FrameSampleStream, write_video
from eigmotion.imaging.render import render_shaded
from eigmotion.mocap.motion import Motion
from eigmotion.mocap.rotations import axis_rotation
from eigmotion.retrieval.results import Segment, frame_range

#: Height of each panel of a replay video, pixels.
PANEL_HEIGHT_PX = 240


@dataclass(frozen=True, eq=False)
class Replay:
    """A retrieved motion window, on the avatar, facing the clip's camera.

    Attributes
    ----------
    motion : Motion
        On the avatar's canonical skeleton, metres, at the clip's frame rate and
        length; the root starts above the origin.
    vertices : (F, V, 3) float32
        The skinned avatar per frame, metres.
    faces : (T, 3) int32
    elevation_deg : float
        Elevation of the camera that saw it (its azimuth is 0 after turning).
    """

    motion: Motion
    vertices: np.ndarray
    faces: np.ndarray
    elevation_deg: float


def turn_about_vertical(motion: Motion, angle_deg: float) -> Motion:
    """Turn a whole motion about the world Y axis through its first root position.

    Parameters
    ----------
    motion : Motion
        Any skeleton whose root carries the rotation and translation channels.
    angle_deg : float
        Counter-clockwise seen from above (+X towards −Z), degrees.

    Returns
    -------
    Motion
        The same motion turned, its root's first horizontal position moved to x = z = 0.
    """
    turn = axis_rotation("Y", angle_deg)
    rot = motion.local_rotations()
    trans = motion.local_translations()
    rot[:, 0] = turn @ rot[:, 0]
    trans[:, 0] = trans[:, 0] @ turn.T
    trans[:, 0, [0, 2]] -= trans[0, 0, [0, 2]]
    return motion.with_local_transforms(rot, trans)


def replay(
    motion: Motion,
    window: tuple[int, int],
    azimuth_deg: float,
    elevation_deg: float,
    n_frames: int,
    fps: float,
    avatar: Avatar | None = None,
) -> Replay:
    """The matched window of a motion, replayed over the clip's timeline.

    Parameters
    ----------
    motion : Motion
        The basic motion (any skeleton the avatar can be driven by).
    window : (int, int)
        ``[start, stop)`` frames of ``motion`` that matched.
    azimuth_deg, elevation_deg : float
        The matched virtual camera's view of the motion.
    n_frames : int
        Frames of the clip (>= 1).
    fps : float
        The clip's frame rate, frames per second.
    avatar : Avatar, optional
        Default :func:`eigmotion.body.avatar.load_default_avatar`.

    Returns
    -------
    Replay
    """
    start, stop = int(window[0]), int(window[1])
    if not 0 <= start < stop <= motion.n_frames:
        raise InvalidParameterError(
            f"window [{start}, {stop}) is outside motion {motion.name!r} "
            f"of {motion.n_frames} frames"
        )
    if n_frames < 1 or not fps > 0:
        raise InvalidParameterError(f"need n_frames >= 1 and fps > 0, got {n_frames}, {fps}")
    avatar = avatar or load_default_avatar()
    part = motion.trim(start, stop)
    anim = retarget(part, avatar)
    on_avatar = turn_about_vertical(animation_to_motion(anim, avatar), -azimuth_deg)
    # Stretch the window over the clip: same first and last pose, the clip's frame count.
    if n_frames > 1 and on_avatar.n_frames > 1:
        stretched_time_s = (n_frames - 1) / fps / (on_avatar.n_frames - 1)
        on_avatar = on_avatar.replace(frame_time_s=stretched_time_s).resample(fps)
        if on_avatar.n_frames < n_frames:  # rounding at the very end
            pad = np.repeat(on_avatar.values[-1:], n_frames - on_avatar.n_frames, axis=0)
            on_avatar = on_avatar.replace(values=np.concatenate([on_avatar.values, pad]))
        on_avatar = on_avatar.trim(0, n_frames)
    else:
        on_avatar = on_avatar.trim(0, 1).replace(frame_time_s=1.0 / fps)
    on_avatar = on_avatar.replace(name=f"{motion.name}_{start}_{stop}")
    anim_out = retarget(on_avatar, avatar)
    return Replay(on_avatar, pose_avatar(avatar, anim_out), avatar.faces, float(elevation_deg))


def replay_video(
    result: Replay,
    clip_frames: np.ndarray | None,
    masks: np.ndarray,
    motion_picture: np.ndarray,
    path: str | Path,
    fps: float,
    height_px: int = PANEL_HEIGHT_PX,
    progress: bool = False,
    captions: Sequence[str] | None = None,
) -> Path:
    """Write input | silhouettes | motion image | avatar replay, side by side.

    Parameters
    ----------
    result : Replay
    clip_frames : (F, H, W, 3) uint8 or None
        The query clip (``None`` for a clip given as masks only), at any size; read
        by :func:`read_input_panel` it is at the panel height already.
    masks : (F, H, W) bool
        Its silhouettes.
    motion_picture : (S, S) uint8
        The clip's motion image (:func:`eigmotion.retrieval.motion_image.motion_image_picture`).
    path : str or Path
        ``.mp4``, ``.avi`` or ``.gif``.
    fps : float
    height_px : int
        Panel height, pixels.
    captions : sequence of F str, optional
        What each clip frame shows (its segment), written in a band under it; ``F``
        is the number of ``masks``.

    Returns
    -------
    Path
    """
    if captions is not None and len(captions) != len(masks):
        raise InvalidParameterError(
            f"captions must hold one string per mask: {len(captions)} for {len(masks)}"
        )

    times_s = np.arange(len(result.vertices)) * result.motion.frame_time_s
    cameras = frame_cameras(
        result.vertices, times_s, 0.0, result.elevation_deg, height_px, height_px
    )
    shaded = render_shaded(result.vertices, result.faces, cameras, progress=progress)
    panels = [masks, motion_picture[None], shaded]
    titles = ["silhouettes", "motion image", "replay"]
    if clip_frames is not None:
        panels.insert(0, clip_frames)
        titles.insert(0, "input")
    frames = side_by_side(panels, titles, height_px=height_px)
    if captions is not None:
        shown = stretched_frames(len(frames), len(masks))
        frames = with_captions(frames, [captions[i] for i in shown])
    return write_video(frames, path, fps)


def segment_captions(segments: Sequence[Segment], n_frames: int, answer: str) -> list[str]:
    """One caption per clip frame: the clip's answer and the segment the frame lies in
    (``"answer: wave   frames 30-62: wave"``, both ends included), the answer alone where
    no segment is.

    Parameters
    ----------
    segments : sequence of Segment
        A query's (:class:`~eigmotion.retrieval.results.QueryResult`), frames of the clip.
    n_frames : int
    answer : str
        What the clip was answered (its label, or that it is unknown).
    """
    captions = [f"answer: {answer}"] * n_frames
    for segment in segments:
        start, end = segment.start_frame, segment.end_frame
        text = f"answer: {answer}   {frame_range(start, end, dash='-')}: {segment.label}"
        for f in range(max(start, 0), min(end, n_frames)):
            captions[f] = text
    return captions


def read_input_panel(path: str | Path, height_px: int = PANEL_HEIGHT_PX) -> np.ndarray:
    """The query clip for the input panel of :func:`replay_video`.

    Parameters
    ----------
    path : str or Path
        A clip :func:`eigmotion.imaging.media.read_frames` reads.
    height_px : int
        Panel height, pixels.

    Returns
    -------
    (F, H', W', 3) uint8
        Every frame, RGB.  Frames taller than ``height_px`` are scaled to it as they
        are decoded (area averaging, the aspect ratio kept), so that a long clip in
        high definition is never held at its full size.
    """

    def to_panel(frame: np.ndarray) -> np.ndarray:
        h, w = frame.shape[:2]
        if h <= height_px:
            return frame
        size = (max(1, int(round(w * height_px / h))), int(height_px))
        return cv2.resize(frame, size, interpolation=cv2.INTER_AREA)

    return np.concatenate(list(FrameSampleStream(path, transform=to_panel).chunks(16)))
