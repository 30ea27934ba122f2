"""A clip's 3D pose as ``eigmotion query --pose-out`` writes it: the continuous pose
(:mod:`eigmotion.pose.continuous_pose`), refined with the pose network's 2D keypoints
(:mod:`eigmotion.pose.keypoint_fit`) when the cue says so (:data:`~eigmotion.pose.
continuous_pose.CUES`)."""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import TYPE_CHECKING

from eigmotion.errors import InvalidParameterError
from eigmotion.pose.continuous_pose import (
    CUES,
    ContinuousPose,
    ContinuousPoseConfig,
    continuous_pose,
)
from eigmotion.pose.keypoint_fit import KeypointFitConfig, fit_keypoints
from eigmotion.pose.keypoints import clip_keypoints, keypoints_available

if TYPE_CHECKING:
    from eigmotion.retrieval.database import MotionDatabase, QueryResult
    from eigmotion.segmentation.video import ClipMasks


def resolve_cue(cue: str, path: str | os.PathLike | None) -> str:
    """The cue a clip's pose is fitted to: ``"silhouette"`` or ``"keypoints"``.

    Parameters
    ----------
    cue : {"auto", "silhouette", "keypoints"}
    path : str or PathLike or None
        The clip on disk; ``None`` or an ``.npz`` of masks: no frames to see.

    Raises
    ------
    InvalidParameterError
        An unknown cue, or ``"keypoints"`` without frames or without LiteRT.
    """
    if cue not in CUES:
        raise InvalidParameterError(f"pose cue must be one of {', '.join(CUES)}, got {cue!r}")
    frames = path is not None and Path(path).suffix.lower() != ".npz"
    if cue == "auto":
        return "keypoints" if frames and keypoints_available() else "silhouette"
    if cue == "keypoints" and not frames:
        raise InvalidParameterError(
            "the keypoints cue needs the clip's frames (a video or images), not stored masks"
        )
    if cue == "keypoints" and not keypoints_available():
        raise InvalidParameterError(
            "the keypoints cue runs the pose network through LiteRT: "
            "pip install 'eigmotion[segmenter]'"
        )
    return cue


def clip_pose(
    db: MotionDatabase,
    result: QueryResult,
    clip: ClipMasks,
    path: str | os.PathLike | None,
    config: ContinuousPoseConfig | None = None,
    fit_config: KeypointFitConfig | None = None,
) -> ContinuousPose:
    """A clip's pose as ``eigmotion query --pose-out`` writes it: :func:`continuous_pose`,
    then, with the keypoints cue (:func:`resolve_cue` of ``config.cue``), refined with
    the pose network's 2D keypoints (:func:`eigmotion.pose.keypoint_fit.fit_keypoints`).

    Parameters
    ----------
    db : MotionDatabase
    result : QueryResult
    clip : ClipMasks
        The silhouettes of every frame (``query_clip(..., every_frame=True)``).
    path : str or PathLike or None
        The clip on disk the silhouettes were cut from.
    config : ContinuousPoseConfig, optional
    fit_config : KeypointFitConfig, optional

    Returns
    -------
    ContinuousPose
        ``timings_s["keypoints"]``: the network's time, with the keypoints cue.
    """
    config = config or ContinuousPoseConfig()
    cue = resolve_cue(config.cue, path)
    pose = continuous_pose(db, result, clip.masks, clip.fps, config)
    if cue == "silhouette":
        return pose
    started = time.perf_counter()
    keypoints = clip_keypoints(path, clip.masks, clip.frame_indices)
    pose.timings_s["keypoints"] = time.perf_counter() - started
    return fit_keypoints(pose, keypoints, fit_config)
