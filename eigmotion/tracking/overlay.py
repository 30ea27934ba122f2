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


#: Colour of the skeleton drawn by :func:`draw_skeleton`, RGB (cyan).
SKELETON_RGB = (0, 230, 255)


def draw_skeleton(
    image: np.ndarray,
    camera,
    joints_m: np.ndarray,
    parents: np.ndarray,
    color_rgb: tuple[int, int, int] = SKELETON_RGB,
) -> np.ndarray:
    """An image with a skeleton's bones drawn on it, as a camera sees them.

    Parameters
    ----------
    image : (H, W, 3) uint8
        RGB view.
    camera : Camera
        The view's camera.
    joints_m : (J, 3) float
        Joint positions, world metres (the keypoints stage's fitted posture).
    parents : (J,) int
        Each joint's parent, -1 for the root.

    Returns
    -------
    (H, W, 3) uint8
        A copy of ``image`` with a line per bone in front of the camera.
    """
    out = np.ascontiguousarray(image, dtype=np.uint8).copy()
    pixels, depth = camera.project(np.asarray(joints_m, dtype=np.float64))
    color = tuple(int(c) for c in color_rgb)
    for j, p in enumerate(parents):
        ends = pixels[[p, j]] if p >= 0 else None
        if ends is None or not (np.isfinite(ends).all() and (depth[[p, j]] > 0).all()):
            continue
        a, b = (tuple(int(round(v)) for v in end) for end in ends)
        cv2.line(out, a, b, color, 1, cv2.LINE_8)
    return out
