"""The avatar walk the motion-image and video benchmarks film, and its composed scenes.

The walk is CMU 02_01 on the default avatar decimated to the database's face count;
:func:`ring_camera` and :func:`offset_camera` film it, :func:`composed_walks` puts it
over textured backgrounds (:func:`eigmotion.synth.scene.compose_scene`).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence

import numpy as np

from eigmotion.body.avatar import DEFAULT_LOW_POLY_FACES, Avatar, load_default_avatar
from eigmotion.body.retarget import animate_avatar
from eigmotion.imaging.cameras import (
    Camera,
    fit_distance,
    intrinsics,
    look_at,
    ring_rig,
    view_direction,
)
from eigmotion.imaging.render import render_shaded
from eigmotion.imaging.silhouettes import render_masks
from eigmotion.mocap.amc import read_amc
from eigmotion.mocap.motion import Motion
from eigmotion.resources import library_manifest
from eigmotion.synth.scene import compose_scene

#: The CMU motions of the bundled library (``database/motions/cmu``).
CMU = library_manifest().parent / "cmu"

#: Frames of the 1.5 s walk used by the video benchmarks, at 30 fps.
WALK_FRAMES_30FPS = 46

#: Views of the video benchmarks: name → (width, height, ring index, label); the ring
#: index picks azimuth ``90 * index`` of :func:`ring_camera`.
WALK_VIEWS = {
    "side90": (160, 120, 1, "side az 90"),
    "side90-320": (320, 240, 1, "side az 90"),
    "side270": (160, 120, 3, "side az 270"),
    "front": (160, 120, 0, "front az 0"),
}


def walk_views(names: Sequence[str]) -> tuple[list[tuple[int, int, int]], dict]:
    """The ``(width, height, ring index)`` views of :data:`WALK_VIEWS` ``names``, and a
    ``view → "label  WxH"`` dict for printing."""
    views, labels = [], {}
    for name in names:
        width, height, index, label = WALK_VIEWS[name]
        views.append((width, height, index))
        labels[width, height, index] = f"{label:<13} {width}x{height:<4}"
    return views, labels


def walk_motion() -> Motion:
    """The walk CMU 02_01 as recorded (120 fps)."""
    return read_amc(CMU / "amc" / "02_01.amc", CMU / "asf" / "02.asf")


def low_poly_avatar() -> Avatar:
    """The default avatar decimated to the database's face count."""
    return load_default_avatar().decimated(DEFAULT_LOW_POLY_FACES)


def walk_vertices(body: Avatar, fps: float, n_frames: int) -> np.ndarray:
    """(F, V, 3) vertices of ``body`` walking: the first ``n_frames`` at ``fps``."""
    _, vertices = animate_avatar(body, walk_motion().resample(fps).trim(0, n_frames))
    return vertices


def ring_camera(vertices: np.ndarray, index: int, width: int, height: int) -> Camera:
    """View ``index`` of a 4-camera ring at 10° elevation (azimuth ``90 * index``),
    fitted to the whole motion."""
    rig = ring_rig(4, 10.0, width=width, height=height)
    return rig.fitted(vertices[:, ::10])[index]


def offset_camera(
    vertices: np.ndarray,
    azimuth_deg: float,
    elevation_deg: float,
    width: int,
    height: int,
    distance_factor: float = 1.0,
    aim_offset_m: Sequence[float] = (0.0, 0.0, 0.0),
) -> Camera:
    """A 40° camera ``distance_factor`` times further than the fitted distance, aimed
    ``aim_offset_m`` away from the centre of the motion (the person small, off-centre)."""
    points = vertices[:, ::7].reshape(-1, 3)
    centre = 0.5 * (points.min(axis=0) + points.max(axis=0))
    K = intrinsics(width, height, 40.0)
    distance = fit_distance(points, centre, azimuth_deg, elevation_deg, K, width, height)
    eye = centre + distance_factor * distance * view_direction(azimuth_deg, elevation_deg)
    return look_at(eye, centre + np.asarray(aim_offset_m), K, width, height)


def composed_walks(
    views: Sequence[tuple[int, int, int]], seeds: Sequence[int]
) -> Iterator[tuple[tuple[int, int, int], int, np.ndarray, np.ndarray, np.ndarray]]:
    """The 1.5 s avatar walk filmed from each ``(width, height, ring index)`` view and
    composed by :func:`eigmotion.synth.scene.compose_scene` with each seed.

    Yields ``(view, seed, true_masks, frames, background)``.
    """
    body = low_poly_avatar()
    vertices = walk_vertices(body, 30.0, WALK_FRAMES_30FPS)
    for view in views:
        width, height, index = view
        camera = ring_camera(vertices, index, width, height)
        truth = render_masks(vertices, body.faces, camera)
        rgb = render_shaded(vertices, body.faces, camera, floor=False)
        for seed in seeds:
            frames, background = compose_scene(rgb, truth, np.random.default_rng(seed))
            yield view, seed, truth, frames, background
