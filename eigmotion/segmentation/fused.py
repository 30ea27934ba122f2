"""Learned masks and the classical subtraction together, for clips with an image of the
empty scene.

The learned front end (:mod:`eigmotion.segmentation.learned`) finds the whole body but
rounds off thin limbs; subtracting the image of the empty scene finds what differs
from it, limbs included, but also shadows and, where the person's colours match the
scene, loses pieces of the body.  Fused, the learned mask is the person and what the
subtraction finds within :data:`NEAR_PX` pixels (working size) of it is added:

    person = learned | (subtracted & grown(learned, NEAR_PX))

then the largest blob and the big pieces beside it, as everywhere
(:func:`~eigmotion.segmentation.learned.person_in_frame`).  In a frame where the
learned mask is much smaller than usual in the clip (under :data:`LOST_SHARE` of its
median area: the network lost part of a person dressed like the scene), every piece
the subtraction finds that touches it is added whole instead.  A frame where the learned
front end finds no one stays empty (the subtraction alone there is the shadow or the
scene that moved).  ``docs/segmentation.md`` compares this with the other ways of
combining them, measured on the development set.
"""

from __future__ import annotations

import cv2
import numpy as np

from eigmotion.errors import InvalidParameterError
from eigmotion.segmentation.config import SilhouetteConfig
from eigmotion.segmentation.learned import person_in_frame

#: What the subtraction finds is kept within this many pixels (working size) of the
#: learned mask.
NEAR_PX = 2

#: In a frame where the learned mask covers less than this share of the clip's median
#: learned area, the network has lost part of the person (colours like the scene's):
#: every piece of the subtraction that touches the learned mask is kept whole.
LOST_SHARE = 0.7


def fuse_masks(learned: np.ndarray, subtracted: np.ndarray, config: SilhouetteConfig) -> np.ndarray:
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
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * NEAR_PX + 1, 2 * NEAR_PX + 1))
    areas = learned.sum(axis=(1, 2))
    typical = float(np.median(areas[areas > 0])) if areas.any() else 0.0
    fused = np.zeros_like(learned)
    for i, (mine, theirs) in enumerate(zip(learned, subtracted, strict=True)):
        if not mine.any():
            continue
        near = cv2.dilate(mine.view(np.uint8), kernel).view(bool)
        if areas[i] < LOST_SHARE * typical:  # whole pieces of the subtraction touching it
            _, labels = cv2.connectedComponents(theirs.view(np.uint8), connectivity=8)
            touching = np.unique(labels[near & theirs])
            near = np.isin(labels, touching[touching > 0])
        fused[i] = person_in_frame(mine | (theirs & near), config)[0]
    return fused
