"""Learned masks and the classical subtraction together: for clips with an image of the
empty scene (:func:`fuse_masks`), and, without one, against the scene the clip itself
shows (:func:`without_seen_scene`).

The learned front end (:mod:`eigmotion.segmentation.learned`) finds the whole body but
rounds off thin limbs; subtracting the image of the empty scene finds what differs
from it, limbs included, but also shadows and, where the person's colours match the
scene, loses pieces of the body.  Fused, the learned mask is the person and what the
subtraction finds within :data:`NEAR_PX` pixels (working size) of it is added:

    person = learned | (subtracted & grown(learned, NEAR_PX))

then the largest blob and the big pieces beside it, as everywhere
(:func:`~eigmotion.segmentation.learned.person_in_frame`).  Every piece the
subtraction finds that touches the learned mask is added whole instead in two kinds of
frame: where the learned mask is much smaller than usual in the clip (under
:data:`LOST_SHARE` of its median area: the network lost part of a person dressed like
the scene), and where the subtraction covers most of the learned mask (at least
:data:`AGREEING_SHARE`: it sees the body the network sees, so a limb it finds attached
is the person's — a kicking leg, an arm held out, which the networks round off or
lose).  In the second kind only limbs come whole: the pieces beyond the two pixels
that are large (:data:`LIMB_SHARE` of the learned mask) and thick (they outlast an
opening by :data:`LIMB_MIN_WIDTH_PX`), not the seam of a wall the head passes or the
gap between the legs.

A frame where the learned front end finds no one takes the subtraction's person only
where the networks lost a person who is there: between two frames at most
:data:`GAP_FRAMES` apart whose fused masks hold the person, the subtraction's person
(:func:`~eigmotion.segmentation.learned.person_in_frame`) lying in the box around both
of theirs (grown by :data:`GAP_REACH` of its height) and of an area between
:data:`GAP_AREA_RATIO` times less and more than theirs (a person far away, a few dozen
pixels tall, whom the networks miss for a few frames).  Elsewhere such a frame stays
empty: the subtraction alone there is the shadow or the scene that moved.

Before that, what the networks take for the person but the frame shows exactly as the
empty scene is not the person: a stool or a chair the person sits on, a box beside
them.  In a frame where the subtraction found the person (it covers at least
:data:`SCENE_FOUND_SHARE` of the learned mask: not an image of the scene taken with the
person in it, nor clothes the colour of the scene), where the learned mask lies more
than :data:`SCENE_NEAR_PX` pixels from anything the subtraction found, on pixels whose
colour difference to the empty scene is under the clip's low threshold
(``plain_scene``, :func:`~eigmotion.segmentation.subtraction.subtract_scene`), the
solid pieces of it (they outlast an opening by a 3 × 3 square) of at least
:data:`SCENE_PIECE_SHARE` of the learned mask's area are taken out of it.  Clothes the
colour of the scene are not: the smoothed difference keeps their small, consistent
offset above the threshold.  ``docs/segmentation.md`` compares this with the other ways
of combining them, measured on the development set.

Without an image of the empty scene the learned front end takes the same pieces out
against the scene the clip shows where the learned masks leave it
(:func:`~eigmotion.segmentation.background.seen_scene`), on the pixels it shows in
enough of the frames: where the person never leaves a pixel nothing is known of the
scene there, and nothing is taken out (:func:`without_seen_scene`).  Each shot of an
edited clip shows its own scene (:mod:`~eigmotion.segmentation.shots`); a shot whose
frames show no steady scene (the camera pans or zooms) keeps its learned masks.
"""

from __future__ import annotations

from dataclasses import replace

import cv2
import numpy as np

from eigmotion.errors import InvalidParameterError, SceneMismatchError
from eigmotion.segmentation.background import seen_scene
from eigmotion.segmentation.config import SilhouetteConfig
from eigmotion.segmentation.learned import person_in_frame
from eigmotion.segmentation.shots import shot_spans
from eigmotion.segmentation.subtraction import frame_chunks, subtract_scene

#: What the subtraction finds is kept within this many pixels (working size) of the
#: learned mask.
NEAR_PX = 2

#: In a frame where the learned mask covers less than this share of the clip's median
#: learned area, the network has lost part of the person (colours like the scene's):
#: every piece of the subtraction that touches the learned mask is kept whole.
LOST_SHARE = 0.7

#: In a frame where the subtraction covers at least this share of the learned mask, the
#: two see the same body: the pieces of the subtraction that touch the learned mask and
#: are limbs (:func:`_limbs`) are kept whole.
AGREEING_SHARE = 0.8

#: A piece the subtraction finds beyond :data:`NEAR_PX` of the learned mask, in a frame
#: where the two agree, is a limb when it covers at least this share of the learned
#: mask's area...
LIMB_SHARE = 0.03

#: ... and part of it is at least this many pixels (working size) thick: it outlasts a
#: morphological opening by a square of this side.
LIMB_MIN_WIDTH_PX = 3

#: The learned mask is looked at for pieces of the empty scene only in frames where the
#: subtraction covers at least this share of it...
SCENE_FOUND_SHARE = 0.5

#: ... farther than this many pixels (working size) from anything the subtraction
#: found...
SCENE_NEAR_PX = 2

#: ... in pieces of at least this share of the learned mask's area.
SCENE_PIECE_SHARE = 0.02

#: The disc of :data:`SCENE_NEAR_PX`, and the square a solid piece outlasts.
_SCENE_NEAR = cv2.getStructuringElement(
    cv2.MORPH_ELLIPSE, (2 * SCENE_NEAR_PX + 1, 2 * SCENE_NEAR_PX + 1)
)
_SOLID = np.ones((3, 3), np.uint8)

#: A run of frames where the learned front end finds no one is filled from the
#: subtraction only when the fused masks hold the person on both sides of it, at most
#: this many frames apart...
GAP_FRAMES = 8

#: ... with the subtraction's person inside the box around both of theirs, grown on every
#: side by this share of its height...
GAP_REACH = 0.25

#: ... and its area within this factor of the mean of theirs, either way.
GAP_AREA_RATIO = 2.0


def fuse_masks(
    learned: np.ndarray,
    subtracted: np.ndarray,
    config: SilhouetteConfig,
    plain_scene: np.ndarray | None = None,
) -> np.ndarray:
    """The learned masks with what the subtraction finds beside them (the module's
    description).

    Parameters
    ----------
    learned : (F, H, W) bool
        The learned front end's masks.
    subtracted : (F, H, W) bool
        The subtraction's masks of the same frames, same size.
    config : SilhouetteConfig
        Its ``min_person_frac`` and ``keep_piece_frac`` apply.
    plain_scene : (F, H, W) bool, optional
        Where the frames show the empty scene as it is
        (:class:`~eigmotion.segmentation.subtraction.Subtraction`); with it, the pieces
        of the learned masks that are the scene are taken out first
        (:func:`without_scene`).

    Returns
    -------
    (F, H, W) bool
    """
    learned, subtracted = np.asarray(learned, bool), np.asarray(subtracted, bool)
    if learned.shape != subtracted.shape or learned.ndim != 3:
        raise InvalidParameterError(
            f"masks to fuse must be two (F, H, W) stacks of one shape, got {learned.shape} "
            f"and {subtracted.shape}"
        )
    if plain_scene is not None:
        learned = without_scene(learned, subtracted, plain_scene)
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * NEAR_PX + 1, 2 * NEAR_PX + 1))
    areas = learned.sum(axis=(1, 2))
    typical = float(np.median(areas[areas > 0])) if areas.any() else 0.0
    fused = np.zeros_like(learned)
    for i, (mine, theirs) in enumerate(zip(learned, subtracted, strict=True)):
        if not mine.any():
            continue
        near = cv2.dilate(mine.view(np.uint8), kernel).view(bool)
        lost = areas[i] < LOST_SHARE * typical
        # where the two agree, a limb needs LIMB_SHARE of the area beyond the two pixels
        agreeing = (
            np.count_nonzero(mine & theirs) >= AGREEING_SHARE * areas[i]
            and np.count_nonzero(theirs & ~near) >= LIMB_SHARE * areas[i]
        )
        if lost or agreeing:  # pieces of the subtraction touching it, whole (agreeing: limbs)
            n, labels = cv2.connectedComponents(theirs.view(np.uint8), connectivity=8)
            touching = np.zeros(n, bool)
            touching[labels[near & theirs]] = True
            touching[0] = False  # the background
            whole = touching[labels]
            near = whole if lost else near | _limbs(whole & ~near, areas[i])
        fused[i] = person_in_frame(mine | (theirs & near), config)[0]
    _fill_lost_frames(fused, learned, subtracted, config)
    return fused


def _fill_lost_frames(
    fused: np.ndarray, learned: np.ndarray, subtracted: np.ndarray, config: SilhouetteConfig
) -> None:
    """Fill, in place, the frames of ``fused`` (F, H, W) bool where ``learned`` found no
    one with the person of ``subtracted`` where the person stands on both sides (the
    module's description: :data:`GAP_FRAMES`, :data:`GAP_REACH`, :data:`GAP_AREA_RATIO`)."""
    held = np.flatnonzero(fused.any(axis=(1, 2)))
    for before, after in zip(held[:-1], held[1:], strict=True):
        if after - before < 2 or after - before > GAP_FRAMES:
            continue
        rows = np.flatnonzero(fused[before].any(axis=1) | fused[after].any(axis=1))
        cols = np.flatnonzero(fused[before].any(axis=0) | fused[after].any(axis=0))
        reach = int(np.ceil(GAP_REACH * (rows[-1] - rows[0] + 1)))
        box = np.zeros(fused.shape[1:], bool)
        box[max(rows[0] - reach, 0) : rows[-1] + reach + 1,
            max(cols[0] - reach, 0) : cols[-1] + reach + 1] = True  # fmt: skip
        typical = (np.count_nonzero(fused[before]) + np.count_nonzero(fused[after])) / 2.0
        for i in range(before + 1, after):
            if learned[i].any():
                continue  # the networks saw someone there and the fusion kept no one
            person = person_in_frame(subtracted[i], config)[0]
            area = np.count_nonzero(person)
            inside = area > 0 and not np.any(person & ~box)
            if inside and typical / GAP_AREA_RATIO <= area <= typical * GAP_AREA_RATIO:
                fused[i] = person


def _limbs(beyond: np.ndarray, area: int) -> np.ndarray:
    """The pieces of ``beyond`` (H, W) bool that are limbs: at least :data:`LIMB_SHARE` of
    ``area`` pixels, and thick enough to outlast an opening by :data:`LIMB_MIN_WIDTH_PX`."""
    pieces = beyond.view(np.uint8)
    n, parts, stats, _ = cv2.connectedComponentsWithStats(pieces, connectivity=8)
    square = np.ones((LIMB_MIN_WIDTH_PX, LIMB_MIN_WIDTH_PX), np.uint8)
    core = cv2.morphologyEx(pieces, cv2.MORPH_OPEN, square).view(bool)
    keep = np.zeros(n, bool)
    keep[np.unique(parts[core])] = True
    keep &= stats[:, cv2.CC_STAT_AREA] >= LIMB_SHARE * area
    keep[0] = False  # the background
    return keep[parts]


def without_scene(
    learned: np.ndarray, subtracted: np.ndarray, plain_scene: np.ndarray
) -> np.ndarray:
    """``learned`` (F, H, W) bool less the pieces that show the empty scene, in frames
    where ``subtracted`` (F, H, W) bool covers at least :data:`SCENE_FOUND_SHARE` of it:
    farther than :data:`SCENE_NEAR_PX` from ``subtracted``, on ``plain_scene`` (F, H, W)
    bool, solid (they outlast an opening by a 3 × 3 square) and at least
    :data:`SCENE_PIECE_SHARE` of the frame's learned area."""
    plain_scene = np.asarray(plain_scene, bool)
    if plain_scene.shape != learned.shape:
        raise InvalidParameterError(
            f"plain_scene must have the masks' shape {learned.shape}, got {plain_scene.shape}"
        )
    out = learned.copy()
    for mine, theirs, plain, kept in zip(learned, subtracted, plain_scene, out, strict=True):
        area = np.count_nonzero(mine)
        if area and np.count_nonzero(mine & theirs) >= SCENE_FOUND_SHARE * area:
            kept &= ~_scene_pieces(mine, theirs, plain)
    return out


def without_seen_scene(
    learned: np.ndarray,
    frames: np.ndarray,
    config: SilhouetteConfig,
    shot_starts: np.ndarray | None = None,
) -> np.ndarray:
    """``learned`` (F, H, W) bool less the pieces that show the scene, for a clip
    without an image of the empty scene: the scene is the one the clip itself shows
    where the learned masks leave it (:func:`~eigmotion.segmentation.background.
    seen_scene`), and only pixels it shows often enough (``seen``) can be taken out.

    In a frame, the pieces of the learned mask farther than :data:`SCENE_NEAR_PX` from
    what subtracting that scene finds, on seen pixels whose colour difference to it is
    under the clip's low threshold, solid and of at least :data:`SCENE_PIECE_SHARE` of
    the learned area, are taken out (as :func:`without_scene` does with the image).
    Where the person never leaves a pixel nothing is known of the scene there, so a
    person standing still keeps every pixel; that is the guard here, in place of
    :data:`SCENE_FOUND_SHARE`.

    Each shot is taken on its own, its scene from its own frames; a shot whose frames
    differ from the scene they show over most of the picture (the camera moves: the
    subtraction's :class:`~eigmotion.errors.SceneMismatchError`) keeps its masks.

    Parameters
    ----------
    learned : (F, H, W) bool
        The learned front end's masks.
    frames : (F, H, W, 3) uint8
        The same frames, RGB, at the masks' size.
    config : SilhouetteConfig
        As for the subtraction without an image (its ``upper_body_frac`` unused).
    shot_starts : (S,) int, optional
        The first frame of each shot (:func:`~eigmotion.segmentation.shots.
        shot_starts`), 0 first; default the clip is one shot.

    Returns
    -------
    (F, H, W) bool
    """
    learned = np.asarray(learned, bool)
    out = learned.copy()
    for first, stop in shot_spans(shot_starts, len(learned)):
        try:
            out[first:stop] = _without_scene_of_shot(
                learned[first:stop], frames[first:stop], config
            )
        except SceneMismatchError:
            pass  # no steady scene to take out: the learned masks stand
    return out


def _without_scene_of_shot(
    learned: np.ndarray, frames: np.ndarray, config: SilhouetteConfig
) -> np.ndarray:
    """:func:`without_seen_scene` of one shot."""
    scene = seen_scene(frames, learned, config)

    def may_lose_pieces(plain: np.ndarray) -> np.ndarray:
        # A piece taken out lies in ``mine & plain & seen``: a frame where that holds no
        # piece large enough loses none, whatever the subtraction finds (taking its
        # surroundings away leaves only smaller pieces), and needs no masks of its own.
        return np.array([
            _scene_pieces(mine, None, shown & scene.seen).any()
            for mine, shown in zip(learned, plain, strict=True)
        ], bool)  # fmt: skip

    # against an estimated scene the shadow test stands everywhere (extract_silhouettes)
    subtracted = subtract_scene(
        frame_chunks(frames), scene.image, replace(config, upper_body_frac=0.0),
        frames_wanted=may_lose_pieces,
    )  # fmt: skip
    out = learned.copy()
    for i in np.flatnonzero(subtracted.wanted):
        plain = subtracted.plain_scene[i] & scene.seen
        out[i] &= ~_scene_pieces(learned[i], subtracted.masks[i], plain)
    return out


def _scene_pieces(mine: np.ndarray, theirs: np.ndarray | None, plain: np.ndarray) -> np.ndarray:
    """(H, W) bool: the pieces of the learned mask ``mine`` farther than
    :data:`SCENE_NEAR_PX` from the subtraction's ``theirs`` (None: it found nothing), on
    ``plain`` scene, that
    outlast an opening by a 3 × 3 square and cover at least :data:`SCENE_PIECE_SHARE`
    of ``mine`` (all False where ``mine`` is).

    Worked out inside ``mine``'s box grown by what the dilation and the opening reach,
    the same to the pixel as over the whole frame: outside the box nothing is kept.
    """
    out = np.zeros(mine.shape, bool)
    x, y, w, h = cv2.boundingRect(mine.view(np.uint8))
    if not w:
        return out
    reach = SCENE_NEAR_PX + 1
    box = np.s_[max(0, y - reach) : y + h + reach, max(0, x - reach) : x + w + reach]
    mine, plain = mine[box], plain[box]
    scene = mine & plain
    if theirs is not None:
        scene &= ~cv2.dilate(theirs[box].view(np.uint8), _SCENE_NEAR).view(bool)
    scene = scene.view(np.uint8)
    scene = cv2.morphologyEx(scene, cv2.MORPH_OPEN, _SOLID)
    _, pieces, stats, _ = cv2.connectedComponentsWithStats(scene, connectivity=8)
    big = stats[:, cv2.CC_STAT_AREA] >= SCENE_PIECE_SHARE * np.count_nonzero(mine)
    big[0] = False  # not the scene's pieces: the rest
    out[box] = big[pieces]
    return out
