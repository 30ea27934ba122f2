"""Smooth output motion by variable-speed playback of a reference (the paper's 2.4.5).

Dictionary postures alone are coarse and jitter from estimate to estimate.  Instead a
reference mocap sequence ``p(t)`` (typically the one the dictionary was built from) is
replayed at a varying speed that follows the estimates:

1. the output holds the start posture ``p(t0)`` until an estimate comes within
   ``start_threshold_deg`` (d1) of it;
2. from then on, each estimate moves the output to the reference frame closest (d1)
   to the estimate among the frames ``prev … prev + window_frames`` after the
   previous output frame ``prev``: the playback never goes back and never jumps more
   than the window in reference time.

The heading is not compared by default (the reference may have been recorded walking
another way than the person); the output takes the person's heading from the
estimates instead (:func:`playback_motion`).
"""

from __future__ import annotations

from numbers import Integral, Real
from typing import ClassVar

import numpy as np

from eigmotion.errors import InvalidParameterError
from eigmotion.mocap.motion import Motion, Skeleton, standard_channels
from eigmotion.tracking.dictionary import PostureSequence
from eigmotion.tracking.postures import d1_distance, heading_deg, wrap_deg, yaw_rotation
from eigmotion.validation import Interval, validate_params


class VariableSpeedPlayback:
    """Online variable-speed playback of a reference sequence.

    Parameters
    ----------
    reference_vectors : (R, D) float
        Posture vectors of the reference frames, degrees.
    start_frame : int
        ``t0``: the posture held until the person reaches it.
    start_threshold_deg : float
        d1 within which an estimate starts the playback, degrees.
    window_frames : int
        Largest step in reference frames per estimate, ≥ 1.
    compare_heading : bool
        Include the heading in the d1 comparisons.
    """

    #: The valid values of the scalar parameters (see :mod:`eigmotion.validation`);
    #: ``start_frame``, whose bound is the reference's length, is checked apart.
    _parameter_constraints: ClassVar[dict] = {
        "window_frames": Interval(Integral, 1, None),
        "start_threshold_deg": Interval(Real, 0.0, None, closed="neither", noun=""),
    }

    def __init__(
        self,
        reference_vectors: np.ndarray,
        start_frame: int = 0,
        start_threshold_deg: float = 20.0,
        window_frames: int = 12,
        compare_heading: bool = False,
    ):
        ref = np.asarray(reference_vectors, dtype=np.float64)
        if ref.ndim != 2 or len(ref) == 0:
            raise InvalidParameterError(
                f"reference_vectors must be a non-empty (R, D) array, got shape {ref.shape}"
            )
        if not 0 <= int(start_frame) < len(ref):
            raise InvalidParameterError(
                f"start_frame {start_frame} outside the reference's frames 0..{len(ref) - 1}"
            )
        validate_params(
            {"window_frames": window_frames, "start_threshold_deg": start_threshold_deg},
            self._parameter_constraints,
        )
        self.reference_vectors = ref.copy()
        if not compare_heading:
            self.reference_vectors[:, 0] = 0.0
        self.start_frame = int(start_frame)
        self.start_threshold_deg = float(start_threshold_deg)
        self.window_frames = int(window_frames)
        self.compare_heading = bool(compare_heading)
        self.frame_ = self.start_frame
        self.started_ = False

    def reset(self) -> None:
        """Back to holding the start posture."""
        self.frame_ = self.start_frame
        self.started_ = False

    def step(self, estimate_vector: np.ndarray) -> int:
        """The output reference frame for the next estimate.

        Parameters
        ----------
        estimate_vector : (D,) float
            Posture vector of the estimated posture, degrees.

        Returns
        -------
        int
            Reference frame to output, in ``[prev, prev + window_frames]``.
        """
        est = np.asarray(estimate_vector, dtype=np.float64).copy()
        if est.shape != self.reference_vectors.shape[1:]:
            raise InvalidParameterError(
                f"estimate_vector has shape {est.shape}, expected "
                f"{self.reference_vectors.shape[1:]}"
            )
        if not self.compare_heading:
            est[0] = 0.0
        if not self.started_:
            d = float(d1_distance(self.reference_vectors[self.start_frame], est))
            if d >= self.start_threshold_deg:
                return self.frame_
            self.started_ = True
        stop = min(self.frame_ + self.window_frames + 1, len(self.reference_vectors))
        d = d1_distance(self.reference_vectors[self.frame_ : stop], est)
        self.frame_ += int(np.argmin(d))
        return self.frame_


def variable_speed_playback(
    reference_vectors: np.ndarray,
    estimate_vectors: np.ndarray,
    start_frame: int = 0,
    start_threshold_deg: float = 20.0,
    window_frames: int = 12,
    compare_heading: bool = False,
) -> np.ndarray:
    """Reference frame per estimate (see :class:`VariableSpeedPlayback`).

    Parameters
    ----------
    reference_vectors : (R, D) float
    estimate_vectors : (E, D) float
        Posture vectors, degrees.

    Returns
    -------
    (E,) int64
        Non-decreasing, consecutive values at most ``window_frames`` apart.
    """
    playback = VariableSpeedPlayback(
        reference_vectors, start_frame, start_threshold_deg, window_frames, compare_heading
    )
    return np.array([playback.step(v) for v in np.asarray(estimate_vectors)], dtype=np.int64)


def playback_motion(
    sequence: PostureSequence,
    frames: np.ndarray,
    root_positions_m: np.ndarray,
    frame_time_s: float,
    headings_deg: np.ndarray | None = None,
    name: str = "tracked",
) -> Motion:
    """The output motion: reference postures placed at the tracked positions.

    Parameters
    ----------
    sequence : PostureSequence
        The reference.
    frames : (E,) int
        Reference frame per output frame (:func:`variable_speed_playback`).
    root_positions_m : (E, 3) float
        Tracked body-centre positions, world metres; the height is the reference's.
    frame_time_s : float
        Seconds per output frame.
    headings_deg : (E,) float, optional
        Heading of the person per output frame, degrees; default the reference's.
    name : str

    Returns
    -------
    Motion
        On the reference's skeleton, metres (``length_unit_m = 1``), channels root 6,
        others 3, Euler ZXY.
    """
    frames = np.asarray(frames, dtype=np.int64).reshape(-1)
    if frames.size and (frames.min() < 0 or frames.max() >= sequence.n_frames):
        raise InvalidParameterError(
            f"frames must lie in [0, {sequence.n_frames}), got [{frames.min()}, {frames.max()}]"
        )
    root = np.array(root_positions_m, dtype=np.float64).reshape(len(frames), 3)
    local = sequence.local_rotations()[frames]
    root[:, 1] = sequence.root_positions[frames, 1]
    if headings_deg is not None:
        turn = wrap_deg(np.asarray(headings_deg, dtype=np.float64) - heading_deg(local[:, 0]))
        local[:, 0] = yaw_rotation(turn) @ local[:, 0]
    rest = np.asarray(sequence.rest_joints, dtype=np.float64)
    offsets = rest.copy()
    offsets[1:] -= rest[np.asarray(sequence.parents)[1:]]
    skeleton = Skeleton(
        sequence.joint_names,
        sequence.parents,
        offsets,
        standard_channels(len(sequence.joint_names)),
    )
    return Motion.from_local_transforms(
        skeleton, local, root, frame_time_s, length_unit_m=1.0, name=name
    )


def smooth_headings_deg(headings_deg: np.ndarray, window: int = 5) -> np.ndarray:
    """Moving average of unwrapped headings over ``window`` estimates, degrees."""
    h = np.unwrap(np.deg2rad(np.asarray(headings_deg, dtype=np.float64)))
    if window <= 1 or len(h) < 2:
        return np.rad2deg(h)
    kernel = np.ones(int(window)) / int(window)
    padded = np.pad(h, (window // 2, window - 1 - window // 2), mode="edge")
    return wrap_deg(np.rad2deg(np.convolve(padded, kernel, mode="valid")))
