"""People whose legs the silhouettes leave out: below the frame, or lost in some frames.

Real footage often frames a person from the head down to the knees or the shins: the
camera is close, or tilted up.  The silhouette then ends at the frame's bottom edge,
and everything that measures the body from its silhouette is wrong: the motion image's
person frame (:class:`~eigmotion.retrieval.motion_image.ClipMotionImages`) scales the
clip by the silhouette's height and centres each frame on its mass, so a person waving
with the legs cut off at the thighs is enlarged and moved up into the shape of a
crouch, and is answered *sit_down*.

The pose landmark network (:mod:`eigmotion.segmentation.learned`'s second look) places
its 33 landmarks even where the body is out of view, and says how likely each one is
in view (its *presence*).  Where the silhouette touches the bottom edge in most frames
and the ankles are out of view (median presence under :data:`ANKLE_PRESENCE`), the
feet lie where the network puts them, but no further below the knees than the body's
proportions allow (:data:`SHANK_PER_THIGH`): :func:`hidden_rows_below` is how many
rows of body the frame leaves out, and the motion image continues the silhouette down
by as many rows (the legs go on straight down, as the bottom row shows them).  Without the
pose network's landmarks (no LiteRT, the selfie network's second look, the classical
front end) nothing is estimated and nothing changes.

Legs can also be lost inside the picture: light trousers against a light wall, cut out
in some frames and not in others.  :func:`restored_legs` gives such frames the legs of
the nearest frame whose hips, knees and ankles stand where theirs do.

Measured on the development set's real clips (64 × 64, people cut off at the shins or
the knees in half of them; ``docs/accuracy.md``, ``docs/segmentation.md``).
"""

from __future__ import annotations

import numpy as np

#: MediaPipe's pose landmark indices: the ankles, and every landmark of the feet
#: (ankles, heels, toes), the lowest of which is where the body ends.
ANKLES = (27, 28)
FEET = (27, 28, 29, 30, 31, 32)

#: A silhouette with at least this many pixels on the bottom row touches the edge.
EDGE_PX = 2

#: The body is cut by the bottom edge when at least this share of the frames with a
#: person touch it ...
CUT_SHARE = 0.5

#: ... and the ankles' median presence (the network's probability that they are in
#: view) over those frames is below this.  On the development set's real clips the
#: people whose feet are in view (at the very edge) score 0.7-0.95, those cut off at
#: the shins or knees 0.07-0.45.
ANKLE_PRESENCE = 0.5

#: The hips, knees and ankles: where the legs stand.
LEGS = (23, 24, 25, 26, 27, 28)
HIPS = (23, 24)
KNEES = (25, 26)

#: The lowest landmark of the feet lies at most this many thigh lengths (hips to
#: knees, as the picture shows them) below the knees.  Knee to sole is 1.16 thigh
#: lengths in the standard segment proportions (knee height 0.285, hip height 0.530 of
#: the stature: Drillis and Contini); the margin allows for a thigh seen shortened.  The
#: network guesses feet out of the picture, and on real people cut off at the shins in
#: 64-row frames it put them 1.7-2.3 thigh lengths below the knees: 8-11 rows too low.
SHANK_PER_THIGH = 1.35

#: At most this share of the frame's height is added below it: a wild landmark (a
#: person lying down, a network's guess from a head and shoulders) adds no more.
MAX_HIDDEN_SHARE = 1.0


def _checked(masks, landmarks) -> tuple[np.ndarray, np.ndarray]:
    """``masks`` as (F, H, W) bool and ``landmarks`` as (F, 33, 4) float64, or a
    ValueError naming both shapes."""
    masks = np.asarray(masks, dtype=bool)
    landmarks = np.asarray(landmarks, dtype=np.float64)
    if masks.ndim != 3 or landmarks.shape != (len(masks), 33, 4):
        raise ValueError(
            f"masks (F, H, W) and landmarks (F, 33, 4) expected, got {masks.shape} and "
            f"{landmarks.shape}"
        )
    return masks, landmarks


def hidden_rows_below(masks: np.ndarray, landmarks: np.ndarray, landmark_scale: float) -> int:
    """Rows of the person's body below the frame's bottom edge, at the masks' scale.

    Parameters
    ----------
    masks : (F, H, W) bool
        The person's silhouette per frame.
    landmarks : (F, 33, 4) float
        The pose network's landmarks per frame (x, y in pixels of the frames the
        network saw, visibility, presence), NaN where it did not look or saw no one
        (:func:`~eigmotion.segmentation.learned.learned_masks_and_landmarks`).
    landmark_scale : float
        Mask pixels per landmark pixel (the masks' height over the frames').

    Returns
    -------
    int
        0 when the body is not cut by the bottom edge, or the landmarks cannot tell;
        else the median, over the frames that touch the edge, of how far below it the
        lowest landmark of the feet lies, in mask rows, each frame's taken no lower
        than :data:`SHANK_PER_THIGH` thigh lengths below its knees where its knees lie
        below its hips (at most :data:`MAX_HIDDEN_SHARE` × H).
    """
    masks, landmarks = _checked(masks, landmarks)
    height = masks.shape[1]
    occupied = masks.any(axis=(1, 2))
    touching = masks[:, -1, :].sum(axis=1) >= EDGE_PX
    if not occupied.any() or touching.sum() < CUT_SHARE * occupied.sum():
        return 0
    seen = touching & np.isfinite(landmarks[:, ANKLES, 3]).all(axis=1)
    if not seen.any():
        return 0
    if float(np.median(landmarks[seen][:, ANKLES, 3])) >= ANKLE_PRESENCE:
        return 0
    rows = landmarks[seen][:, :, 1] * landmark_scale
    knees = rows[:, KNEES].mean(axis=1)
    thighs = knees - rows[:, HIPS].mean(axis=1)
    reach = np.where(thighs > 0, knees + SHANK_PER_THIGH * thighs, np.inf)
    feet_rows = np.minimum(rows[:, FEET].max(axis=1), reach)
    below = float(np.median(feet_rows)) - height
    return int(np.clip(np.ceil(below), 0, MAX_HIDDEN_SHARE * height))


def continued_below(masks: np.ndarray, rows: int) -> np.ndarray:
    """The silhouettes continued below the frame by ``rows`` copies of their bottom row.

    Parameters
    ----------
    masks : (F, H, W)
        Silhouettes (any dtype).
    rows : int
        Rows to add, >= 0.

    Returns
    -------
    (F, H + rows, W), the dtype of ``masks``
        ``masks`` itself when ``rows`` is 0.
    """
    if rows <= 0:
        return masks
    return np.concatenate([masks, np.repeat(masks[:, -1:, :], rows, axis=1)], axis=1)


#: A frame has lost its legs when its silhouette ends above the lowest landmark of the
#: feet (or the frame's bottom edge, if higher) by more than this share of the length
#: from the hips down to there ...
LOST_LEG_SHARE = 0.25

#: ... and it takes them from the nearest frame in time that has not, whose hips, knees
#: and ankles lie within this share of that length of its own (the mean distance).
SAME_LEGS_SHARE = 0.2


def restored_legs(masks: np.ndarray, landmarks: np.ndarray, landmark_scale: float) -> np.ndarray:
    """The silhouettes with legs the segmentation lost taken from a frame where the
    legs stand the same.

    A network that cuts people out loses light trousers against a light wall in some
    frames and not in others: the silhouette then ends at the thighs, and the person
    seems to rise and fall.  The pose network's landmarks still place the hips, knees
    and ankles there; where the silhouette ends well above them
    (:data:`LOST_LEG_SHARE`), the silhouette below the hips is joined with that of the
    nearest frame whose legs are whole and stand where these do
    (:data:`SAME_LEGS_SHARE`).  A frame without such a frame stays as it is: legs that
    move (a jump, a kick) are not made up.

    Parameters
    ----------
    masks : (F, H, W) bool
        The person's silhouette per frame.
    landmarks : (F, 33, 4) float
        The pose network's landmarks per frame (as :func:`hidden_rows_below`).
    landmark_scale : float
        Mask pixels per landmark pixel.

    Returns
    -------
    (F, H, W) bool
        ``masks`` itself when no frame is restored, else a copy.
    """
    masks, landmarks = _checked(masks, landmarks)
    height = masks.shape[1]
    points = landmarks[:, :, :2] * landmark_scale
    feet = np.minimum(np.max(points[:, FEET, 1], axis=1), height)
    hips = np.mean(points[:, HIPS, 1], axis=1)
    length = feet - hips
    rows = masks.any(axis=2)
    bottom = np.where(rows.any(axis=1), height - np.argmax(rows[:, ::-1], axis=1), 0)
    known = np.isfinite(points[:, LEGS + FEET]).all(axis=(1, 2)) & rows.any(axis=1)
    known &= length > 0
    lost = known & (feet - bottom > LOST_LEG_SHARE * length)
    whole = np.flatnonzero(known & ~lost)
    if not lost.any() or not whole.size:
        return masks
    out = masks.copy()
    for i in np.flatnonzero(lost):
        apart = np.linalg.norm(points[whole][:, LEGS] - points[i, LEGS], axis=2).mean(axis=1)
        same = whole[apart <= SAME_LEGS_SHARE * length[i]]
        if same.size:
            donor = same[np.argmin(np.abs(same - i))]
            cut = int(np.clip(np.floor(hips[i]), 0, height))
            out[i, cut:] |= masks[donor, cut:]
    return out
