"""A posed mesh and the cameras that look at it, as the renderers take them.

The checks of a posed mesh ``vertices (F, V, 3)``, ``faces (T, 3)`` and of one camera
or one per frame, smooth vertex normals, and the depth range that encloses the body in
every frame's view.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from eigmotion.errors import InvalidParameterError
from eigmotion.imaging.cameras import Camera

#: Vertices per frame used to fit a camera distance or a depth range (a stride subsample).
FIT_POINTS_PER_FRAME = 1500


def check_posed_mesh(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    vertices = np.asarray(vertices)
    faces = np.asarray(faces)
    if vertices.ndim != 3 or vertices.shape[2] != 3 or vertices.shape[0] < 1:
        raise InvalidParameterError(
            "vertices must be an (F, V, 3) array of positions in metres with F >= 1 (one "
            f"pose is vertices[None]), got shape {vertices.shape}"
        )
    if faces.ndim != 2 or faces.shape[1] != 3 or faces.shape[0] < 1:
        raise InvalidParameterError(
            f"faces must be a (T, 3) array of vertex indices, got shape {faces.shape}"
        )
    if not np.issubdtype(faces.dtype, np.integer):
        raise InvalidParameterError(f"faces must hold integers, got dtype {faces.dtype}")
    if faces.min() < 0 or faces.max() >= vertices.shape[1]:
        raise InvalidParameterError(
            f"faces index vertices 0..{vertices.shape[1] - 1}, got indices "
            f"{faces.min()}..{faces.max()}"
        )
    if not np.all(np.isfinite(vertices)):
        raise InvalidParameterError("vertices must be finite (no NaN or inf)")
    return np.asarray(vertices, dtype=np.float32), np.ascontiguousarray(faces, dtype=np.uint32)


def check_frame_cameras(camera: Camera | Sequence[Camera], n_frames: int) -> list[Camera]:
    cameras = [camera] * n_frames if isinstance(camera, Camera) else list(camera)
    if len(cameras) != n_frames or not all(isinstance(c, Camera) for c in cameras):
        raise InvalidParameterError(
            f"camera must be one Camera or a sequence of {n_frames} Cameras (one per "
            f"frame), got {type(camera).__name__} of length {len(cameras)}"
        )
    sizes = {(c.width, c.height) for c in cameras}
    if len(sizes) != 1:
        raise InvalidParameterError(
            f"all per-frame cameras must share one image size, got {sorted(sizes)}"
        )
    return cameras


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Smooth unit normals: the area-weighted mean of the adjacent faces' normals.

    Parameters
    ----------
    vertices : (V, 3) float
        Positions, metres.
    faces : (T, 3) int
        Triangles, counter-clockwise seen from outside.

    Returns
    -------
    (V, 3) float32
        Unit normals; ``(0, 1, 0)`` for vertices used by no (non-degenerate) face.
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    face_normals = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])  # 2 × area
    index = f.ravel()
    normals = np.stack(
        [np.bincount(index, np.repeat(face_normals[:, c], 3), minlength=len(v)) for c in range(3)],
        axis=1,
    )
    norm = np.linalg.norm(normals, axis=1, keepdims=True)
    out = np.where(norm > 1e-20, normals / np.maximum(norm, 1e-20), [0.0, 1.0, 0.0])
    return out.astype(np.float32)


def depth_range(
    vertices: np.ndarray, cameras: list[Camera], extra_points: np.ndarray
) -> tuple[float, float]:
    """(znear, zfar) in metres enclosing each frame's body (and the floor) for its camera.

    A stride subsample of the vertices is enough: the planes get a factor 2 of slack.
    """
    stride = max(1, vertices.shape[1] // FIT_POINTS_PER_FRAME)
    lo, hi = np.inf, 0.0
    by_camera: dict[int, list[int]] = {}
    for f, cam in enumerate(cameras):
        by_camera.setdefault(id(cam), []).append(f)
    for frames in by_camera.values():
        cam = cameras[frames[0]]
        depth = cam.to_camera(vertices[frames, ::stride].reshape(-1, 3))[:, 2]
        in_front = depth[depth > 1e-6]
        if in_front.size:
            lo = min(lo, float(in_front.min()))
            hi = max(hi, float(in_front.max()))
        if extra_points.size:
            hi = max(hi, float(cam.to_camera(extra_points)[:, 2].max()))
    if not np.isfinite(lo):
        return 0.01, 100.0
    return max(0.01, 0.5 * lo), max(2.0 * hi, 1.0)
