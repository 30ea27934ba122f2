"""Pinhole cameras and virtual camera rigs.

Convention, used everywhere in eigmotion:

* world: metres, Y up, the floor at y = 0; a body at rest faces +Z with its left
  side towards +X;
* camera: OpenCV axes — x right, y down, z forward (into the scene); a world point
  ``X`` maps to camera coordinates ``x_cam = R @ X + t`` and to pixels
  ``u = fx * x / z + cx``, ``v = fy * y / z + cy`` (pixel centres at integers);
* a virtual camera's azimuth is measured about +Y from +Z (the body's front) towards
  +X (its left), its elevation upwards from the horizontal plane; it sits at
  ``target + d * (sin(az) cos(el), sin(el), cos(az) cos(el))`` looking at ``target``.

Rigs are stored as TOML (see ``virtual_cameras/``), one ``[[camera]]`` table each.
"""

from __future__ import annotations

import tomllib
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import tomli_w

from eigmotion.errors import InvalidParameterError

CONVENTION = (
    "OpenCV camera axes (x right, y down, z forward), x_cam = R @ X_world + t; "
    "world metres, Y up, floor y = 0; azimuth about +Y from +Z towards +X"
)

#: OpenCV camera axes → OpenGL/pyrender camera axes (x right, y up, z backward).
CV_TO_GL = np.diag([1.0, -1.0, -1.0])


@dataclass(frozen=True, eq=False)
class Camera:
    """A calibrated pinhole camera (no lens distortion).

    Parameters
    ----------
    K : (3, 3) float
        Intrinsics ``[[fx, 0, cx], [0, fy, cy], [0, 0, 1]]``, pixels.
    R : (3, 3) float
        World → camera rotation.
    t : (3,) float
        World → camera translation, metres.
    width, height : int
        Image size, pixels.
    name : str
    azimuth_deg, elevation_deg : float or None
        Viewing direction of a virtual camera (see module docstring); ``None`` for a
        real, calibrated camera.
    """

    K: np.ndarray
    R: np.ndarray
    t: np.ndarray
    width: int
    height: int
    name: str = ""
    azimuth_deg: float | None = None
    elevation_deg: float | None = None

    def __post_init__(self):
        K = np.asarray(self.K, dtype=np.float64)
        R = np.asarray(self.R, dtype=np.float64)
        t = np.asarray(self.t, dtype=np.float64).reshape(-1)
        if K.shape != (3, 3) or R.shape != (3, 3) or t.shape != (3,):
            raise InvalidParameterError(
                f"camera {self.name!r}: K and R must be 3×3 and t of length 3, got "
                f"{K.shape}, {R.shape}, {t.shape}"
            )
        if not (np.all(np.isfinite(K)) and np.all(np.isfinite(R)) and np.all(np.isfinite(t))):
            raise InvalidParameterError(f"camera {self.name!r}: K, R and t must be finite")
        if not np.allclose(R @ R.T, np.eye(3), atol=1e-6) or np.linalg.det(R) < 0:
            raise InvalidParameterError(f"camera {self.name!r}: R is not a rotation matrix")
        if K[0, 0] <= 0 or K[1, 1] <= 0:
            raise InvalidParameterError(f"camera {self.name!r}: focal lengths must be > 0")
        if int(self.width) < 1 or int(self.height) < 1:
            raise InvalidParameterError(
                f"camera {self.name!r}: image size {self.width}×{self.height} must be positive"
            )
        object.__setattr__(self, "K", K)
        object.__setattr__(self, "R", R)
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "width", int(self.width))
        object.__setattr__(self, "height", int(self.height))

    # -- facts -------------------------------------------------------------------
    @property
    def fx(self) -> float:
        return float(self.K[0, 0])

    @property
    def fy(self) -> float:
        return float(self.K[1, 1])

    @property
    def cx(self) -> float:
        return float(self.K[0, 2])

    @property
    def cy(self) -> float:
        return float(self.K[1, 2])

    @property
    def center(self) -> np.ndarray:
        """(3,) camera centre in world coordinates, metres."""
        return -self.R.T @ self.t

    @property
    def yfov_rad(self) -> float:
        """Vertical field of view, radians."""
        return float(2.0 * np.arctan2(self.height / 2.0, self.fy))

    def camera_to_world(self) -> np.ndarray:
        """(4, 4) pose with OpenCV camera axes (camera → world)."""
        pose = np.eye(4)
        pose[:3, :3] = self.R.T
        pose[:3, 3] = self.center
        return pose

    def gl_pose(self) -> np.ndarray:
        """(4, 4) camera → world pose with OpenGL axes, as pyrender expects."""
        pose = self.camera_to_world()
        pose[:3, :3] = pose[:3, :3] @ CV_TO_GL
        return pose

    # -- geometry ------------------------------------------------------------------
    def to_camera(self, points: np.ndarray) -> np.ndarray:
        """World points (..., 3) → camera coordinates (..., 3), metres."""
        return np.asarray(points, dtype=np.float64) @ self.R.T + self.t

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World points → pixels.

        Parameters
        ----------
        points : (..., 3) float, metres

        Returns
        -------
        pixels : (..., 2) float
            (u, v) pixel coordinates; meaningless where ``depth <= 0``.
        depth : (...,) float
            z in the camera frame, metres.
        """
        cam = self.to_camera(points)
        z = cam[..., 2]
        safe = np.where(np.abs(z) < 1e-12, 1e-12, z)
        u = self.fx * cam[..., 0] / safe + self.cx
        v = self.fy * cam[..., 1] / safe + self.cy
        return np.stack([u, v], axis=-1), z

    def pixel_rays(self, pixels: np.ndarray) -> np.ndarray:
        """Unit world directions (..., 3) of the rays through pixels (..., 2)."""
        pixels = np.asarray(pixels, dtype=np.float64)
        x = (pixels[..., 0] - self.cx) / self.fx
        y = (pixels[..., 1] - self.cy) / self.fy
        d = np.stack([x, y, np.ones_like(x)], axis=-1) @ self.R
        return d / np.linalg.norm(d, axis=-1, keepdims=True)

    def with_image_size(self, width: int, height: int) -> Camera:
        """The same camera with its intrinsics scaled to another image size."""
        sx, sy = width / self.width, height / self.height
        K = self.K.copy()
        K[0] *= sx
        K[1] *= sy
        return replace(self, K=K, width=width, height=height)


def intrinsics(width: int, height: int, yfov_deg: float) -> np.ndarray:
    """(3, 3) K for square pixels and the principal point at the image centre."""
    if not 1.0 <= yfov_deg < 179.0:
        raise InvalidParameterError(f"yfov_deg must be in [1, 179), got {yfov_deg}")
    f = (height / 2.0) / np.tan(np.deg2rad(yfov_deg) / 2.0)
    return np.array([[f, 0, (width - 1) / 2.0], [0, f, (height - 1) / 2.0], [0, 0, 1.0]])


def look_at(
    eye: Sequence[float],
    target: Sequence[float],
    K: np.ndarray,
    width: int,
    height: int,
    up: Sequence[float] = (0.0, 1.0, 0.0),
    name: str = "",
    azimuth_deg: float | None = None,
    elevation_deg: float | None = None,
) -> Camera:
    """A camera at ``eye`` looking at ``target`` with world ``up`` pointing up in the image."""
    eye = np.asarray(eye, dtype=np.float64)
    R = _look_axes(np.asarray(target, dtype=np.float64) - eye, up)
    return Camera(K, R, -R @ eye, width, height, name, azimuth_deg, elevation_deg)


def _look_axes(forward: np.ndarray, up: Sequence[float] = (0.0, 1.0, 0.0)) -> np.ndarray:
    """(3, 3) rotation world → camera (rows: right, down, forward) of a camera looking
    along ``forward`` (3,) with world ``up`` pointing up in the image."""
    norm = np.linalg.norm(forward)
    if norm < 1e-9:
        raise InvalidParameterError("look_at: eye and target coincide")
    forward = forward / norm
    right = np.cross(forward, np.asarray(up, dtype=np.float64))
    if np.linalg.norm(right) < 1e-9:  # looking straight up or down
        right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    return np.stack([right, down, forward])


def view_direction(azimuth_deg: float, elevation_deg: float) -> np.ndarray:
    """(3,) unit vector from the target towards a camera at that azimuth/elevation."""
    az, el = np.deg2rad(azimuth_deg), np.deg2rad(elevation_deg)
    return np.array([np.sin(az) * np.cos(el), np.sin(el), np.cos(az) * np.cos(el)])


def view_name(azimuth_deg: float, elevation_deg: float) -> str:
    return f"az{azimuth_deg % 360:05.1f}_el{elevation_deg:+05.1f}"


def fit_distance(
    points: np.ndarray,
    target: np.ndarray,
    azimuth_deg: float,
    elevation_deg: float,
    K: np.ndarray,
    width: int,
    height: int,
    margin: float = 0.05,
) -> float:
    """Smallest distance at which a camera at this view sees all ``points`` in frame.

    Parameters
    ----------
    points : (N, 3) float
        Everything that must stay in view (e.g. all joints over a motion), metres.
    target : (3,) float
        The point the camera looks at.
    margin : float
        Fraction of the image kept free on every side.

    Returns
    -------
    float, metres, within [0.1, 1000]: the nearest distance at which every point
    lies more than 0.05 m in front of the camera and inside the image less its margin.

    Raises
    ------
    InvalidParameterError
        The principal point of ``K`` lies outside the image less its margin.
    """
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    target = np.asarray(target, dtype=np.float64)
    direction = view_direction(azimuth_deg, elevation_deg)
    # The camera's axes depend on the view only: moving it back along ``direction``
    # by d adds d to every point's depth and leaves x and y as they are.
    axes = _look_axes(target - (target + direction))  # as look_at computes it, to the bit
    x, y, z = ((points - target) @ axes.T).T
    lowest = [0.05 - z]  # depth > 0.05 m
    for focal, centre, size, along in ((K[0, 0], K[0, 2], width, x), (K[1, 1], K[1, 2], height, y)):
        first, last = margin * size - centre, (1 - margin) * size - 1 - centre
        if not first < 0 < last:
            raise InvalidParameterError(
                f"fit_distance: the principal point ({K[0, 2]:g}, {K[1, 2]:g}) lies outside "
                f"the image less its {margin:g} margin"
            )
        # focal·along / depth must lie in [first, last]: depth ≥ focal·along / first
        # for points on the near side of the centre, ≥ focal·along / last beyond it.
        lowest += [focal * along / first - z, focal * along / last - z]
    return float(np.clip(np.max(lowest), 0.1, 1000.0))


@dataclass(frozen=True, eq=False)
class CameraRig:
    """A named group of cameras, as read from or written to TOML."""

    cameras: tuple[Camera, ...]
    name: str = ""
    meta: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.cameras)

    def __iter__(self):
        return iter(self.cameras)

    def __getitem__(self, i: int) -> Camera:
        return self.cameras[i]

    def fitted(self, points: np.ndarray, margin: float = 0.05) -> CameraRig:
        """The same views re-aimed at ``points``' centre, each as close as it can be
        while all points stay in frame (virtual cameras only)."""
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        target = 0.5 * (points.min(axis=0) + points.max(axis=0))
        out = []
        for cam in self.cameras:
            if cam.azimuth_deg is None or cam.elevation_deg is None:
                raise InvalidParameterError(
                    f"camera {cam.name!r} has no azimuth/elevation: only virtual cameras "
                    "can be re-aimed"
                )
            d = fit_distance(
                points,
                target,
                cam.azimuth_deg,
                cam.elevation_deg,
                cam.K,
                cam.width,
                cam.height,
                margin,
            )
            eye = target + d * view_direction(cam.azimuth_deg, cam.elevation_deg)
            out.append(
                look_at(
                    eye,
                    target,
                    cam.K,
                    cam.width,
                    cam.height,
                    name=cam.name,
                    azimuth_deg=cam.azimuth_deg,
                    elevation_deg=cam.elevation_deg,
                )
            )
        return replace(self, cameras=tuple(out))


def virtual_rig(
    azimuths_deg: Iterable[float],
    elevations_deg: Iterable[float],
    width: int = 128,
    height: int = 128,
    yfov_deg: float = 40.0,
    distance_m: float = 4.0,
    target: Sequence[float] = (0.0, 0.9, 0.0),
    name: str = "",
) -> CameraRig:
    """Cameras at every (azimuth, elevation) pair, equidistant from ``target``."""
    K = intrinsics(width, height, yfov_deg)
    target = np.asarray(target, dtype=np.float64)
    cams = []
    for el in elevations_deg:
        if not -89.0 <= el <= 89.0:
            raise InvalidParameterError(f"elevation {el}° must be within [-89, 89]")
        for az in azimuths_deg:
            eye = target + distance_m * view_direction(az, el)
            cams.append(
                look_at(
                    eye,
                    target,
                    K,
                    width,
                    height,
                    name=view_name(az, el),
                    azimuth_deg=float(az),
                    elevation_deg=float(el),
                )
            )
    return CameraRig(tuple(cams), name, {"yfov_deg": yfov_deg, "distance_m": distance_m})


def ring_rig(n_views: int, elevation_deg: float = 0.0, **kwargs) -> CameraRig:
    """``n_views`` azimuths at equal angles (starting at 0°) at one elevation."""
    if n_views < 1:
        raise InvalidParameterError(f"n_views must be >= 1, got {n_views}")
    return virtual_rig(np.arange(n_views) * 360.0 / n_views, [elevation_deg], **kwargs)


def dome_rig(n_azimuths: int, elevations_deg: Sequence[float], **kwargs) -> CameraRig:
    """``n_azimuths`` equal-angle azimuths at each elevation (horizontal, above, below)."""
    if n_azimuths < 1:
        raise InvalidParameterError(f"n_azimuths must be >= 1, got {n_azimuths}")
    return virtual_rig(np.arange(n_azimuths) * 360.0 / n_azimuths, elevations_deg, **kwargs)


def save_rig(rig: CameraRig, path: str | Path) -> None:
    """Write a rig as TOML (one ``[[camera]]`` table per camera)."""
    doc = {"name": rig.name, "convention": CONVENTION, "meta": dict(rig.meta), "camera": []}
    for cam in rig.cameras:
        entry = {
            "name": cam.name,
            "width": cam.width,
            "height": cam.height,
            "fx": cam.fx,
            "fy": cam.fy,
            "cx": cam.cx,
            "cy": cam.cy,
            "R": cam.R.tolist(),
            "t": cam.t.tolist(),
        }
        if cam.azimuth_deg is not None:
            entry["azimuth_deg"] = cam.azimuth_deg
            entry["elevation_deg"] = cam.elevation_deg
        doc["camera"].append(entry)
    Path(path).write_bytes(tomli_w.dumps(doc).encode())


def load_rig(path: str | Path) -> CameraRig:
    """Read a rig written by :func:`save_rig` (or by hand in the same layout)."""
    path = Path(path)
    try:
        doc = tomllib.loads(path.read_text())
    except ValueError as exc:  # a decode error, bad UTF-8, a number too long
        raise InvalidParameterError(f"{path}: not valid TOML: {exc}") from None
    entries = doc.get("camera")
    if not entries:
        raise InvalidParameterError(f"{path}: no [[camera]] tables")
    cams = []
    for i, e in enumerate(entries):
        try:
            K = np.array([[e["fx"], 0, e["cx"]], [0, e["fy"], e["cy"]], [0, 0, 1.0]], float)
            cams.append(
                Camera(
                    K,
                    e["R"],
                    e["t"],
                    e["width"],
                    e["height"],
                    e.get("name", f"cam{i}"),
                    e.get("azimuth_deg"),
                    e.get("elevation_deg"),
                )
            )
        except KeyError as exc:
            raise InvalidParameterError(f"{path}: camera {i} lacks {exc.args[0]!r}") from None
        except (TypeError, ValueError) as exc:
            raise InvalidParameterError(f"{path}: camera {i}: {exc}") from None
    return CameraRig(tuple(cams), doc.get("name", path.stem), doc.get("meta", {}))


def rig_to_plain(rig: CameraRig) -> dict:
    """A rig as plain values, the form a motion database keeps it in (its build
    configuration's ``rig``): each camera's ``K``, ``R`` and ``t`` as nested lists, its
    image size, name and view direction (None for a real camera).  The rig's ``meta``
    is not kept.  :func:`rig_from_plain` reads it back.

    Unlike the TOML of :func:`save_rig` (``fx``, ``fy``, ``cx``, ``cy`` and no view
    direction for a real camera), this form holds the whole ``K``: databases already
    built store it, so it stays as it is.
    """
    return {
        "name": rig.name,
        "cameras": [
            {
                "name": c.name,
                "K": c.K.tolist(),
                "R": c.R.tolist(),
                "t": c.t.tolist(),
                "width": c.width,
                "height": c.height,
                "azimuth_deg": c.azimuth_deg,
                "elevation_deg": c.elevation_deg,
            }
            for c in rig.cameras
        ],
    }


def rig_from_plain(data: dict) -> CameraRig:
    """The rig of :func:`rig_to_plain`'s plain values (with an empty ``meta``)."""
    cams = tuple(
        Camera(
            np.asarray(c["K"]),
            np.asarray(c["R"]),
            np.asarray(c["t"]),
            c["width"],
            c["height"],
            c["name"],
            c["azimuth_deg"],
            c["elevation_deg"],
        )
        for c in data["cameras"]
    )
    return CameraRig(cams, data["name"])
