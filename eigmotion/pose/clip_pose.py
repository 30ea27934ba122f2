"""A clip's 3D pose as ``eigmotion query --pose-out`` writes it: the continuous pose
(:mod:`eigmotion.pose.continuous_pose`), moved toward the pose network's 3D posture or
refined with its 2D keypoints (:mod:`eigmotion.pose.keypoint_fit`) when the cue says so
(:data:`~eigmotion.pose.keypoints.CUES`)."""

from __future__ import annotations

import os
import time
from typing import TYPE_CHECKING

from eigmotion.pose.continuous_pose import (
    ContinuousPose,
    ContinuousPoseConfig,
    continuous_pose,
)
from eigmotion.pose.keypoint_fit import KeypointFitConfig, fit_keypoints, toward_network
from eigmotion.pose.keypoints import pose_keypoints, resolve_cue

if TYPE_CHECKING:
    from eigmotion.retrieval.database import MotionDatabase, QueryResult
    from eigmotion.segmentation.video import ClipMasks


def clip_pose(
    db: MotionDatabase,
    result: QueryResult,
    clip: ClipMasks,
    path: str | os.PathLike | None,
    config: ContinuousPoseConfig | None = None,
    fit_config: KeypointFitConfig | None = None,
    progress: bool = False,
) -> ContinuousPose:
    """A clip's pose as ``eigmotion query --pose-out`` writes it: :func:`continuous_pose`,
    then (:func:`~eigmotion.pose.keypoints.resolve_cue` of ``config.cue``) with the
    world cue moved toward the pose network's 3D posture
    (:func:`eigmotion.pose.keypoint_fit.toward_network`), with the keypoints cue
    refined with its 2D keypoints (:func:`eigmotion.pose.keypoint_fit.fit_keypoints`).

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
    progress : bool
        A progress bar while the pose network runs on the clip's frames (only where
        the front end kept no answer of its own:
        :func:`~eigmotion.pose.keypoints.pose_keypoints`).

    Returns
    -------
    ContinuousPose
        ``timings_s["keypoints"]``: the time to get the network's answer, with the
        world and keypoints cues (next to nothing where the learned front end kept
        its own).
    """
    config = config or ContinuousPoseConfig()
    cue = resolve_cue(config.cue, path)
    pose = continuous_pose(db, result, clip.masks, clip.fps, config)
    if cue == "silhouette":
        return pose
    started = time.perf_counter()
    keypoints = pose_keypoints(clip, path, progress)
    pose.timings_s["keypoints"] = time.perf_counter() - started
    if cue == "world":
        return toward_network(pose, keypoints, fit_config)
    return fit_keypoints(pose, keypoints, fit_config)
