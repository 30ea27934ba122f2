"""Cameras that keep a moving body in view, for replays and figures (:func:`frame_cameras`)."""

from __future__ import annotations

import numpy as np
from scipy.ndimage import uniform_filter1d
from scipy.spatial import ConvexHull, QhullError

from eigmotion.errors import InvalidParameterError
from eigmotion.imaging.cameras import (
    Camera,
    fit_distance,
    intrinsics,
    look_at,
    view_direction,
    virtual_rig,
)
from eigmotion.imaging.posed_mesh import FIT_POINTS_PER_FRAME

#: :func:`frame_cameras` with ``framing="auto"`` follows the body when its horizontal
#: path spans more than this, metres.
FOLLOW_TRAVEL_M = 1.5
#: Length of the moving average that smooths a followed path, seconds.
FOLLOW_SMOOTHING_S = 1.0


def frame_cameras(
    vertices: np.ndarray,
    times_s: np.ndarray,
    azimuth_deg: float,
    elevation_deg: float,
    width: int,
    height: int,
    framing: str = "auto",
    yfov_deg: float = 40.0,
) -> list[Camera]:
    """One camera per frame that keeps the body in view, for replays and figures.

    ``fixed``: one camera in the given direction, as close as it can be while every
    frame's body stays inside the image (:meth:`CameraRig.fitted`).  ``follow``: the
    same direction, at the distance that frames the body alone (its pose extent, not
    its path), aimed at the body's horizontal centre smoothed over
    :data:`FOLLOW_SMOOTHING_S` so that the gait's sway does not shake the picture.
    ``auto``: ``follow`` when the body's horizontal path spans more than
    :data:`FOLLOW_TRAVEL_M`, else ``fixed``.

    Parameters
    ----------
    vertices : (F, V, 3) float
        Posed vertices, world metres.
    times_s : (F,) float
        Time of each frame, seconds (for the smoothing of a followed path).
    azimuth_deg, elevation_deg : float
        Viewing direction (see :mod:`eigmotion.imaging.cameras`).
    width, height : int
        Image size, pixels.
    framing : {"auto", "fixed", "follow"}
        How the camera is placed (above).
    yfov_deg : float
        Vertical field of view, degrees.

    Returns
    -------
    list of F :class:`~eigmotion.imaging.cameras.Camera`
        The same object repeated when the camera is fixed.
    """
    if framing not in ("auto", "fixed", "follow"):
        raise InvalidParameterError(f"framing must be 'auto', 'fixed' or 'follow', got {framing!r}")
    vertices = np.asarray(vertices, dtype=np.float64)
    times_s = np.asarray(times_s, dtype=np.float64).reshape(-1)
    if vertices.ndim != 3 or vertices.shape[2] != 3 or len(vertices) < 1:
        raise InvalidParameterError(f"vertices must have shape (F, V, 3), got {vertices.shape}")
    if times_s.shape != (len(vertices),):
        raise InvalidParameterError(
            f"times_s must hold one time per frame ({len(vertices)}), got {times_s.shape}"
        )
    n_frames, n_vertices = vertices.shape[:2]
    stride = max(1, n_vertices // FIT_POINTS_PER_FRAME)
    sample = vertices[:, ::stride]
    path = sample.mean(axis=1)[:, [0, 2]]  # (F, 2) horizontal body centre
    travel_m = float(np.max(np.ptp(path, axis=0))) if n_frames > 1 else 0.0
    if framing == "auto":
        framing = "follow" if travel_m > FOLLOW_TRAVEL_M else "fixed"
    if framing == "fixed":
        rig = virtual_rig([azimuth_deg], [elevation_deg], width, height, yfov_deg)
        return [rig.fitted(_hull_points(sample.reshape(-1, 3)))[0]] * n_frames
    centre = _smooth_path(path, times_s)
    relative = sample.copy()
    relative[:, :, 0] -= centre[:, None, 0]
    relative[:, :, 2] -= centre[:, None, 1]
    points = _hull_points(relative.reshape(-1, 3))
    target = 0.5 * (points.min(axis=0) + points.max(axis=0))
    K = intrinsics(width, height, yfov_deg)
    distance_m = fit_distance(points, target, azimuth_deg, elevation_deg, K, width, height)
    offset = distance_m * view_direction(azimuth_deg, elevation_deg)
    cameras = []
    for cx, cz in centre:
        aim = target + [cx, 0.0, cz]
        cameras.append(
            look_at(
                aim + offset,
                aim,
                K,
                width,
                height,
                azimuth_deg=azimuth_deg,
                elevation_deg=elevation_deg,
            )
        )
    return cameras


def _hull_points(points: np.ndarray) -> np.ndarray:
    """The corners of the convex hull of (N, 3) points (all of them if it is flat).

    A perspective projection's u and v are linear-fractional in the point, so over a
    convex body in front of the camera their extremes lie at hull corners: fitting a
    camera to the corners frames all the points, at a fraction of the cost.
    """
    try:
        return points[ConvexHull(points).vertices]
    except (QhullError, ValueError):
        return points


def _smooth_path(path: np.ndarray, times_s: np.ndarray) -> np.ndarray:
    """(F, 2) moving average of a horizontal path over :data:`FOLLOW_SMOOTHING_S`."""
    if len(path) < 2:
        return path
    frame_time_s = float(np.median(np.diff(times_s))) if len(times_s) > 1 else 1.0
    window = max(1, int(round(FOLLOW_SMOOTHING_S / max(frame_time_s, 1e-6))))
    return uniform_filter1d(path, size=window, axis=0, mode="nearest")
