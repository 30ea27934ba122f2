"""The ``eigmotion track`` pipeline past the silhouettes: the posture dictionary the
command builds by default, and the joints per estimate that ``--joints-out`` writes.

Shared by the command and the development set's benchmark
(:mod:`eigmotion.evaluation.devset_tracking`), so that both run one code path.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from eigmotion.errors import InvalidParameterError
from eigmotion.mocap.library import find_motion
from eigmotion.tracking.dictionary import PostureDictionary, build_dictionary
from eigmotion.tracking.keypoint_fit import FittedPoses, KeypointFitter
from eigmotion.tracking.tracker import SilhouetteTracker, TrackResult
from eigmotion.tracking.triangulation import KEYPOINT_JOINTS, triangulate_clip

#: Motions of the default dictionary (library names): CMU walks and both turns.
DEFAULT_DICTIONARY = ("walk_02_01", "walk_16_15", "turn_16_17", "turn_16_19")

#: Turns of the default dictionary's postures about the vertical, degrees.
DEFAULT_HEADING_STEP_DEG = 15.0

#: Near-duplicate postures (d1 below this, degrees) the default dictionary drops.
DEFAULT_PRUNE_DEG = 5.0

#: Estimates per second of video the command asks by default (as the paper).
DEFAULT_ESTIMATE_FPS = 25.0


def read_motion(spec: str, asf: Path | None = None):
    """A motion from a ``.bvh`` / ``.amc`` file or a library name."""
    if Path(spec).suffix.lower() in (".bvh", ".amc") and not Path(spec).is_file():
        raise InvalidParameterError(f"{spec}: motion file not found")
    return find_motion(spec, asf)


def dictionary_from_specs(
    specs: Sequence[str] | None = None,
    asf: Path | None = None,
    heading_step_deg: float = DEFAULT_HEADING_STEP_DEG,
    prune_deg: float = DEFAULT_PRUNE_DEG,
) -> PostureDictionary:
    """The posture dictionary of ``eigmotion track --dictionary SPECS``.

    Parameters
    ----------
    specs : sequence of str, optional
        Motions (``.bvh``, ``.amc`` with ``asf``, library names) or one saved dictionary
        ``.npz``; default :data:`DEFAULT_DICTIONARY`.
    asf : Path, optional
        The skeleton of ``.amc`` motions.
    heading_step_deg : float
        Postures are turned to every multiple of this angle about the vertical, degrees;
        0 keeps the recorded headings.
    prune_deg : float
        Near-duplicate postures (d1 below this, degrees) are dropped.
    """
    specs = list(specs or DEFAULT_DICTIONARY)
    if len(specs) == 1 and specs[0].lower().endswith(".npz"):
        return PostureDictionary.load(specs[0])
    if any(s.lower().endswith(".npz") for s in specs):
        raise InvalidParameterError("a saved dictionary (.npz) must be given on its own")
    step = heading_step_deg
    if not (np.isfinite(step) and 0 <= step <= 180):
        raise InvalidParameterError(f"--heading-step-deg must be in [0, 180], got {step}")
    headings = (0.0,) if step == 0 else tuple(np.arange(-180.0, 180.0, step))
    motions = [read_motion(s, asf) for s in specs]
    return build_dictionary(
        motions, threshold_deg=prune_deg, headings_deg=headings, face_forward=step > 0
    )


@dataclass(frozen=True, eq=False)
class TrackedClip:
    """A tracked clip, with the person's first estimate held before it was first seen.

    Attributes
    ----------
    result : TrackResult
    frame_step : int
        Every ``frame_step``-th input frame was tracked.
    first : int
        The first estimate that found the person.
    entries : (E,) int64
        Dictionary entry per estimate.
    positions_m : (E, 3) float64
        Body-centre positions, world metres.
    joints_m : (E, J, 3) float64
        Joint positions, world metres (``--joints-out``'s ``positions``): the fitted
        ones when the keypoints stage or the paths' smoothing ran.
    wall_s, cpu_s : float
        Wall and CPU time (this process, :func:`time.process_time`) of the tracking
        itself (the keypoints stage and the smoothing included), seconds.
    fitted : FittedPoses or None
        The postures of the keypoints stage and the paths' smoothing
        (:func:`fitted_poses`); None when neither ran.
    """

    result: TrackResult
    frame_step: int
    first: int
    entries: np.ndarray
    positions_m: np.ndarray
    joints_m: np.ndarray
    wall_s: float
    cpu_s: float
    fitted: FittedPoses | None = None


def fitted_poses(
    tracker: SilhouetteTracker,
    result: TrackResult,
    landmarks: Sequence[np.ndarray] | None,
) -> FittedPoses:
    """The tracker's estimates fitted to the joints triangulated from every camera's
    landmarks (the keypoints stage: :func:`~eigmotion.tracking.triangulation.triangulate_clip`,
    then :class:`~eigmotion.tracking.keypoint_fit.KeypointFitter`), then to their own
    paths smoothed over time (``joint_smooth_s``).

    Parameters
    ----------
    tracker : SilhouetteTracker
    result : TrackResult
        Its estimates of the clip.
    landmarks : sequence of (F, 33, 4) float, or None
        Per camera, the pose network's landmarks of every input frame; None: the paths
        are only smoothed.
    """
    targets = None
    if landmarks is not None:
        names = list(result.joint_names)
        own = result.joint_positions_m[:, [names.index(n) for n in KEYPOINT_JOINTS]]
        views = [np.asarray(m)[result.frames] for m in landmarks]
        targets = triangulate_clip(tracker.cameras, views, own).positions_m
    fitter = KeypointFitter(tracker.dictionary)
    return fitter.fit(
        result.entries, result.joint_positions_m, targets,
        tracker.config.keypoint_weight,
        tracker.config.joint_smooth_s / result.frame_time_s,
    )  # fmt: skip


def track_clip(
    tracker: SilhouetteTracker,
    masks: Sequence[np.ndarray],
    fps: float,
    estimate_fps: float = DEFAULT_ESTIMATE_FPS,
    landmarks: Sequence[np.ndarray | None] | None = None,
) -> TrackedClip:
    """Track the silhouettes of every camera as ``eigmotion track`` does.

    Parameters
    ----------
    tracker : SilhouetteTracker
    masks : sequence of (F, H, W) bool
        One per camera, in calibration order.
    fps : float
        The videos' frames per second.
    estimate_fps : float
        Estimates per second of video: every ``round(fps / estimate_fps)``-th frame.
    landmarks : sequence of ((F, 33, 4) float or None), optional
        Per camera, the pose network's landmarks of every frame (x, y in frame pixels,
        continuous; visibility; presence), as the learned and fused front ends give
        them.  With every camera's, two cameras or more and the tracker's
        ``keypoints`` on, the keypoints stage runs (:func:`fitted_poses`).

    Raises
    ------
    InvalidParameterError
        ``estimate_fps`` not positive, or no person in any frame.
    """
    if not (np.isfinite(estimate_fps) and estimate_fps > 0):
        raise InvalidParameterError(f"--estimate-fps must be > 0, got {estimate_fps}")
    step = max(1, int(round(fps / estimate_fps)))
    wall, cpu = time.perf_counter(), time.process_time()
    result = tracker.track(masks, frame_step=step, frame_time_s=1.0 / fps)
    stage = tracker.config.keypoints and len(masks) >= 2
    if not (stage and landmarks is not None and all(m is not None for m in landmarks)):
        landmarks = None
    fitted = None
    if landmarks is not None or tracker.config.joint_smooth_s > 0:
        fitted = fitted_poses(tracker, result, landmarks)
    cpu = time.process_time() - cpu
    wall = time.perf_counter() - wall
    if not np.any(result.found):
        raise InvalidParameterError("no person was found in any frame of the videos")
    first = int(np.argmax(result.entries >= 0))
    entries = result.entries.copy()
    entries[:first] = entries[first]
    positions = result.positions_m.copy()
    positions[:first] = positions[first]
    joints = (result.joint_positions_m if fitted is None else fitted.joints_m).copy()
    joints[:first] = joints[first]
    return TrackedClip(result, step, first, entries, positions, joints, wall, cpu, fitted)
