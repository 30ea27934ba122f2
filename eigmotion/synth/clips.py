"""Synthetic query clips: a motion on a body, filmed by one still camera, in a scene.

Used for the bundled sample clips, the accuracy benchmarks and integration tests: the
avatar (any body shape, in any garments) performs a motion, a fixed camera at a given
azimuth and elevation films it (shaded with pyrender, true silhouettes with the CPU
rasteriser), and :func:`eigmotion.synth.scene.compose_scene` puts it over a textured
background with a cast shadow, camouflaged clothing and sensor noise.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from eigmotion.body.avatar import Avatar
from eigmotion.body.garments import DressedAvatar, dress
from eigmotion.body.retarget import animate_avatar
from eigmotion.imaging.cameras import Camera, virtual_rig
from eigmotion.imaging.render import BODY_RGB, render_shaded
from eigmotion.imaging.silhouettes import render_masks
from eigmotion.mocap.motion import Motion
from eigmotion.retrieval.library_views import hull_points
from eigmotion.synth.scene import compose_scene


@dataclass(frozen=True, eq=False)
class SyntheticClip:
    """A rendered clip with its ground truth.

    Attributes
    ----------
    frames : (F, H, W, 3) uint8
        The composed video, RGB.
    background : (H, W, 3) uint8
        The empty scene.
    true_masks : (F, H, W) bool
        The body's silhouettes.
    fps : float
    camera : Camera
    """

    frames: np.ndarray
    background: np.ndarray
    true_masks: np.ndarray
    fps: float
    camera: Camera


def clip_camera(
    vertices: np.ndarray,
    azimuth_deg: float,
    elevation_deg: float,
    width: int = 320,
    height: int = 240,
    margin: float = 0.08,
) -> Camera:
    """The still camera of a query clip: looking from a direction, fitted to the motion.

    Parameters
    ----------
    vertices : (F, V, 3) float
        The posed body over the whole clip, world metres.
    azimuth_deg, elevation_deg : float
        Camera direction (see :mod:`eigmotion.imaging.cameras`).
    width, height : int
        Image size, pixels.
    margin : float
        Fraction of the frame kept free around the whole motion.

    Returns
    -------
    Camera
        Aimed and placed so that every frame of the body stays in view.
    """
    rig = virtual_rig([azimuth_deg], [elevation_deg], width, height)
    return rig.fitted(hull_points(vertices), margin=margin)[0]


def render_clip(
    motion: Motion,
    avatar: Avatar,
    azimuth_deg: float,
    elevation_deg: float,
    rng: np.random.Generator,
    width: int = 320,
    height: int = 240,
    fps: float = 30.0,
    margin: float = 0.08,
    shadow: bool = True,
    noise_sigma: float = 3.0,
    camouflage: float = 0.25,
    garments: Sequence[str] = (),
) -> SyntheticClip:
    """Film ``motion`` on ``avatar`` with one still camera and compose the scene.

    Parameters
    ----------
    motion : Motion
    avatar : Avatar
        The body (e.g. ``load_default_avatar().with_shape(...)``).
    azimuth_deg, elevation_deg : float
        Camera direction (see :mod:`eigmotion.imaging.cameras`).
    rng : numpy.random.Generator
        Scene randomness (background, shadow, clothing, noise).
    width, height : int
        Frame size, pixels.
    fps : float
        The clip's frame rate; the motion is resampled to it.
    margin : float
        Fraction of the frame kept free around the whole motion.
    garments : sequence of str
        Garments the body wears (names from :data:`eigmotion.body.garments.GARMENTS`),
        each shaded in its own colour; the true masks include them.

    Returns
    -------
    SyntheticClip
    """
    body = dress(avatar, garments)
    _, vertices = animate_avatar(body, motion.resample(fps))
    camera = clip_camera(vertices, azimuth_deg, elevation_deg, width, height, margin)
    colours = body.vertex_rgb(BODY_RGB) if isinstance(body, DressedAvatar) else None
    shaded = render_shaded(vertices, body.faces, camera, floor=False, vertex_rgb=colours)
    masks = render_masks(vertices, body.faces, camera)
    frames, background = compose_scene(
        shaded, masks, rng, shadow=shadow, noise_sigma=noise_sigma, camouflage=camouflage
    )
    return SyntheticClip(frames, background, masks, float(fps), camera)


def time_warped(motion: Motion, speeds: tuple[float, ...], fps: float) -> Motion:
    """A motion whose speed changes along the way, for clips that must be aligned in time.

    Parameters
    ----------
    motion : Motion
    speeds : tuple of float
        The motion is cut into ``len(speeds)`` equal parts; part ``k`` is played at
        ``speeds[k]`` × its recorded speed (> 0).
    fps : float
        Frame rate of the result, frames per second.

    Returns
    -------
    Motion
        At ``fps``; the parts joined without repeating their shared frame.
    """
    bounds = np.linspace(0, motion.n_frames - 1, len(speeds) + 1).round().astype(int)
    values = []
    for k, speed in enumerate(speeds):
        part = motion.trim(bounds[k], bounds[k + 1] + 1)
        part = part.replace(frame_time_s=motion.frame_time_s / speed).resample(fps)
        values.append(part.values if k == 0 else part.values[1:])
    return motion.replace(values=np.concatenate(values), frame_time_s=1.0 / fps)
