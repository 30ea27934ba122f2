"""OpenGL rendering with pyrender: shaded replays and GL silhouettes.

Two products, both from a posed mesh ``vertices (F, V, 3)`` (world metres, Y up) and a
:class:`~eigmotion.imaging.cameras.Camera`:

* :meth:`Renderer.render_shaded` — the body lit by a key and a fill light (smooth
  normals), standing on a checker (or plain) floor at y = 0: replay videos, figures;
* :meth:`Renderer.render_masks_gl` — binary silhouettes, the GL counterpart of the CPU
  rasteriser :func:`eigmotion.imaging.silhouettes.render_masks`, which it matches pixel for
  pixel up to ties on triangle edges.

Pixel convention (that of :meth:`Camera.project`): pixel ``(row v, column u)`` is
centred at integer ``(u, v)``.  OpenGL samples pixel ``i`` at window coordinate
``i + 0.5``, so the ``pyrender.IntrinsicsCamera`` gets the principal point
``(cx + 0.5, cy + 0.5)`` (its ``cy`` is measured from the top, like OpenCV's).  The
shaded colour image is the average of pyrender's 4 multisamples, which are centred on
the pixel.  The depth image, from which masks come, is not averaged: the driver
keeps one sample, off the pixel centre (Mesa's llvmpipe: 1/8 px left, 3/8 px down).
That offset is measured once per process (:func:`depth_sample_offset_px`) and folded
into the principal point of mask renders, so that a mask pixel is set exactly when
its centre is covered.

The GL platform is EGL (headless), selected by setting ``PYOPENGL_PLATFORM=egl``
unless the variable is already set; pyrender is imported only when a
:class:`Renderer` is made, so ``import eigmotion`` works without OpenGL.  pyrender
0.1.45 still uses ``np.infty``, which numpy 2 removed; the alias is restored before
pyrender is imported.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Sequence
from functools import lru_cache

import numpy as np
from tqdm import tqdm

from eigmotion.errors import InvalidParameterError
from eigmotion.imaging.cameras import Camera
from eigmotion.imaging.posed_mesh import (
    check_frame_cameras,
    check_posed_mesh,
    depth_range,
    vertex_normals,
)

#: Linear RGB in [0, 1] of the default look: a warm grey body on a grey checker floor
#: in front of a dark blue-grey background.
BODY_RGB = (0.80, 0.68, 0.56)
BACKGROUND_RGB = (0.12, 0.13, 0.16)
FLOOR_RGB = ((0.58, 0.58, 0.60), (0.40, 0.40, 0.43))

#: Key and fill light directions in the camera's OpenCV frame (x right, y down, z
#: forward): the key comes from above left, the fill from the right.
KEY_LIGHT_DIRECTION_CAM = (0.45, 0.65, 0.60)
FILL_LIGHT_DIRECTION_CAM = (-0.80, 0.10, 0.55)


def _import_pyrender():
    """pyrender, imported with a headless GL platform and numpy 2 compatibility."""
    os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
    if not hasattr(np, "infty"):  # pyrender 0.1.45 mesh.py uses np.infty (gone in numpy 2)
        setattr(np, "infty", np.inf)  # noqa: B010 - the attribute name trips NPY201
    try:
        import pyrender
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise ImportError(
            f"rendering needs pyrender and an OpenGL platform (EGL or OSMesa): {exc}"
        ) from exc
    return pyrender


def _delete_offscreen(offscreen) -> None:
    """Free one ``pyrender.OffscreenRenderer`` without breaking the others.

    pyrender's own ``delete`` ends with ``eglTerminate`` on the EGL display that every
    renderer of the process shares, which invalidates all other live contexts.  Here
    an EGL context is destroyed alone and the display stays initialised.
    """
    platform = getattr(offscreen, "_platform", None)
    if platform is None or type(platform).__name__ != "EGLPlatform":
        offscreen.delete()
        return
    from OpenGL.EGL import EGL_NO_CONTEXT, EGL_NO_SURFACE, eglDestroyContext, eglMakeCurrent

    platform.make_current()
    offscreen._renderer.delete()
    display, context = platform._egl_display, platform._egl_context
    eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT)
    eglDestroyContext(display, context)
    platform._egl_context = platform._egl_display = None
    offscreen._renderer = offscreen._platform = None  # its __del__ now does nothing


def _intrinsics_camera(
    pyrender, camera: Camera, offset_px: tuple[float, float], znear_m: float, zfar_m: float
):
    return pyrender.IntrinsicsCamera(
        fx=camera.fx,
        fy=camera.fy,
        cx=camera.cx + 0.5 + offset_px[0],
        cy=camera.cy + 0.5 + offset_px[1],
        znear=znear_m,
        zfar=zfar_m,
    )


def _light_pose(camera: Camera, direction_cam: Sequence[float]) -> np.ndarray:
    """(4, 4) pose of a directional light shining along ``direction_cam`` (camera frame)."""
    d_world = camera.R.T @ np.asarray(direction_cam, dtype=np.float64)
    d_world /= np.linalg.norm(d_world)
    z_axis = -d_world  # pyrender lights shine along their node's -z
    helper = np.array([0.0, 1.0, 0.0]) if abs(z_axis[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
    x_axis = np.cross(helper, z_axis)
    x_axis /= np.linalg.norm(x_axis)
    pose = np.eye(4)
    pose[:3, :3] = np.stack([x_axis, np.cross(z_axis, x_axis), z_axis], axis=1)
    pose[:3, 3] = camera.center
    return pose


def checker_floor(
    x_range_m: tuple[float, float],
    z_range_m: tuple[float, float],
    tile_m: float = 0.5,
    rgb: tuple[Sequence[float], Sequence[float]] = FLOOR_RGB,
    checker: bool = True,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A floor of square tiles at y = 0, facing up.

    Parameters
    ----------
    x_range_m, z_range_m : (float, float)
        Extent to cover, metres; widened to whole tiles aligned on multiples of
        ``tile_m``.
    tile_m : float
        Tile edge, metres.
    rgb : two (3,) float
        Colours of the two kinds of tile, in [0, 1].
    checker : bool
        Alternate the two colours; ``False`` paints every tile with the first.

    Returns
    -------
    vertices : (4 N, 3) float32
        Tile corners, metres (each tile has its own four, so colours do not blend).
    faces : (2 N, 3) uint32
        Two counter-clockwise (seen from above) triangles per tile.
    colors : (4 N, 4) float32
        RGBA per vertex.
    """
    if not tile_m > 0:
        raise InvalidParameterError(f"tile_m must be > 0 metres, got {tile_m}")
    i0, i1 = int(np.floor(x_range_m[0] / tile_m)), int(np.ceil(x_range_m[1] / tile_m))
    k0, k1 = int(np.floor(z_range_m[0] / tile_m)), int(np.ceil(z_range_m[1] / tile_m))
    ii, kk = np.meshgrid(
        np.arange(i0, max(i1, i0 + 1)), np.arange(k0, max(k1, k0 + 1)), indexing="ij"
    )
    ii, kk = ii.ravel(), kk.ravel()
    corners = np.array([[0, 0], [0, 1], [1, 1], [1, 0]], dtype=np.float64)  # (x, z) steps
    x = (ii[:, None] + corners[None, :, 0]) * tile_m
    z = (kk[:, None] + corners[None, :, 1]) * tile_m
    vertices = np.stack([x, np.zeros_like(x), z], axis=-1).reshape(-1, 3).astype(np.float32)
    base = 4 * np.arange(len(ii))[:, None]
    # (x, z) → (x, z + dz) → (x + dx, z + dz) is counter-clockwise seen from +y.
    faces = np.concatenate([base + [0, 1, 2], base + [0, 2, 3]], axis=0).astype(np.uint32)
    dark = ((ii + kk) % 2 == 1) if checker else np.zeros(len(ii), bool)
    tile_rgb = np.where(dark[:, None], np.asarray(rgb[1], float), np.asarray(rgb[0], float))
    colors = np.concatenate([tile_rgb, np.ones((len(ii), 1))], axis=1)
    colors = np.repeat(colors, 4, axis=0).astype(np.float32)
    return vertices, faces, colors


class _DynamicMesh:
    """A pyrender mesh node whose vertex positions change every frame.

    pyrender uploads a primitive's positions and normals once, interleaved in one
    vertex buffer.  When that buffer exists and has the expected layout it is
    overwritten in place (``glBufferSubData``); otherwise the node is rebuilt, which
    is always correct but re-uploads the triangle indices too.
    """

    def __init__(self, pyrender, scene, faces: np.ndarray, material, smooth: bool, colors=None):
        self._pyrender = pyrender
        self._scene = scene
        self._faces = faces
        self._material = material
        self._smooth = smooth
        self._colors = colors  # (V, 4) float32 per-vertex RGBA, or None
        self._node = None
        self._primitive = None
        self.rebuilds = 0
        self.in_place_updates = 0

    def _build(self, positions: np.ndarray, normals: np.ndarray | None) -> None:
        if self._node is not None:
            self._scene.remove_node(self._node)
        self._primitive = self._pyrender.Primitive(
            positions=positions,
            normals=normals,
            color_0=self._colors,
            indices=self._faces,
            material=self._material,
        )
        self._node = self._scene.add(self._pyrender.Mesh([self._primitive]))
        self.rebuilds += 1

    def update(self, positions: np.ndarray, offscreen) -> None:
        """Set the vertex positions (V, 3) float32, metres, before the next render."""
        normals = vertex_normals(positions, self._faces) if self._smooth else None
        prim = self._primitive
        buffers = getattr(prim, "_buffers", None)
        platform = getattr(offscreen, "_platform", None)
        if prim is None or not buffers or platform is None or not prim._in_context():
            self._build(positions, normals)
            return
        prim.positions = positions
        prim.normals = normals
        # pyrender's layout: positions, normals, then colours, interleaved per vertex.
        columns = [a for a in (positions, normals, self._colors) if a is not None]
        data = np.ascontiguousarray(np.hstack(columns), dtype=np.float32)
        from OpenGL import GL

        platform.make_current()
        GL.glBindBuffer(GL.GL_ARRAY_BUFFER, buffers[0])
        size = GL.glGetBufferParameteriv(GL.GL_ARRAY_BUFFER, GL.GL_BUFFER_SIZE)
        if int(size) != data.nbytes:  # another layout: rebuild
            GL.glBindBuffer(GL.GL_ARRAY_BUFFER, 0)
            self._build(positions, normals)
            return
        GL.glBufferSubData(GL.GL_ARRAY_BUFFER, 0, data.nbytes, data)
        GL.glBindBuffer(GL.GL_ARRAY_BUFFER, 0)
        self.in_place_updates += 1


class Renderer:
    """Offscreen OpenGL renderer (pyrender), one GL context per image size.

    Parameters
    ----------
    body_rgb : (3,) float
        Base colour of the body, in [0, 1].
    background_rgb : (3,) float
        Colour behind everything, in [0, 1].
    floor_rgb : two (3,) float
        Colours of the checker tiles, in [0, 1].
    tile_m : float
        Checker tile edge, metres.
    floor_margin_m : float
        How far the floor reaches beyond the body's footprint over the clip, metres.
    key_intensity, fill_intensity : float
        Directional light intensities (pyrender units, W/m²); the key light comes
        from above left of the camera, the fill from its right.
    ambient : float
        Ambient light level in [0, 1].

    Notes
    -----
    Holds GL contexts: call :meth:`close` (or use it as a context manager) to free
    them.  Not thread-safe.
    """

    def __init__(
        self,
        body_rgb: Sequence[float] = BODY_RGB,
        background_rgb: Sequence[float] = BACKGROUND_RGB,
        floor_rgb: tuple[Sequence[float], Sequence[float]] = FLOOR_RGB,
        tile_m: float = 0.5,
        floor_margin_m: float = 8.0,
        key_intensity: float = 2.0,
        fill_intensity: float = 0.8,
        ambient: float = 0.3,
    ):
        for name, rgb in (("body_rgb", body_rgb), ("background_rgb", background_rgb)):
            _check_rgb(name, rgb)
        if len(floor_rgb) != 2:
            raise InvalidParameterError(f"floor_rgb must hold two colours, got {floor_rgb!r}")
        for rgb in floor_rgb:
            _check_rgb("floor_rgb", rgb)
        if not tile_m > 0:
            raise InvalidParameterError(f"tile_m must be > 0 metres, got {tile_m}")
        if not floor_margin_m >= 0:
            raise InvalidParameterError(f"floor_margin_m must be >= 0 metres, got {floor_margin_m}")
        if not (key_intensity >= 0 and fill_intensity >= 0 and 0 <= ambient <= 1):
            raise InvalidParameterError(
                "light intensities must be >= 0 and ambient in [0, 1], got "
                f"key {key_intensity}, fill {fill_intensity}, ambient {ambient}"
            )
        self.body_rgb = tuple(float(c) for c in body_rgb)
        self.background_rgb = tuple(float(c) for c in background_rgb)
        self.floor_rgb = tuple(tuple(float(c) for c in rgb) for rgb in floor_rgb)
        self.tile_m = float(tile_m)
        self.floor_margin_m = float(floor_margin_m)
        self.key_intensity = float(key_intensity)
        self.fill_intensity = float(fill_intensity)
        self.ambient = float(ambient)
        self._pyrender = _import_pyrender()
        self._offscreen: dict[tuple[int, int], object] = {}
        #: Statistics of the last render: in-place buffer updates vs node rebuilds.
        self.last_update_counts: dict[str, int] = {}

    # -- contexts ------------------------------------------------------------------
    def _renderer(self, width: int, height: int):
        key = (int(width), int(height))
        if key not in self._offscreen:
            self._offscreen[key] = self._pyrender.OffscreenRenderer(*key)
        return self._offscreen[key]

    def close(self) -> None:
        """Free every GL context; the renderer may still be used (contexts are remade)."""
        while self._offscreen:
            _, offscreen = self._offscreen.popitem()
            _delete_offscreen(offscreen)

    def __del__(self):
        # Free the contexts before pyrender's own finaliser would terminate the shared
        # EGL display (see _delete_offscreen); nothing can be done at interpreter exit.
        try:
            self.close()
        except Exception:  # a finaliser must not raise
            pass

    def __enter__(self) -> Renderer:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # -- products ------------------------------------------------------------------
    def render_shaded(
        self,
        vertices: np.ndarray,
        faces: np.ndarray,
        camera: Camera | Sequence[Camera],
        floor: bool = True,
        checker: bool = True,
        shadows: bool = False,
        progress: bool = False,
        vertex_rgb: np.ndarray | None = None,
    ) -> np.ndarray:
        """Render a posed mesh, lit, on a floor, frame by frame.

        Parameters
        ----------
        vertices : (F, V, 3) float
            Vertex positions per frame, world metres (Y up, floor at y = 0).
        faces : (T, 3) int
            Triangles, counter-clockwise seen from outside (both sides are drawn).
        camera : Camera or sequence of F Cameras
            One fixed camera, or one per frame (e.g. following the body); all of one
            image size.
        floor : bool
            Draw a floor at y = 0 under the body's footprint over all frames.
        checker : bool
            Checker tiles; ``False`` gives a plain floor.
        shadows : bool
            Cast shadow-mapped shadows from the lights (about 5× slower on a
            software GL).
        progress : bool
            Show a progress bar on stderr.
        vertex_rgb : (V, 3) float, optional
            A colour per vertex in [0, 1] (e.g. a body and its garments, see
            :meth:`eigmotion.body.garments.DressedAvatar.vertex_rgb`) instead of the
            renderer's ``body_rgb``.

        Returns
        -------
        (F, H, W, 3) uint8
            RGB images; ``H, W = camera.height, camera.width``.

        Raises
        ------
        InvalidParameterError
            Wrong shapes, dtypes, face indices, non-finite vertices or cameras.
        """
        pyrender = self._pyrender
        vertices, faces = check_posed_mesh(vertices, faces)
        cameras = check_frame_cameras(camera, len(vertices))
        first = cameras[0]
        scene = pyrender.Scene(
            bg_color=[*self.background_rgb, 1.0], ambient_light=[self.ambient] * 3
        )
        floor_points = np.zeros((0, 3))
        if floor:
            lo = vertices.reshape(-1, 3).min(axis=0) - self.floor_margin_m
            hi = vertices.reshape(-1, 3).max(axis=0) + self.floor_margin_m
            fv, ff, fc = checker_floor(
                (lo[0], hi[0]), (lo[2], hi[2]), self.tile_m, self.floor_rgb, checker
            )
            floor_material = pyrender.MetallicRoughnessMaterial(
                baseColorFactor=[1.0, 1.0, 1.0, 1.0], metallicFactor=0.0, roughnessFactor=0.9
            )
            scene.add(
                pyrender.Mesh(
                    [
                        pyrender.Primitive(
                            positions=fv,
                            normals=np.tile(np.float32([0, 1, 0]), (len(fv), 1)),
                            color_0=fc,
                            indices=ff,
                            material=floor_material,
                        )
                    ]
                )
            )
            floor_points = fv.astype(np.float64)
        znear, zfar = depth_range(vertices, cameras, floor_points)
        cam_node = scene.add(
            _intrinsics_camera(pyrender, first, (0.0, 0.0), znear, zfar), pose=first.gl_pose()
        )
        key_node = scene.add(
            pyrender.DirectionalLight(color=np.ones(3), intensity=self.key_intensity),
            pose=_light_pose(first, KEY_LIGHT_DIRECTION_CAM),
        )
        fill_node = scene.add(
            pyrender.DirectionalLight(color=np.ones(3), intensity=self.fill_intensity),
            pose=_light_pose(first, FILL_LIGHT_DIRECTION_CAM),
        )
        colors = None
        if vertex_rgb is not None:
            rgb = np.asarray(vertex_rgb, dtype=np.float32)
            if rgb.shape != (vertices.shape[1], 3) or not np.all((rgb >= 0) & (rgb <= 1)):
                raise InvalidParameterError(
                    f"vertex_rgb must be ({vertices.shape[1]}, 3) colours in [0, 1], got "
                    f"shape {rgb.shape}"
                )
            colors = np.concatenate([rgb, np.ones((len(rgb), 1), np.float32)], axis=1)
        body_material = pyrender.MetallicRoughnessMaterial(
            baseColorFactor=[*(self.body_rgb if colors is None else (1.0, 1.0, 1.0)), 1.0],
            metallicFactor=0.0,
            roughnessFactor=0.65,
            doubleSided=True,
        )
        offscreen = self._renderer(first.width, first.height)
        body = _DynamicMesh(pyrender, scene, faces, body_material, smooth=True, colors=colors)
        out = np.empty((len(vertices), first.height, first.width, 3), dtype=np.uint8)
        flags = pyrender.RenderFlags.SHADOWS_DIRECTIONAL if shadows else pyrender.RenderFlags.NONE
        previous = first
        for f in _frames(len(vertices), progress, "rendering"):
            cam = cameras[f]
            if cam is not previous:
                scene.set_pose(cam_node, cam.gl_pose())
                cam_node.camera = _intrinsics_camera(pyrender, cam, (0.0, 0.0), znear, zfar)
                scene.set_pose(key_node, _light_pose(cam, KEY_LIGHT_DIRECTION_CAM))
                scene.set_pose(fill_node, _light_pose(cam, FILL_LIGHT_DIRECTION_CAM))
                previous = cam
            body.update(vertices[f], offscreen)
            color, _ = offscreen.render(scene, flags=flags)
            out[f] = color
        self.last_update_counts = {"in_place": body.in_place_updates, "rebuilds": body.rebuilds}
        return out

    def render_masks_gl(
        self,
        vertices: np.ndarray,
        faces: np.ndarray,
        camera: Camera | Sequence[Camera],
        progress: bool = False,
    ) -> np.ndarray:
        """Silhouettes of a posed mesh, rasterised by OpenGL.

        Parameters
        ----------
        vertices : (F, V, 3) float
            Vertex positions per frame, world metres.
        faces : (T, 3) int
            Triangles; either winding (both sides are drawn).
        camera : Camera or sequence of F Cameras
            One fixed camera or one per frame, of one image size.
        progress : bool
            Show a progress bar on stderr.

        Returns
        -------
        (F, H, W) bool
            True where the mesh covers the pixel centre (pixel ``(v, u)`` centred at
            integer ``(u, v)``, as :meth:`Camera.project`); ``H, W = camera.height,
            camera.width``.

        Raises
        ------
        InvalidParameterError
            As :meth:`render_shaded`.
        """
        pyrender = self._pyrender
        vertices, faces = check_posed_mesh(vertices, faces)
        cameras = check_frame_cameras(camera, len(vertices))
        first = cameras[0]
        offset = depth_sample_offset_px()
        # The depth-only pass culls back faces whatever the material says: draw both windings.
        both_sides = np.concatenate([faces, faces[:, ::-1]], axis=0)
        scene = pyrender.Scene(bg_color=[0.0, 0.0, 0.0, 1.0])
        znear, zfar = depth_range(vertices, cameras, np.zeros((0, 3)))
        znear = min(znear, 0.01)  # match the CPU rasteriser's near limit
        cam_node = scene.add(
            _intrinsics_camera(pyrender, first, offset, znear, zfar), pose=first.gl_pose()
        )
        offscreen = self._renderer(first.width, first.height)
        material = pyrender.MetallicRoughnessMaterial(doubleSided=True)
        body = _DynamicMesh(pyrender, scene, both_sides, material, smooth=False)
        out = np.empty((len(vertices), first.height, first.width), dtype=bool)
        previous = first
        for f in _frames(len(vertices), progress, "silhouettes"):
            cam = cameras[f]
            if cam is not previous:
                scene.set_pose(cam_node, cam.gl_pose())
                cam_node.camera = _intrinsics_camera(pyrender, cam, offset, znear, zfar)
                previous = cam
            body.update(vertices[f], offscreen)
            depth = offscreen.render(scene, flags=pyrender.RenderFlags.DEPTH_ONLY)
            out[f] = depth > 0
        self.last_update_counts = {"in_place": body.in_place_updates, "rebuilds": body.rebuilds}
        return out


def _check_rgb(name: str, rgb: Sequence[float]) -> None:
    values = np.asarray(rgb, dtype=np.float64)
    if values.shape != (3,) or not np.all((values >= 0) & (values <= 1)):
        raise InvalidParameterError(f"{name} must be three numbers in [0, 1], got {rgb!r}")


def _frames(n: int, progress: bool, desc: str):
    if not progress:
        return range(n)
    return tqdm(range(n), desc=desc, unit="frame", file=sys.stderr, leave=False)


@lru_cache(maxsize=1)
def depth_sample_offset_px() -> tuple[float, float]:
    """Where, inside a pixel, the GL depth image is sampled.

    pyrender draws into a 4× multisampled framebuffer and copies depth to the image
    it reads back by keeping one sample per pixel, chosen by the driver.  Rows of
    one-pixel-high strips, their left edges stepping by 1/32 px, show which strips
    cover the sample (and columns of strips the same vertically).

    Returns
    -------
    dx_px, dy_px : float
        Offset of the depth sample from the pixel centre, pixels, image axes (x
        right, y down), to within 1/64 px; ``(-0.125, 0.375)`` on Mesa llvmpipe.
    """
    pyrender = _import_pyrender()
    size, n, f = 64, 32, 64.0
    c = (size - 1) / 2.0
    quads = []
    for k in range(n):
        edge = 9.5 + (k + 0.5) / n
        row = 16 + k
        quads.append((edge, 40.0, row - 0.5, row + 0.5))  # strip k: row 16 + k
        quads.append((row - 0.5, row + 0.5, edge, 40.0))  # strip k: column 16 + k
    points, faces = [], []
    for u0, u1, v0, v1 in quads:
        base = len(points)
        for u, v in ((u0, v0), (u1, v0), (u1, v1), (u0, v1)):
            points.append(((u - c) / f, -(v - c) / f, -1.0))  # OpenGL camera frame, z = -1
        faces += [[base, base + 1, base + 2], [base, base + 2, base + 3]]
    faces = np.asarray(faces, dtype=np.uint32)
    faces = np.concatenate([faces, faces[:, ::-1]])
    scene = pyrender.Scene()
    scene.add(pyrender.Mesh([pyrender.Primitive(positions=np.float32(points), indices=faces)]))
    scene.add(pyrender.IntrinsicsCamera(f, f, c + 0.5, c + 0.5, 0.1, 10.0), pose=np.eye(4))
    offscreen = pyrender.OffscreenRenderer(size, size)
    try:
        covered = offscreen.render(scene, flags=pyrender.RenderFlags.DEPTH_ONLY) > 0
    finally:
        _delete_offscreen(offscreen)
    # Pixel 10 of strip k is covered iff 10 + d > 9.5 + (k + 0.5) / n.
    dx = covered[16 : 16 + n, 10].sum() / n - 0.5
    dy = covered[10, 16 : 16 + n].sum() / n - 0.5
    return float(dx), float(dy)


@lru_cache(maxsize=1)
def default_renderer() -> Renderer:
    """A process-wide :class:`Renderer` with the default look, made on first use."""
    return Renderer()


def render_shaded(
    vertices: np.ndarray,
    faces: np.ndarray,
    camera: Camera | Sequence[Camera],
    floor: bool = True,
    checker: bool = True,
    shadows: bool = False,
    progress: bool = False,
    vertex_rgb: np.ndarray | None = None,
) -> np.ndarray:
    """:meth:`Renderer.render_shaded` on the :func:`default_renderer`.

    Returns
    -------
    (F, H, W, 3) uint8
    """
    return default_renderer().render_shaded(
        vertices, faces, camera, floor, checker, shadows, progress, vertex_rgb
    )


def render_masks_gl(
    vertices: np.ndarray,
    faces: np.ndarray,
    camera: Camera | Sequence[Camera],
    progress: bool = False,
) -> np.ndarray:
    """:meth:`Renderer.render_masks_gl` on the :func:`default_renderer`.

    Returns
    -------
    (F, H, W) bool
    """
    return default_renderer().render_masks_gl(vertices, faces, camera, progress)
