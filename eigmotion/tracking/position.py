"""The person's 3D position from several views (the paper's section 2.3).

The tracked person is roughly upright, so the height of the body centre (the root
joint) above the floor, ``H_b``, is taken as known (the previous posture's).  Each
camera ``c`` sees the person at an image position ``P_c`` (the foreground centroid).
The ray from the camera centre through ``P_c``, projected vertically onto the plane
``y = H_b``, is a line on that plane; the lines of all cameras meet at the person's
position ``G`` (least squares for three cameras or more).  With a single camera the
ray itself meets the plane ``y = H_b`` at ``G``.

With more than two cameras, cameras work in pairs, each pair owning a region of the
stage (:class:`~eigmotion.tracking.calibration.CameraPair`); :func:`select_pair` picks
the pair whose region holds the person.

World frame: metres, Y up, floor at ``y = 0``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from eigmotion.errors import InvalidParameterError, VideoError
from eigmotion.imaging.cameras import Camera
from eigmotion.tracking.calibration import CameraPair


def mask_centroid(mask: np.ndarray) -> np.ndarray:
    """(2,) float64 centroid ``(u, v)`` of a silhouette's pixels, pixels.

    Parameters
    ----------
    mask : (H, W) bool or float
        Foreground (True / weight) per pixel.

    Raises
    ------
    VideoError
        The mask is empty (no person in view).
    """
    mask = np.asarray(mask)
    if mask.ndim != 2:
        raise InvalidParameterError(f"mask must be (H, W), got shape {mask.shape}")
    weights = mask.astype(np.float64)
    total = weights.sum()
    if not total > 0:
        raise VideoError("the silhouette is empty: no person in view")
    rows = weights.sum(axis=1)
    cols = weights.sum(axis=0)
    v = float(rows @ np.arange(mask.shape[0]) / total)
    u = float(cols @ np.arange(mask.shape[1]) / total)
    return np.array([u, v])


def ray_plane_points(cameras: Sequence[Camera], pixels: np.ndarray, height_m: float) -> np.ndarray:
    """Where each camera's ray through a pixel meets the plane ``y = height_m``.

    Parameters
    ----------
    cameras : sequence of C Camera
    pixels : (C, 2) float
        One pixel ``(u, v)`` per camera.
    height_m : float
        Height of the horizontal plane, metres.

    Returns
    -------
    (C, 3) float64
        World points, metres.

    Raises
    ------
    InvalidParameterError
        A ray that does not meet the plane in front of its camera.
    """
    pixels = np.asarray(pixels, dtype=np.float64).reshape(len(cameras), 2)
    out = np.empty((len(cameras), 3))
    for i, (cam, px) in enumerate(zip(cameras, pixels, strict=True)):
        origin = cam.center
        direction = cam.pixel_rays(px)
        if abs(direction[1]) < 1e-9:
            raise InvalidParameterError(
                f"camera {cam.name!r}: the ray through pixel {px.tolist()} is parallel to "
                f"the plane y = {height_m} m"
            )
        s = (height_m - origin[1]) / direction[1]
        if s <= 0:
            raise InvalidParameterError(
                f"camera {cam.name!r}: the ray through pixel {px.tolist()} meets the plane "
                f"y = {height_m} m behind the camera"
            )
        out[i] = origin + s * direction
    return out


def intersect_plane_lines(
    cameras: Sequence[Camera],
    pixels: np.ndarray,
    height_m: float,
    prior_m: np.ndarray | None = None,
    prior_weight: float = 1e-3,
) -> np.ndarray:
    """The person's position from the cameras' rays, projected onto ``y = height_m``.

    Each camera's ray through its pixel is projected vertically onto the horizontal
    plane at ``height_m``, giving a line through the camera's foot point; the result
    minimises the sum of squared distances to these lines (their intersection for two
    cameras).  A weak pull towards ``prior_m`` keeps the answer defined when the lines
    are (nearly) parallel, e.g. for two cameras facing each other across the person.

    Parameters
    ----------
    cameras : sequence of C Camera
        C >= 1.  With one camera the ray meets the plane directly
        (:func:`ray_plane_points`).
    pixels : (C, 2) float
        The person's image position ``(u, v)`` per camera, pixels.
    height_m : float
        Body-centre height ``H_b``, metres.
    prior_m : (3,) float, optional
        A rough position (e.g. the previous one); default the mean of the points where
        the rays meet the plane.
    prior_weight : float
        Weight of the prior relative to one line, ≥ 0.

    Returns
    -------
    (3,) float64
        ``(x, height_m, z)``, metres.
    """
    if len(cameras) == 0:
        raise InvalidParameterError("at least one camera is needed to locate the person")
    if not (np.isfinite(prior_weight) and prior_weight >= 0):
        raise InvalidParameterError(f"prior_weight must be >= 0, got {prior_weight!r}")
    pixels = np.asarray(pixels, dtype=np.float64).reshape(len(cameras), 2)
    if len(cameras) == 1:
        return ray_plane_points(cameras, pixels, height_m)[0]
    if prior_m is None:
        try:
            prior_m = ray_plane_points(cameras, pixels, height_m).mean(axis=0)
        except InvalidParameterError:
            prior_m = np.mean([cam.center for cam in cameras], axis=0)
    prior = np.asarray(prior_m, dtype=np.float64).reshape(3)[[0, 2]]
    A = prior_weight * np.eye(2)
    b = prior_weight * prior
    for cam, px in zip(cameras, pixels, strict=True):
        d = cam.pixel_rays(px)[[0, 2]]
        norm = np.linalg.norm(d)
        if norm < 1e-12:
            continue  # a ray straight down gives no line: it only fixes a point
        d = d / norm
        P = np.eye(2) - np.outer(d, d)
        o = cam.center[[0, 2]]
        A += P
        b += P @ o
    if np.linalg.cond(A) > 1e12:
        raise InvalidParameterError(
            "the cameras' lines on the plane are parallel: give a prior_weight > 0"
        )
    x, z = np.linalg.solve(A, b)
    return np.array([x, height_m, z])


def locate(
    cameras: Sequence[Camera],
    masks: Sequence[np.ndarray],
    height_m: float,
    prior_m: np.ndarray | None = None,
) -> np.ndarray:
    """(3,) position ``G`` of the person, metres, from one silhouette per camera.

    Parameters
    ----------
    cameras : sequence of C Camera
    masks : sequence of C (H, W) bool
        Observed silhouettes, each of its camera's image size.
    height_m : float
        Body-centre height, metres.
    prior_m : (3,) float, optional
        See :func:`intersect_plane_lines`.
    """
    if len(masks) != len(cameras):
        raise InvalidParameterError(f"{len(masks)} masks given for {len(cameras)} cameras")
    pixels = np.stack([mask_centroid(m) for m in masks])
    return intersect_plane_lines(cameras, pixels, height_m, prior_m)


def _centrality(camera: Camera, point: np.ndarray) -> float:
    """How far inside the image a point projects: 1 at the centre, 0 at the border,
    negative outside or behind the camera."""
    px, depth = camera.project(point[None])
    if depth[0] <= 0:
        return -np.inf
    u, v = px[0]
    du = 1.0 - abs(u - (camera.width - 1) / 2.0) / (camera.width / 2.0)
    dv = 1.0 - abs(v - (camera.height - 1) / 2.0) / (camera.height / 2.0)
    return float(min(du, dv))


def select_pair(
    pairs: Sequence[CameraPair], cameras: Sequence[Camera], position_m: np.ndarray
) -> CameraPair:
    """The camera pair in charge of a position on the stage.

    Parameters
    ----------
    pairs : sequence of CameraPair
        With regions: the pair whose region holds the position, or else the one
        whose region is nearest.  Without regions: the pair whose less central
        camera sees the position most centrally.
    cameras : sequence of Camera
        All cameras of the calibration.
    position_m : (3,) float
        The person's position, metres.

    Returns
    -------
    CameraPair
    """
    if len(pairs) == 0:
        raise InvalidParameterError("no camera pairs to choose from")
    point = np.asarray(position_m, dtype=np.float64).reshape(3)
    best, best_key = None, None
    for pair in pairs:
        if pair.region is not None:
            x0, z0, x1, z1 = pair.region
            dx = max(x0 - point[0], 0.0, point[0] - x1)
            dz = max(z0 - point[2], 0.0, point[2] - z1)
            key = -float(np.hypot(dx, dz))
        else:
            key = min(_centrality(cameras[i], point) for i in pair.cameras)
        if best_key is None or key > best_key:
            best, best_key = pair, key
    return best
