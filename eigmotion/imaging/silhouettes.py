"""Binary silhouettes of a posed mesh, rasterised on the CPU (no OpenGL).

A silhouette is the union of the projections of all the mesh's triangles, front- and
back-facing alike, so open meshes (eye sockets, a cut neck) render without holes and
the winding order of the faces does not matter.  A pixel belongs to the silhouette
when its centre lies inside (or on the edge of) a projected triangle — the sampling
rule of OpenGL without multisampling.

Pixel convention: that of :meth:`eigmotion.imaging.cameras.Camera.project` — OpenCV camera
axes, pixel ``(row v, column u)`` centred at the integer coordinates ``(u, v)``, the
image covering ``[-0.5, width - 0.5] × [-0.5, height - 0.5]``.  A GL renderer given
the same camera must shift the principal point by half a pixel to agree (GL samples
pixel centres at ``i + 0.5``); :func:`eigmotion.imaging.render.render_masks_gl` does, and also
allows for where the multisampled depth buffer is sampled, so the two agree pixel for
pixel up to centres lying on an edge.

Triangles are not clipped: one with a vertex nearer than ``near_m`` to the camera
plane (or behind it) is skipped whole.  Bodies filmed by virtual or real cameras are
metres away, so this only matters for a camera placed inside the mesh.

The rasteriser is a small numba kernel, single-threaded, compiled on first use (about
2 s, then cached on disk next to this module); numba is imported lazily so that
importing this module stays cheap.  ``benchmarks/speed/bench_render.py`` measures it
against pyrender.
"""

from __future__ import annotations

from collections.abc import Iterator
from functools import lru_cache

import numpy as np

from eigmotion.errors import InvalidParameterError
from eigmotion.imaging.cameras import Camera, CameraRig

#: Triangles with a vertex closer than this to the camera plane are not drawn, metres.
DEFAULT_NEAR_M = 0.01


@lru_cache(maxsize=1)
def _kernel():
    """The compiled rasteriser (numba is imported and the kernel compiled here)."""
    from numba import njit

    return njit(cache=True, nogil=True)(_rasterise_frames)


def _rasterise_frames(vertices, faces, projection, near_m, out):  # pragma: no cover - JIT
    """Fill ``out`` (F, H, W) bool with the silhouettes of ``vertices`` (F, V, 3).

    ``projection`` is the (3, 4) matrix ``K @ [R | t]``; ``out`` must be all False on
    entry.  Written for numba: plain loops, no Python objects.
    """
    n_frames, n_vertices = vertices.shape[0], vertices.shape[1]
    height, width = out.shape[1], out.shape[2]
    u = np.empty(n_vertices, np.float64)
    v = np.empty(n_vertices, np.float64)
    visible = np.empty(n_vertices, np.bool_)
    p = projection
    for f in range(n_frames):
        for i in range(n_vertices):
            x = vertices[f, i, 0]
            y = vertices[f, i, 1]
            z = vertices[f, i, 2]
            w = p[2, 0] * x + p[2, 1] * y + p[2, 2] * z + p[2, 3]
            if w < near_m:
                visible[i] = False
                continue
            visible[i] = True
            u[i] = (p[0, 0] * x + p[0, 1] * y + p[0, 2] * z + p[0, 3]) / w
            v[i] = (p[1, 0] * x + p[1, 1] * y + p[1, 2] * z + p[1, 3]) / w
        mask = out[f]
        for t in range(faces.shape[0]):
            a = faces[t, 0]
            b = faces[t, 1]
            c = faces[t, 2]
            if not (visible[a] and visible[b] and visible[c]):
                continue
            ua, va, ub, vb, uc, vc = u[a], v[a], u[b], v[b], u[c], v[c]
            # Clamp in floating point before int(): a vertex just past the near plane
            # can project far outside any integer range.
            left = max(np.ceil(min(ua, ub, uc)), 0.0)
            right = min(np.floor(max(ua, ub, uc)), width - 1.0)
            if left > right:
                continue  # no pixel centre between the triangle's extreme columns
            top = max(np.ceil(min(va, vb, vc)), 0.0)
            bottom = min(np.floor(max(va, vb, vc)), height - 1.0)
            if top > bottom:
                continue
            col0, col1, row0, row1 = int(left), int(right), int(top), int(bottom)
            area = (ub - ua) * (vc - va) - (vb - va) * (uc - ua)
            if area == 0.0:
                continue
            if area < 0.0:  # make the winding positive so all edge tests are ">= 0"
                ub, vb, uc, vc = uc, vc, ub, vb
            # Most triangles cover a pixel or two: three tests without a branch between
            # them beat returning early.
            for row in range(row0, row1 + 1):
                for col in range(col0, col1 + 1):
                    mask[row, col] |= (
                        ((ub - ua) * (row - va) - (vb - va) * (col - ua) >= 0.0)
                        & ((uc - ub) * (row - vb) - (vc - vb) * (col - ub) >= 0.0)
                        & ((ua - uc) * (row - vc) - (va - vc) * (col - uc) >= 0.0)
                    )


def _check_mesh(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    vertices = np.asarray(vertices)
    faces = np.asarray(faces)
    if vertices.ndim != 3 or vertices.shape[2] != 3:
        raise InvalidParameterError(
            f"vertices must be an (F, V, 3) array of positions in metres, got shape "
            f"{vertices.shape}"
        )
    if faces.ndim != 2 or faces.shape[1] != 3:
        raise InvalidParameterError(
            f"faces must be a (T, 3) array of vertex indices, got shape {faces.shape}"
        )
    if not (
        np.issubdtype(vertices.dtype, np.floating) or np.issubdtype(vertices.dtype, np.integer)
    ):
        raise InvalidParameterError(f"vertices must hold numbers, got dtype {vertices.dtype}")
    if not np.issubdtype(faces.dtype, np.integer):
        raise InvalidParameterError(f"faces must hold integers, got dtype {faces.dtype}")
    if faces.size and (faces.min() < 0 or faces.max() >= vertices.shape[1]):
        raise InvalidParameterError(
            f"faces index vertices 0..{vertices.shape[1] - 1}, got indices "
            f"{faces.min()}..{faces.max()}"
        )
    # float32 (what Avatar.skin returns) is rasterised as is: no float64 copy of a
    # long clip; the projection itself runs in float64.
    dtype = vertices.dtype if vertices.dtype in (np.float32, np.float64) else np.float64
    vertices = np.ascontiguousarray(vertices, dtype=dtype)
    if not np.all(np.isfinite(vertices)):
        raise InvalidParameterError("vertices must be finite (no NaN or inf)")
    return vertices, np.ascontiguousarray(faces, dtype=np.int64)


def projection_matrix(camera: Camera) -> np.ndarray:
    """(3, 4) float64 ``K @ [R | t]``: homogeneous world point (metres) → pixels."""
    return camera.K @ np.hstack([camera.R, camera.t[:, None]])


def render_masks(
    vertices: np.ndarray,
    faces: np.ndarray,
    camera: Camera,
    near_m: float = DEFAULT_NEAR_M,
) -> np.ndarray:
    """The silhouette of a posed mesh in every frame, seen by one camera.

    Parameters
    ----------
    vertices : (F, V, 3) float
        Vertex positions per frame, world metres (Y up).  One pose is ``(1, V, 3)``.
        float32 and float64 are used without a copy.
    faces : (T, 3) int
        Triangles as vertex indices; either winding.
    camera : Camera
        Pinhole camera; its image size is the mask size.
    near_m : float
        Triangles with a vertex closer than this to the camera plane are skipped
        (not clipped), metres.

    Returns
    -------
    (F, H, W) bool
        True where a triangle covers the pixel centre; ``H, W = camera.height,
        camera.width``.  Pixel centres at integer coordinates, as
        :meth:`Camera.project`.

    Raises
    ------
    InvalidParameterError
        Wrong shapes, dtypes, out-of-range face indices, non-finite vertices, a
        ``near_m`` that is not > 0, or ``camera`` not a :class:`Camera`.
    """
    vertices, faces = _check_mesh(vertices, faces)
    _check_near(near_m)
    _check_camera(camera)
    return _render_checked(vertices, faces, camera, near_m)


def _render_checked(
    vertices: np.ndarray, faces: np.ndarray, camera: Camera, near_m: float
) -> np.ndarray:
    """:func:`render_masks` on arguments already checked by :func:`_check_mesh`."""
    out = np.zeros((vertices.shape[0], camera.height, camera.width), dtype=np.bool_)
    _kernel()(vertices, faces, projection_matrix(camera), float(near_m), out)
    return out


def _check_camera(camera) -> None:
    if not isinstance(camera, Camera):
        raise InvalidParameterError(
            f"camera must be an eigmotion.imaging.cameras.Camera, got {type(camera).__name__}"
        )


def _check_near(near_m: float) -> None:
    if not near_m > 0:
        raise InvalidParameterError(f"near_m must be > 0 metres, got {near_m}")


def _check_rig(rig: CameraRig) -> None:
    if not isinstance(rig, CameraRig):
        raise InvalidParameterError(
            f"rig must be an eigmotion.imaging.cameras.CameraRig, got {type(rig).__name__}"
        )
    if len(rig) == 0:
        raise InvalidParameterError(f"rig {rig.name!r} holds no cameras")


def iter_rig_masks(
    vertices: np.ndarray,
    faces: np.ndarray,
    rig: CameraRig,
    near_m: float = DEFAULT_NEAR_M,
) -> Iterator[tuple[Camera, np.ndarray]]:
    """Silhouettes seen by each camera of a rig in turn, one camera at a time.

    Parameters
    ----------
    vertices : (F, V, 3) float
        Vertex positions per frame, world metres.
    faces : (T, 3) int
    rig : CameraRig
        Cameras may differ in image size.
    near_m : float
        See :func:`render_masks`.

    Returns
    -------
    iterator of (Camera, (F, camera.height, camera.width) bool)
        Each camera of the rig with its masks, rendered when the iterator reaches it.

    Raises
    ------
    InvalidParameterError
        As :func:`render_masks`, or an empty rig; raised by the call itself, before
        iterating.
    """
    _check_rig(rig)
    _check_near(near_m)
    vertices, faces = _check_mesh(vertices, faces)  # checked now, not at the first next()
    return ((camera, _render_checked(vertices, faces, camera, near_m)) for camera in rig)


def render_rig_masks(
    vertices: np.ndarray,
    faces: np.ndarray,
    rig: CameraRig,
    near_m: float = DEFAULT_NEAR_M,
) -> np.ndarray:
    """Silhouettes of every frame from every camera of a rig.

    Parameters
    ----------
    vertices : (F, V, 3) float
        Vertex positions per frame, world metres.
    faces : (T, 3) int
    rig : CameraRig
        All cameras must share one image size (use :func:`iter_rig_masks` otherwise).
    near_m : float
        See :func:`render_masks`.

    Returns
    -------
    (C, F, H, W) bool
        ``C = len(rig)``, cameras in rig order.

    Raises
    ------
    InvalidParameterError
        As :func:`render_masks`, an empty rig, or cameras of different image sizes.
    """
    _check_rig(rig)
    sizes = {(cam.height, cam.width) for cam in rig}
    if len(sizes) != 1:
        raise InvalidParameterError(
            f"rig {rig.name!r}: cameras have different image sizes {sorted(sizes)}; "
            "use iter_rig_masks"
        )
    _check_near(near_m)
    vertices, faces = _check_mesh(vertices, faces)
    (height, width) = sizes.pop()
    out = np.zeros((len(rig), vertices.shape[0], height, width), dtype=np.bool_)
    kernel = _kernel()
    for i, camera in enumerate(rig):
        kernel(vertices, faces, projection_matrix(camera), float(near_m), out[i])
    return out
