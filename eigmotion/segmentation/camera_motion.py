"""How the camera moved: a phone that pans to follow a person, or zooms.

The floor cues of a query (:mod:`eigmotion.retrieval.motion_cues`) read the person's
travel from where the figure stands in the frame and how tall it is, which holds for a
camera that stands still.  A camera that pans moves the whole picture; one that zooms
scales it.  Both show in the scene around the person, so per frame the scene's motion
is measured and the figure's place can be given in the first frame's pixels:

1. each grey frame levelled: its scene's mean and spread brought to the same values
   (:data:`LEVEL_STD`), so that a flicker of the light, which changes every pixel, is
   not read as motion along the scene's shading;
2. corners of the scene (:func:`cv2.goodFeaturesToTrack`, at most :data:`MAX_CORNERS`)
   away from the person (the mask grown by :data:`PERSON_MARGIN_PX`) in an anchor
   frame: the shot's first, or, once too few of its corners are followed, the frame
   before;
3. followed from the anchor into each frame by pyramidal Lucas–Kanade optical flow
   (:func:`cv2.calcOpticalFlowPyrLK`, starting where the frame before's motion puts
   them) and back again: a corner that does not return within :data:`RETURN_PX`, or
   that lands on the person, is dropped;
4. the similarity (turn, scale, shift) that carries them back to the anchor, by RANSAC
   (:func:`cv2.estimateAffinePartial2D`, :data:`RANSAC_PX`): the person's shadow, other
   people and the frames' noise are outliers to the scene's one motion.  With fewer
   than :data:`MIN_INLIERS` corners agreeing, or under :data:`MIN_INLIER_SHARE` of
   them, or spread over less than :data:`MIN_SPREAD` of the frame's width or height,
   the frame's motion is not measured and it is taken as not moved since the frame
   before;
5. composed with the anchor's own motion to the first frame of the shot
   (:mod:`~eigmotion.segmentation.shots`).

A pan turns the camera about its centre, which moves the picture by a homography that a
similarity approximates well for the few degrees a clip pans between frames; a zoom is
a scale.  A camera that moves through the room (walking beside the person) also shows
parallax, which no single motion of the picture holds: the similarity then fits the
floor and walls near the person as well as it can.

A camera that never moved the picture by :data:`STILL_PX` or more (at the frames' size)
counts as still: :func:`camera_motion` returns None and the cues read the frames as
they are.  Most cameras stand still, so before following every frame it compares
every :data:`CHECK_EVERY`-th frame of each shot (and its last) with the shot's first,
steps 2–4 with the anchor the first frame: where each of them is measured and none
has moved the picture by :data:`STILL_PX`, the camera counts as still and nothing more
is measured (a fifth of the optical flow's time).
"""

from __future__ import annotations

import cv2
import numpy as np

from eigmotion.errors import InvalidParameterError
from eigmotion.segmentation.evidence import check_frames
from eigmotion.segmentation.shots import shot_spans

#: Most scene corners followed from one frame to the next.
MAX_CORNERS = 100

#: The optical flow's window (pixels) and pyramid levels above the frame.
FLOW_WINDOW = (15, 15)
FLOW_LEVELS = 3

#: Corners are taken this far from the person's mask at least, pixels.
PERSON_MARGIN_PX = 4

#: A corner carried back within this many pixels of where it was agrees with the motion.
RANSAC_PX = 1.0

#: Fewest corners that must agree for a frame's motion to be measured ...
MIN_INLIERS = 12

#: ... and the least share of the corners followed that must.
MIN_INLIER_SHARE = 0.5

#: The grey frames' standard deviation over the scene, levels, before they are compared.
LEVEL_STD = 40.0

#: A corner followed into a frame and back must return within this many pixels.
RETURN_PX = 0.5

#: The corners that agree must spread over at least this share of the frame's width
#: and of its height: a few corners close together hold a turn or a scale poorly.
MIN_SPREAD = 0.4

#: A camera whose picture never moved this far (a corner of the frame, pixels at the
#: frames' size) from where the first frame of its shot had it stands still.
STILL_PX = 2.0

#: The quick look for a still camera compares every this many frames of a shot (and
#: its last) with its first.
CHECK_EVERY = 5


def camera_motion(
    frames: np.ndarray, masks: np.ndarray, shot_starts: np.ndarray | None = None
) -> np.ndarray | None:
    """Per frame, the similarity that carries its pixels to the first frame of its shot.

    Parameters
    ----------
    frames : (F, H, W, 3) uint8
        RGB frames, in order.
    masks : (F, H, W) bool
        The person in each frame (left out of the scene's motion).
    shot_starts : (S,) int, optional
        The first frame of each shot (:func:`~eigmotion.segmentation.shots.shot_starts`);
        default one shot.

    Returns
    -------
    (F, 2, 3) float64 or None
        ``[x', y'] = M[:, :2] @ [x, y] + M[:, 2]`` takes a pixel of frame ``i`` (x right,
        y down, continuous pixel coordinates) to the first frame of its shot; the
        identity for that first frame.  None where the camera stands still
        (:data:`STILL_PX`).
    """
    frames = check_frames(frames)
    masks = np.asarray(masks, bool)
    if masks.shape != frames.shape[:3]:
        raise InvalidParameterError(
            f"masks must have the frames' shape {frames.shape[:3]}, got {masks.shape}"
        )
    n, h, w = masks.shape
    grey = [
        _levelled(cv2.cvtColor(f, cv2.COLOR_RGB2GRAY), m)
        for f, m in zip(frames, masks, strict=True)
    ]
    scenes = [_scene(m) for m in masks]  # where corners may be taken and land
    corners = _frame_corners(h, w)
    if _still_at_checks(grey, scenes, shot_starts, corners):
        return None
    motion = np.tile(np.eye(2, 3), (n, 1, 1))
    for first, stop in shot_spans(shot_starts, n):
        anchor = first  # the frame the corners are taken from
        points = _corners(grey[anchor], scenes[anchor])
        for i in range(first + 1, stop):
            step = _to_anchor(grey, scenes, i, anchor, points, motion)
            if step is None and anchor != i - 1:  # its corners lost: anchored to the frame before
                anchor = i - 1
                points = _corners(grey[anchor], scenes[anchor])
                step = _to_anchor(grey, scenes, i, anchor, points, motion)
            # not measured: taken as not moved since the frame before
            motion[i] = motion[i - 1] if step is None else _then(motion[anchor], step)
    moved = np.einsum("fij,cj->fci", motion, corners) - corners[None, :, :2]
    if np.abs(moved).max() < STILL_PX:
        return None
    return motion


def _still_at_checks(
    grey: list[np.ndarray],
    scenes: list[np.ndarray],
    shot_starts: np.ndarray | None,
    corners: np.ndarray,
) -> bool:
    """Whether every :data:`CHECK_EVERY`-th frame of each shot, and its last, is
    measured against the shot's first frame (:func:`_to_anchor`, no frame between) and
    none has moved the frame's ``corners`` (4, 3) (:func:`_frame_corners`) by
    :data:`STILL_PX`; False as soon as one is not measured or has moved."""
    unmoved = np.tile(np.eye(2, 3), (len(grey), 1, 1))  # the search starts where it was
    for first, stop in shot_spans(shot_starts, len(grey)):
        points = _corners(grey[first], scenes[first])
        checks = set(range(first + CHECK_EVERY, stop, CHECK_EVERY)) | {stop - 1}
        for i in sorted(checks - {first}):
            step = _to_anchor(grey, scenes, i, first, points, unmoved)
            if step is None or np.abs(corners @ step.T - corners[:, :2]).max() >= STILL_PX:
                return False
    return True


def _levelled(grey: np.ndarray, person: np.ndarray) -> np.ndarray:
    """(H, W) uint8: a grey frame with its scene's mean brought to 128 and its standard
    deviation to :data:`LEVEL_STD` (the person, ``person`` (H, W) bool, left out of
    both): a flicker of the light changes every pixel, which the optical flow would
    read as motion along the scene's shading."""
    scene = grey[~person] if (~person).any() else grey.ravel()
    mean, std = float(scene.mean()), max(float(scene.std()), 1.0)
    out = (grey.astype(np.float32) - mean) * (LEVEL_STD / std) + 128.0
    return np.clip(np.rint(out), 0, 255).astype(np.uint8)


def _corners(grey: np.ndarray, scene: np.ndarray) -> np.ndarray | None:
    """(K, 1, 2) float32 corners of a grey frame where ``scene`` (:func:`_scene`) is
    not 0; None where fewer than :data:`MIN_INLIERS`."""
    found = cv2.goodFeaturesToTrack(
        grey, MAX_CORNERS, qualityLevel=0.01, minDistance=5, mask=scene, blockSize=5
    )
    return None if found is None or len(found) < MIN_INLIERS else found


def _scene(person: np.ndarray) -> np.ndarray:
    """(H, W) uint8: 255 farther than :data:`PERSON_MARGIN_PX` from the person, else 0."""
    grown = cv2.dilate(person.view(np.uint8), _GROW)
    return np.where(grown > 0, 0, 255).astype(np.uint8)


_GROW = cv2.getStructuringElement(
    cv2.MORPH_ELLIPSE, (2 * PERSON_MARGIN_PX + 1, 2 * PERSON_MARGIN_PX + 1)
)


def _to_anchor(
    grey: list[np.ndarray],
    scenes: list[np.ndarray],
    i: int,
    anchor: int,
    points: np.ndarray | None,
    motion: np.ndarray,
) -> np.ndarray | None:
    """(2, 3): the similarity taking frame ``i``'s pixels to frame ``anchor``'s, measured
    on the anchor's corners ``points`` followed into frame ``i`` (grey frames ``grey``,
    each frame's scene ``scenes``: :func:`_scene`); the search starts where the frame
    before's motion (``motion`` (F, 2, 3), filled up to ``i - 1``) puts them.  None
    where fewer than :data:`MIN_INLIERS` corners agree."""
    if points is None:
        return None
    # where the frame before saw the anchor's corners: its motion undone
    before_to_anchor = _then(cv2.invertAffineTransform(motion[anchor]), motion[i - 1])
    guess = cv2.transform(points, cv2.invertAffineTransform(before_to_anchor))
    followed, status, _ = cv2.calcOpticalFlowPyrLK(
        grey[anchor], grey[i], points, guess.astype(np.float32), winSize=FLOW_WINDOW,
        maxLevel=FLOW_LEVELS, flags=cv2.OPTFLOW_USE_INITIAL_FLOW,
    )  # fmt: skip
    back, returned, _ = cv2.calcOpticalFlowPyrLK(
        grey[i], grey[anchor], followed, points.copy(), winSize=FLOW_WINDOW, maxLevel=FLOW_LEVELS,
        flags=cv2.OPTFLOW_USE_INITIAL_FLOW,
    )  # fmt: skip
    # followed there and back to where it started: a corner the flow could hold
    kept = (status.ravel() == 1) & (returned.ravel() == 1)
    kept &= np.linalg.norm((back - points)[:, 0], axis=1) < RETURN_PX
    h, w = scenes[i].shape
    at = np.clip(np.floor(followed[:, 0]).astype(int), 0, [w - 1, h - 1])
    kept &= scenes[i][at[:, 1], at[:, 0]] > 0  # not on the person there
    if kept.sum() < MIN_INLIERS:
        return None
    step, inliers = cv2.estimateAffinePartial2D(
        followed[kept], points[kept], method=cv2.RANSAC, ransacReprojThreshold=RANSAC_PX
    )
    if step is None or inliers is None:
        return None
    agree = int(inliers.sum())
    if agree < max(MIN_INLIERS, MIN_INLIER_SHARE * int(kept.sum())):
        return None
    spread = np.ptp(points[kept][inliers.ravel() == 1, 0], axis=0)  # (x, y) pixels
    if (spread < MIN_SPREAD * np.array([w, h])).any():
        return None
    return step


def _frame_corners(h: int, w: int) -> np.ndarray:
    """(4, 3): the corners of an (H, W) frame, homogeneous, continuous pixel coordinates."""
    return np.array([[0.0, 0.0, 1.0], [w, 0.0, 1.0], [0.0, h, 1.0], [w, h, 1.0]])


def _then(outer: np.ndarray, inner: np.ndarray) -> np.ndarray:
    """(2, 3): the similarity ``inner`` (2, 3), then ``outer`` (2, 3)."""
    last_row = np.array([[0.0, 0.0, 1.0]])
    return (np.vstack([outer, last_row]) @ np.vstack([inner, last_row]))[:2]


#: Most a stabilised canvas grows beyond the frame on each side, in frame widths and
#: heights: a camera that swept further leaves the person's far frames cut at the edge.
MAX_CANVAS_GROWTH = 1.0


def stabilised(masks: np.ndarray, camera: np.ndarray) -> np.ndarray:
    """The silhouettes as a still camera at the first frame's place would see them.

    Each mask is carried by its similarity (bilinear, so a shift of part of a pixel
    moves the edge by part of a pixel) onto a canvas that holds every frame's picture,
    grown by at most :data:`MAX_CANVAS_GROWTH` of the frame on each side.

    Parameters
    ----------
    masks : (F, H, W) bool
    camera : (F, 2, 3) float
        Per frame, the similarity taking its pixels to the first frame's
        (:func:`camera_motion`).

    Returns
    -------
    (F, H', W') uint8
        Silhouettes in [0, 255] (255: the person), H' >= H and W' >= W.
    """
    masks = np.asarray(masks, bool)
    camera = np.asarray(camera, np.float64)
    n, h, w = masks.shape
    corners = _frame_corners(h, w)
    placed = np.einsum("fij,cj->fci", camera, corners).reshape(-1, 2)
    low = np.maximum(np.floor(placed.min(axis=0)), [-MAX_CANVAS_GROWTH * w, -MAX_CANVAS_GROWTH * h])
    high = np.minimum(
        np.ceil(placed.max(axis=0)), [(1 + MAX_CANVAS_GROWTH) * w, (1 + MAX_CANVAS_GROWTH) * h]
    )
    low, high = np.minimum(low, 0.0), np.maximum(high, [w, h])
    size = (int(high[0] - low[0]), int(high[1] - low[1]))
    out = np.empty((n, size[1], size[0]), np.uint8)
    for mask, motion, canvas in zip(masks, camera, out, strict=True):
        shifted = motion.copy()
        shifted[:, 2] -= low
        cv2.warpAffine(
            mask.view(np.uint8) * np.uint8(255), shifted, size, dst=canvas,
            flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0,
        )  # fmt: skip
    return out
