"""Synthetic test scenes: a person composed over a textured background, seeded.

Used by the tests of the video front end and by the accuracy benchmark to make clips
whose true silhouettes are known.  Everything random comes from the
``numpy.random.Generator`` passed in, so a seed gives the same scene every time.

:func:`compose_scene` puts given person frames (rendered RGB, or a flat two-colour
outfit) over a procedural background — a wall with stripes and smooth noise over a
tiled floor — and adds what makes silhouette extraction hard in real video: a cast
shadow on the floor, clothing whose colour is close to the background in places
(camouflage), slight optical blur and Gaussian sensor noise.

:func:`stick_figure_masks` draws a simple articulated figure (head, trunk, two-segment
arms and legs) walking and swinging its arms, as a continuous function of time, so the
same motion can be sampled at any frame rate.
"""

from __future__ import annotations

from dataclasses import dataclass
from numbers import Real

import cv2
import numpy as np

from eigmotion.errors import InvalidParameterError
from eigmotion.validation import Interval, validate_params

#: The valid values of :func:`compose_scene`'s scalar parameters (see
#: :mod:`eigmotion.validation`).
SCENE_CONSTRAINTS = {
    "shadow_strength": Interval(Real, 0.0, 0.9, noun=""),
    "camouflage": Interval(Real, 0.0, 1.0, noun=""),
    "camouflage_delta": Interval(Real, 0.0, 255.0, noun=""),
    "noise_sigma": Interval(Real, 0.0, 50.0, noun=""),
    "blur_sigma_px": Interval(Real, 0.0, 5.0, noun=""),
}


@dataclass(frozen=True)
class SceneLayout:
    """Where things ended up in a composed scene (for tests and reports).

    Attributes
    ----------
    horizon_row : int
        First image row of the floor; rows above it are wall.
    shadow_masks : (F, H, W) bool
        Where the cast shadow darkens the floor and is not hidden by the person.
    camouflage_masks : (F, H, W) bool
        Person pixels recoloured close to the background.
    """

    horizon_row: int
    shadow_masks: np.ndarray
    camouflage_masks: np.ndarray


def compose_scene(
    person_rgb: np.ndarray | None,
    person_masks: np.ndarray,
    rng: np.random.Generator,
    *,
    shadow: bool = True,
    shadow_strength: float = 0.45,
    camouflage: float = 0.25,
    camouflage_delta: float = 18.0,
    noise_sigma: float = 3.0,
    blur_sigma_px: float = 0.7,
) -> tuple[np.ndarray, np.ndarray]:
    """Compose person frames over a textured background with shadow, camouflage, noise.

    Parameters
    ----------
    person_rgb : (F, H, W, 3) uint8 or None
        The person's colours (e.g. a shaded rendering), used where ``person_masks``
        is set; ``None`` dresses the silhouette in a random shirt and trousers.
    person_masks : (F, H, W) bool
        True silhouettes.
    rng : numpy.random.Generator
        Source of every random choice (background, shadow direction, colours, noise).
    shadow : bool
        Cast a shadow: each frame's silhouette sheared and flattened from its feet
        onto the floor, darkening the floor by ``shadow_strength``.
    shadow_strength : float
        Fraction of brightness the shadow removes, in [0, 0.9].
    camouflage : float
        Height of a band across the body, as a fraction of the body height, in
        [0, 1], whose clothing takes the mean background colour behind it (plus
        ``camouflage_delta``).  0 disables it.
    camouflage_delta : float
        RGB distance, 0–255 levels, between the camouflaged clothing and that mean
        background colour, in [0, 255].
    noise_sigma : float
        Standard deviation of the Gaussian sensor noise, 0–255 levels, in [0, 50].
    blur_sigma_px : float
        Gaussian optical blur before the noise, pixels, in [0, 5] (0: none).

    Returns
    -------
    frames : (F, H, W, 3) uint8
        The composed video, RGB.
    background : (H, W, 3) uint8
        The empty scene, blurred like the frames and with its own independent noise
        (a separate photograph of the empty stage, as a user would take).
    """
    frames, background, _ = compose_scene_with_layout(
        person_rgb,
        person_masks,
        rng,
        shadow=shadow,
        shadow_strength=shadow_strength,
        camouflage=camouflage,
        camouflage_delta=camouflage_delta,
        noise_sigma=noise_sigma,
        blur_sigma_px=blur_sigma_px,
    )
    return frames, background


def compose_scene_with_layout(
    person_rgb: np.ndarray | None,
    person_masks: np.ndarray,
    rng: np.random.Generator,
    *,
    shadow: bool = True,
    shadow_strength: float = 0.45,
    camouflage: float = 0.25,
    camouflage_delta: float = 18.0,
    noise_sigma: float = 3.0,
    blur_sigma_px: float = 0.7,
) -> tuple[np.ndarray, np.ndarray, SceneLayout]:
    """:func:`compose_scene`, also returning the :class:`SceneLayout` it used."""
    masks = _check_person(person_rgb, person_masks)
    if not isinstance(rng, np.random.Generator):
        raise InvalidParameterError(
            f"rng must be a numpy.random.Generator (np.random.default_rng(seed)), got "
            f"{type(rng).__name__}"
        )
    validate_params(
        {
            "shadow_strength": shadow_strength,
            "camouflage": camouflage,
            "camouflage_delta": camouflage_delta,
            "noise_sigma": noise_sigma,
            "blur_sigma_px": blur_sigma_px,
        },
        SCENE_CONSTRAINTS,
    )
    n, h, w = masks.shape

    body = _body_boxes(masks)
    occupied = body[:, 0] >= 0
    if occupied.any():
        feet_row = int(body[occupied, 1].min())
        height_px = float(np.median(body[occupied, 1] - body[occupied, 0] + 1))
        horizon = int(feet_row - rng.uniform(0.25, 0.5) * height_px)
    else:
        horizon = int(rng.uniform(0.4, 0.6) * h)
    horizon = int(np.clip(horizon, round(0.15 * h), round(0.9 * h)))
    background = procedural_background(h, w, horizon, rng)

    # -- the person's colours ------------------------------------------------------
    if person_rgb is None:
        person = _outfit(masks, body, rng)
    else:
        person = np.asarray(person_rgb, dtype=np.float32)
    camo = np.zeros_like(masks)
    if camouflage > 0.0 and occupied.any():
        person, camo = _camouflage(
            person, masks, body, background, camouflage, camouflage_delta, rng
        )

    # -- the floor shadow ------------------------------------------------------------
    scene = np.broadcast_to(background.astype(np.float32), (n, h, w, 3)).copy()
    shadows = np.zeros_like(masks)
    if shadow and occupied.any():
        shear = rng.uniform(0.6, 1.1) * rng.choice([-1.0, 1.0])
        flat = rng.uniform(0.2, 0.35)
        floor = np.zeros((h, w), np.float32)
        floor[horizon:] = 1.0
        for i in np.flatnonzero(occupied):
            soft = _cast_shadow(masks[i], body[i], shear, flat) * floor
            scene[i] *= (1.0 - shadow_strength * soft)[..., None]
            shadows[i] = (soft > 0.5) & ~masks[i]

    scene = np.where(masks[..., None], person, scene)
    frames = np.stack([_camera(f, blur_sigma_px, noise_sigma, rng, cv2) for f in scene])
    empty = _camera(background.astype(np.float32), blur_sigma_px, noise_sigma, rng, cv2)
    return frames, empty, SceneLayout(horizon, shadows, camo)


def procedural_background(
    height: int, width: int, horizon_row: int, rng: np.random.Generator
) -> np.ndarray:
    """A wall over a floor, textured and seeded.

    Parameters
    ----------
    height, width : int
        Image size, pixels.
    horizon_row : int
        First row of the floor.
    rng : numpy.random.Generator

    Returns
    -------
    (height, width, 3) uint8
        The wall: a base colour with vertical stripes of random widths and colours
        and smooth noise.  The floor: another colour with perspective tiles and
        fine noise.
    """
    if height < 2 or width < 2:
        raise InvalidParameterError(f"image size must be at least 2×2, got {width}×{height}")
    horizon_row = int(np.clip(horizon_row, 0, height))
    img = np.empty((height, width, 3), np.float32)

    # Wall: stripes with a random palette around one base colour.
    base = rng.uniform(60, 200, 3)
    edges = np.cumsum(rng.integers(max(2, width // 24), max(3, width // 6), size=width))
    edges = edges[edges < width]
    stripe_of_col = np.searchsorted(edges, np.arange(width), side="right")
    palette = np.clip(base + rng.normal(0.0, 35.0, (len(edges) + 1, 3)), 10, 245)
    img[:horizon_row] = palette[stripe_of_col][None]
    # Floor: tiles in a simple perspective (rows closer together towards the horizon).
    floor_base = rng.uniform(50, 190, 3)
    floor_alt = np.clip(floor_base + rng.normal(0.0, 30.0, 3), 10, 245)
    rows = np.arange(height - horizon_row, dtype=np.float64)
    depth = np.log1p(rows / max(1.0, 0.08 * height))  # compresses near the horizon
    cols = np.arange(width, dtype=np.float64) - width / 2.0
    spread = 1.0 + rows[:, None] / max(1.0, 0.25 * height)
    tile = (np.floor(depth[:, None] * 2.5) + np.floor(cols[None, :] / (12.0 * spread))) % 2
    img[horizon_row:] = np.where(tile[..., None] > 0, floor_alt, floor_base)
    # Smooth illumination-like noise and a fine grain everywhere.
    coarse = rng.normal(0.0, 1.0, (max(2, height // 16), max(2, width // 16), 3))
    smooth = cv2.resize(coarse.astype(np.float32), (width, height), interpolation=cv2.INTER_CUBIC)
    img += 12.0 * smooth + rng.normal(0.0, 4.0, img.shape).astype(np.float32)
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


def stick_figure_masks(
    n_frames: int,
    height: int = 120,
    width: int = 160,
    *,
    fps: float = 30.0,
    body_height_px: float = 80.0,
    start_x_px: float | None = None,
    feet_row_px: float | None = None,
    walk_speed_px_s: float = 20.0,
    cycle_s: float = 1.0,
    arm_swing_deg: float = 40.0,
    leg_swing_deg: float = 25.0,
    raise_arms_deg: float = 0.0,
    reverse: bool = False,
) -> np.ndarray:
    """An articulated stick figure walking and moving its arms.

    Every pose is a function of time ``t = i / fps``, so the same motion can be drawn
    at any frame rate.

    Parameters
    ----------
    n_frames : int
        Frames to draw.
    height, width : int
        Image size, pixels.
    fps : float
        Frame rate, frames per second.
    body_height_px : float
        Standing height, pixels.
    start_x_px, feet_row_px : float, optional
        Where the feet are at ``t = 0``; default: a quarter in from the left, and
        4 % of the height above the bottom.
    walk_speed_px_s : float
        Horizontal speed, pixels per second (negative: walks left).
    cycle_s : float
        Duration of one gait cycle, seconds.
    arm_swing_deg, leg_swing_deg : float
        Amplitudes of the swing of the upper arm and the thigh about the vertical.
    raise_arms_deg : float
        Both arms lift sideways linearly over the clip from 0 to this angle (a
        motion whose reverse is a different motion).
    reverse : bool
        Play the motion backwards (frame ``i`` shows time ``(n_frames - 1 - i)/fps``).

    Returns
    -------
    (n_frames, height, width) bool
    """
    if n_frames < 1:
        raise InvalidParameterError(f"n_frames must be >= 1, got {n_frames}")
    if fps <= 0 or cycle_s <= 0 or body_height_px <= 0:
        raise InvalidParameterError(
            f"fps, cycle_s and body_height_px must be > 0, got {fps}, {cycle_s}, {body_height_px}"
        )
    x_start = 0.25 * width if start_x_px is None else float(start_x_px)
    feet_row = 0.96 * height if feet_row_px is None else float(feet_row_px)
    bh = float(body_height_px)
    shift = 4  # cv2 fixed-point bits: sub-pixel joint positions
    one = 1 << shift
    masks = np.zeros((n_frames, height, width), np.uint8)
    duration_s = (n_frames - 1) / fps
    limb = max(1, int(round(0.07 * bh)))
    trunk = max(1, int(round(0.16 * bh)))
    for i in range(n_frames):
        t = (n_frames - 1 - i) / fps if reverse else i / fps
        phase = 2.0 * np.pi * t / cycle_s
        hip = np.array([x_start + walk_speed_px_s * t, feet_row - 0.5 * bh])
        hip[1] -= 0.02 * bh * abs(np.sin(phase))  # bob
        neck = hip + [0.0, -0.32 * bh]
        lift = np.deg2rad(raise_arms_deg) * (t / duration_s if duration_s > 0 else 0.0)
        img = masks[i]

        def seg(a, b, thick, img=img):
            cv2.line(
                img,
                tuple(np.rint(a * one).astype(int)),
                tuple(np.rint(b * one).astype(int)),
                1,
                thick,
                cv2.LINE_8,
                shift,
            )

        for side in (-1.0, 1.0):
            # Legs: thigh swings, shin bends back on the swing.
            thigh = side * np.deg2rad(leg_swing_deg) * np.sin(phase)
            knee = hip + 0.25 * bh * np.array([np.sin(thigh), np.cos(thigh)])
            shin = thigh - np.deg2rad(20.0) * max(0.0, side * np.cos(phase))
            foot = knee + 0.25 * bh * np.array([np.sin(shin), np.cos(shin)])
            seg(hip, knee, limb)
            seg(knee, foot, limb)
            # Arms: swing opposite to the legs, lift sideways over the clip.
            swing = -side * np.deg2rad(arm_swing_deg) * np.sin(phase) + side * lift
            shoulder = neck + [side * 0.05 * bh, 0.02 * bh]
            elbow = shoulder + 0.17 * bh * np.array([np.sin(swing), np.cos(swing)])
            fore = swing + side * np.deg2rad(15.0)
            hand = elbow + 0.16 * bh * np.array([np.sin(fore), np.cos(fore)])
            seg(shoulder, elbow, limb)
            seg(elbow, hand, limb)
        seg(hip, neck, trunk)
        head = neck + [0.0, -0.09 * bh]
        axes = (int(round(0.055 * bh * one)), int(round(0.075 * bh * one)))
        cv2.ellipse(
            img, tuple(np.rint(head * one).astype(int)), axes, 0, 0, 360, 1, -1, cv2.LINE_8, shift
        )
    return masks.astype(bool)


# -- helpers -----------------------------------------------------------------------------


def _check_person(person_rgb, person_masks) -> np.ndarray:
    masks = np.asarray(person_masks)
    if masks.ndim != 3 or min(masks.shape) < 1:
        raise InvalidParameterError(f"person_masks must have shape (F, H, W), got {masks.shape}")
    masks = masks.astype(bool)
    if person_rgb is not None:
        rgb = np.asarray(person_rgb)
        if rgb.shape != masks.shape + (3,) or rgb.dtype != np.uint8:
            raise InvalidParameterError(
                f"person_rgb must be uint8 of shape {masks.shape + (3,)} to match "
                f"person_masks, got {rgb.dtype} {rgb.shape}"
            )
    return masks


def _body_boxes(masks: np.ndarray) -> np.ndarray:
    """(F, H, W) bool → (F, 4) int [top, bottom, left, right] inclusive; -1 where empty."""
    rows = masks.any(axis=2)
    cols = masks.any(axis=1)
    out = np.full((masks.shape[0], 4), -1, np.int64)
    has = rows.any(axis=1)
    h, w = masks.shape[1:]
    out[has, 0] = rows[has].argmax(axis=1)
    out[has, 1] = h - 1 - rows[has][:, ::-1].argmax(axis=1)
    out[has, 2] = cols[has].argmax(axis=1)
    out[has, 3] = w - 1 - cols[has][:, ::-1].argmax(axis=1)
    return out


def _outfit(masks: np.ndarray, body: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A flat shirt above the body's middle row and trousers below, with mild shading."""
    n, h, w = masks.shape
    shirt, trousers = rng.uniform(30, 225, 3), rng.uniform(30, 225, 3)
    rows = np.arange(h)[None, :, None]
    middle = ((body[:, 0] + body[:, 1]) / 2.0)[:, None, None]
    upper = rows < middle
    shade = 1.0 + 0.08 * np.sin(np.arange(w) / 3.0)[None, None, :]
    out = np.where(upper[..., None], shirt, trousers) * shade[..., None]
    return np.broadcast_to(out, (n, h, w, 3)).astype(np.float32)


def _camouflage(person, masks, body, background, fraction, delta, rng):
    """Recolour a band of the body to the mean background colour behind it (+ delta)."""
    n = masks.shape[0]
    start = rng.uniform(0.15, max(0.15, 1.0 - fraction))
    top = body[:, 0] + start * (body[:, 1] - body[:, 0])
    bottom = top + fraction * (body[:, 1] - body[:, 0])
    rows = np.arange(masks.shape[1])[None, :, None]
    band = masks & (rows >= top[:, None, None]) & (rows <= bottom[:, None, None])
    band &= (body[:, 0] >= 0)[:, None, None]
    if not band.any():
        return person, band
    target = background[band.any(axis=0)].reshape(-1, 3).astype(np.float32).mean(axis=0)
    direction = rng.normal(size=3)
    colour = np.clip(target + delta * direction / np.linalg.norm(direction), 0, 255)
    person = np.array(person, dtype=np.float32, copy=True)
    luma = person @ np.float32([0.299, 0.587, 0.114])
    for i in range(n):  # keep the rendering's shading inside the band
        if band[i].any():
            shade = luma[i][band[i]] / max(float(luma[i][band[i]].mean()), 1.0)
            person[i][band[i]] = colour * np.clip(shade, 0.8, 1.2)[:, None]
    return person, band


def _cast_shadow(mask: np.ndarray, box: np.ndarray, shear: float, flat: float) -> np.ndarray:
    """(H, W) float in [0, 1]: the silhouette sheared and flattened from its feet."""
    h, w = mask.shape
    y_foot = float(box[1])  # the shear pivots about the lowest row of the silhouette
    matrix = np.array([[1.0, -shear, shear * y_foot], [0.0, flat, y_foot * (1.0 - flat)]])
    cast = cv2.warpAffine(mask.astype(np.float32), matrix, (w, h), flags=cv2.INTER_LINEAR)
    return cv2.GaussianBlur(cast, (0, 0), 1.2)


def _camera(image: np.ndarray, blur_sigma_px: float, noise_sigma: float, rng, cv2) -> np.ndarray:
    """Optics then sensor: Gaussian blur, additive Gaussian noise, uint8."""
    out = image.astype(np.float32)
    if blur_sigma_px > 0.0:
        out = cv2.GaussianBlur(out, (0, 0), blur_sigma_px)
    if noise_sigma > 0.0:
        out = out + rng.normal(0.0, noise_sigma, out.shape).astype(np.float32)
    return np.clip(np.rint(out), 0, 255).astype(np.uint8)
