"""Drawing the estimated silhouette over an input view (the paper's figure 6)."""

from __future__ import annotations

import cv2
import numpy as np

from eigmotion.errors import InvalidParameterError

#: Outline colour, RGB (yellow: it stands out on skin, clothes and most scenes).
OUTLINE_RGB = (255, 235, 0)


def draw_outline(
    image: np.ndarray,
    silhouette: np.ndarray,
    color_rgb: tuple[int, int, int] = OUTLINE_RGB,
    thickness_px: int = 1,
) -> np.ndarray:
    """An image with a silhouette's outline drawn on it.

    Parameters
    ----------
    image : (H, W, 3) uint8
        RGB view.
    silhouette : (H, W) bool
        The estimated posture's silhouette in that view.
    color_rgb : (int, int, int)
    thickness_px : int

    Returns
    -------
    (H, W, 3) uint8
        A copy of ``image`` with the outline.
    """
    image = np.asarray(image)
    silhouette = np.asarray(silhouette)
    if image.ndim != 3 or image.shape[2] != 3 or silhouette.shape != image.shape[:2]:
        raise InvalidParameterError(
            f"image {image.shape} must be (H, W, 3) and silhouette {silhouette.shape} (H, W)"
        )
    out = np.ascontiguousarray(image, dtype=np.uint8).copy()
    contours, _ = cv2.findContours(
        silhouette.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE
    )
    cv2.drawContours(out, contours, -1, tuple(int(c) for c in color_rgb), int(thickness_px))
    return out
