"""The pose landmark network's 2D keypoints and 3D world landmarks for a clip.

The network is MediaPipe's pose landmark network (full model, Apache-2.0), shipped
with the package (:data:`eigmotion.segmentation.networks.POSE_PATH`).  It sees a
256×256 square centred on the person, cut by the learned front end's rule
(:func:`eigmotion.segmentation.learned.crop_input`: :data:`~eigmotion.segmentation.
learned.CROP_MARGIN` times the longer side of the box around the person's silhouette,
at least a fifth of the frame's longer side and :data:`~eigmotion.segmentation.learned.
CROP_MIN_SIDE_PX` pixels), and answers with:

* 33 body landmarks (BlazePose topology), x and y in the square's pixels, with their
  visibility and presence (probabilities);
* the same 33 landmarks (plus 6 auxiliary points) in metres, centred between the hips,
  axes those of the camera: x right, y down, z away from the camera ("world
  landmarks");
* the probability that a person is in the square.

:data:`LIMB_LANDMARKS` names the landmarks of the 12 limb joints (shoulders, elbows,
wrists, hips, knees, ankles) in the development set's names.

It runs through LiteRT only (``ai-edge-litert``, installed with eigmotion where LiteRT
has a wheel); :func:`keypoints_available` says whether it can.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from eigmotion.errors import InvalidParameterError
from eigmotion.imaging.media import progress_bar, read_frames
from eigmotion.segmentation.learned import (
    CROP_MARGIN,
    CROP_MIN_SIDE_PX,
    PERSON_PROBABILITY,
    crop_input,
    stored_frame,
)
from eigmotion.segmentation.networks import N_POSE_LANDMARKS, pose_network
from eigmotion.segmentation.video import ClipMasks

#: Development-set limb joint -> the pose network's landmark index (MediaPipe's order;
#: left and right are the person's).
LIMB_LANDMARKS = {
    "l_hip": 23,
    "r_hip": 24,
    "l_knee": 25,
    "r_knee": 26,
    "l_ankle": 27,
    "r_ankle": 28,
    "l_shoulder": 11,
    "r_shoulder": 12,
    "l_elbow": 13,
    "r_elbow": 14,
    "l_wrist": 15,
    "r_wrist": 16,
}

#: What a single-camera pose is fitted to: ``silhouette`` (the continuous pose alone),
#: ``world`` (its trunk and limbs then moved toward the pose network's own 3D posture,
#: its heading and place kept: :func:`eigmotion.pose.keypoint_fit.toward_network`),
#: ``keypoints`` (refined with the network's 2D keypoints first, heading included:
#: :func:`eigmotion.pose.keypoint_fit.fit_keypoints`), ``auto`` (world when the
#: clip's frames and LiteRT are at hand, else silhouette).
CUES = ("auto", "silhouette", "world", "keypoints")

#: The cues that run the pose network on the clip's frames.
NETWORK_CUES = ("world", "keypoints")


@dataclass(frozen=True)
class ClipKeypoints:
    """The pose network's answer for every frame of a clip.

    Attributes
    ----------
    image_px : (F, 33, 2) float64
        x, y of each landmark in the pixels of the clip's silhouettes (continuous: 0
        is the left or top edge of the first pixel); NaN where the network found no
        one.
    visibility : (F, 33) float64
        The network's visibility times its presence, in [0, 1]; 0 where it found no
        one.
    world_m : (F, 33, 3) float64
        World landmarks, metres, centred between the hips; x right, y down, z away
        from the camera; NaN where the network found no one.
    found : (F,) bool
        Frames where the network's flag says a person is in the square.
    seconds_per_frame : float
        Wall time of the network per frame (cropping included, reading not).
    """

    image_px: np.ndarray
    visibility: np.ndarray
    world_m: np.ndarray
    found: np.ndarray
    seconds_per_frame: float

    @property
    def n_frames(self) -> int:
        return len(self.found)


def keypoints_available() -> bool:
    """Whether the pose network can run here (LiteRT installed)."""
    return pose_network() is not None


def person_squares(masks: np.ndarray, frame_size: tuple[int, int]) -> np.ndarray:
    """The square the network sees in each frame, from the person's silhouette.

    Parameters
    ----------
    masks : (F, h, w) bool
        The clip's silhouettes.
    frame_size : (int, int)
        (H, W) of the frames the squares are cut from, pixels.

    Returns
    -------
    (F, 3) float64
        Centre x, centre y and side of each square, pixels of the frames; a frame
        without a silhouette takes the nearest frame's square.

    Raises
    ------
    InvalidParameterError
        No frame has a silhouette.
    """
    masks = np.asarray(masks, bool)
    h, w = masks.shape[1:]
    ay, ax = frame_size[0] / h, frame_size[1] / w
    longest = max(frame_size)
    squares = np.full((len(masks), 3), np.nan)
    for i, mask in enumerate(masks):
        rows, cols = np.flatnonzero(mask.any(1)), np.flatnonzero(mask.any(0))
        if not len(rows):
            continue
        x0, x1 = cols[0] * ax, (cols[-1] + 1) * ax
        y0, y1 = rows[0] * ay, (rows[-1] + 1) * ay
        side = max(CROP_MARGIN * max(x1 - x0, y1 - y0), 0.2 * longest, CROP_MIN_SIDE_PX)
        squares[i] = (x0 + x1) / 2, (y0 + y1) / 2, side
    have = np.flatnonzero(np.isfinite(squares[:, 0]))
    if not len(have):
        raise InvalidParameterError("no frame shows a person: no square for the pose network")
    nearest = have[np.abs(np.arange(len(masks))[:, None] - have[None]).argmin(1)]
    return squares[nearest]


#: Seconds the network runs on a clip's frames before its progress bar shows.
NETWORK_BAR_DELAY_S = 1.0


def frame_keypoints(
    frames: np.ndarray, masks: np.ndarray, progress: bool = False, only: np.ndarray | None = None
) -> ClipKeypoints:
    """The pose network's keypoints for frames whose silhouettes are known.

    Parameters
    ----------
    frames : (F, H, W, 3) uint8
        RGB frames.
    masks : (F, h, w) bool
        Their silhouettes (any size: boxes are scaled to the frames).
    progress : bool
        A progress bar on stderr, once the network has run for
        :data:`NETWORK_BAR_DELAY_S` (a short clip never shows one).
    only : (F,) bool, optional
        The frames the network runs on (the others: found no one); every frame when
        None.  A frame's square comes from the silhouettes either way.

    Returns
    -------
    ClipKeypoints
        Image coordinates in the pixels of ``masks``.

    Raises
    ------
    InvalidParameterError
        LiteRT not installed, frame and mask counts differ, or no silhouette.
    """
    pose = pose_network()
    if pose is None:
        raise InvalidParameterError(
            "the pose network runs through LiteRT only: pip install ai-edge-litert"
        )
    frames, masks = np.asarray(frames), np.asarray(masks, bool)
    if len(frames) != len(masks) or frames.ndim != 4 or masks.ndim != 3:
        raise InvalidParameterError(
            f"frames (F, H, W, 3) and masks (F, h, w) must match, got {frames.shape} and "
            f"{masks.shape}"
        )
    n = len(frames)
    if only is not None and np.shape(only) != (n,):
        raise InvalidParameterError(f"only must be ({n},) bool, got shape {np.shape(only)}")
    started = time.perf_counter()
    squares = person_squares(masks, frames.shape[1:3])
    to_mask = np.array([masks.shape[2] / frames.shape[2], masks.shape[1] / frames.shape[1]])
    image = np.full((n, N_POSE_LANDMARKS, 2), np.nan)
    visibility = np.zeros((n, N_POSE_LANDMARKS))
    world = np.full((n, N_POSE_LANDMARKS, 3), np.nan)
    found = np.zeros(n, bool)
    runs = np.flatnonzero(np.ones(n, bool) if only is None else np.asarray(only, bool))
    bar = None
    for done, i in enumerate(runs):
        if progress and bar is None and time.perf_counter() - started >= NETWORK_BAR_DELAY_S:
            bar = progress_bar(len(runs), "pose network", initial=done)
        if bar is not None:
            bar.update(1)
        square, matrix = crop_input(frames[i], tuple(squares[i]))
        out = pose(square.astype(np.float32) * np.float32(1.0 / 255.0))
        if out.person < PERSON_PROBABILITY:
            continue
        found[i] = True
        xy = out.landmarks[:, :2].astype(np.float64)
        # the square's pixels (continuous) back to the frame's, then the masks'
        frame_xy = (xy - 0.5 - matrix[:, 2]) / np.diag(matrix) + 0.5
        image[i] = frame_xy * to_mask
        visibility[i] = out.landmarks[:, 2].astype(np.float64) * out.landmarks[:, 3]
        world[i] = out.world
    if bar is not None:
        bar.close()
    seconds = (time.perf_counter() - started) / max(len(runs), 1)
    return ClipKeypoints(image, visibility, world, found, seconds)


def clip_keypoints(
    path: str | os.PathLike,
    masks: np.ndarray,
    frame_indices: np.ndarray,
    progress: bool = False,
    only: np.ndarray | None = None,
) -> ClipKeypoints:
    """The pose network's keypoints for a clip on disk whose silhouettes are known.

    Parameters
    ----------
    path : str or PathLike
        The video (or folder of frames, or GIF) the silhouettes were cut from.
    masks : (F, h, w) bool
        The silhouettes.
    frame_indices : (F,) int
        The clip frame each silhouette belongs to.
    progress : bool
        A progress bar while the network runs (:func:`frame_keypoints`).
    only : (F,) bool, optional
        The silhouettes' frames the network runs on (:func:`frame_keypoints`).

    Returns
    -------
    ClipKeypoints
        Image coordinates in the pixels of ``masks``.

    Raises
    ------
    InvalidParameterError
        LiteRT not installed, a silhouette of a frame the clip does not have.
    VideoError
        The clip cannot be read.
    """
    frames, _ = read_frames(Path(path), transform=stored_frame)
    frame_indices = np.asarray(frame_indices, np.int64)
    if len(frame_indices) != len(masks) or (
        len(frame_indices) and not 0 <= frame_indices.min() <= frame_indices.max() < len(frames)
    ):
        raise InvalidParameterError(
            f"{path}: {len(frames)} frames, but silhouettes of frames "
            f"{frame_indices.min()}..{frame_indices.max()} were given"
        )
    return frame_keypoints(frames[frame_indices], masks, progress, only)


def limb_world_joints(keypoints: ClipKeypoints) -> tuple[tuple[str, ...], np.ndarray]:
    """The network's world landmarks of the 12 limb joints, as a pose of its own.

    Frames where the network found no one take the nearest frame's.

    Returns
    -------
    names : tuple of str
        The development set's limb joint names (:data:`LIMB_LANDMARKS`).
    positions : (F, 12, 3) float64
        Metres, hip-centred, the camera's axes (x right, y down, z away from it).

    Raises
    ------
    InvalidParameterError
        The network found no one in any frame.
    """
    have = np.flatnonzero(keypoints.found)
    if not len(have):
        raise InvalidParameterError("the pose network found no one in any frame")
    nearest = have[np.abs(np.arange(keypoints.n_frames)[:, None] - have[None]).argmin(1)]
    names = tuple(LIMB_LANDMARKS)
    return names, keypoints.world_m[nearest][:, list(LIMB_LANDMARKS.values())]


def resolve_cue(cue: str, path: str | os.PathLike | None) -> str:
    """The cue a clip's pose is fitted to: ``"silhouette"``, ``"world"`` or
    ``"keypoints"``.

    Parameters
    ----------
    cue : {"auto", "silhouette", "world", "keypoints"}
    path : str or PathLike or None
        The clip on disk; ``None`` or an ``.npz`` of masks: no frames to see.

    Raises
    ------
    InvalidParameterError
        An unknown cue, or one of :data:`NETWORK_CUES` without frames or without LiteRT.
    """
    if cue not in CUES:
        raise InvalidParameterError(f"pose cue must be one of {', '.join(CUES)}, got {cue!r}")
    frames = path is not None and Path(path).suffix.lower() != ".npz"
    if cue == "auto":
        return "world" if frames and keypoints_available() else "silhouette"
    if cue in NETWORK_CUES and not frames:
        raise InvalidParameterError(
            f"the {cue} cue needs the clip's frames (a video or images), not stored masks"
        )
    if cue in NETWORK_CUES and not keypoints_available():
        raise InvalidParameterError(
            f"the {cue} cue runs the pose network through LiteRT: pip install ai-edge-litert"
        )
    return cue


def front_end_keypoints(clip: ClipMasks) -> ClipKeypoints | None:
    """The pose network's answer the learned front end already gave while it cut the
    clip's silhouettes, as :func:`clip_keypoints` gives it, without running the
    network again.

    The front end's square around the person comes from its own first look (the
    module :mod:`eigmotion.segmentation.learned`), not from the finished silhouettes,
    so the answer is close to, not equal to, :func:`clip_keypoints`'s.

    Parameters
    ----------
    clip : ClipMasks
        Silhouettes cut by the learned or fused front end.

    Returns
    -------
    ClipKeypoints or None
        Image coordinates in the pixels of ``clip.masks``; ``seconds_per_frame`` 0 (no
        network ran).  None where the front end kept no landmarks (background
        subtraction, stored masks, the selfie network's second look).
    """
    if clip.landmarks is None or clip.world_landmarks is None or clip.frame_size is None:
        return None
    landmarks = np.asarray(clip.landmarks, np.float64)
    found = np.isfinite(landmarks[:, :, :2]).all(axis=(1, 2))
    if not found.any():
        return None
    h, w = clip.masks.shape[1:]
    image = landmarks[:, :, :2] * np.array([w / clip.frame_size[1], h / clip.frame_size[0]])
    visibility = np.where(found[:, None], landmarks[:, :, 2] * landmarks[:, :, 3], 0.0)
    world = np.where(found[:, None, None], np.asarray(clip.world_landmarks, np.float64), np.nan)
    return ClipKeypoints(image, np.nan_to_num(visibility), world, found, 0.0)


def pose_keypoints(
    clip: ClipMasks, path: str | os.PathLike, progress: bool = False
) -> ClipKeypoints:
    """The pose network's answer for every silhouette of a clip: the learned front
    end's own (:func:`front_end_keypoints`) where it kept one, and the network run on
    the clip's frames (:func:`clip_keypoints`) for the frames where it did not (all of
    them after background subtraction or the selfie network's second look).

    Parameters
    ----------
    clip : ClipMasks
        The clip's silhouettes.
    path : str or PathLike
        The video (or folder of frames, or GIF) they were cut from.
    progress : bool
        A progress bar while the network runs.

    Returns
    -------
    ClipKeypoints
        Image coordinates in the pixels of ``clip.masks``; ``seconds_per_frame`` is
        the network's time per frame it ran on (0 when it did not run).

    Raises
    ------
    InvalidParameterError
        The network must run and cannot (:func:`clip_keypoints`).
    VideoError
        The clip cannot be read.
    """
    kept = front_end_keypoints(clip)
    if kept is None:
        return clip_keypoints(path, clip.masks, clip.frame_indices, progress)
    if kept.found.all():
        return kept
    again = clip_keypoints(path, clip.masks, clip.frame_indices, progress, only=~kept.found)
    take = again.found & ~kept.found
    return ClipKeypoints(
        np.where(take[:, None, None], again.image_px, kept.image_px),
        np.where(take[:, None], again.visibility, kept.visibility),
        np.where(take[:, None, None], again.world_m, kept.world_m),
        kept.found | take,
        again.seconds_per_frame,
    )
