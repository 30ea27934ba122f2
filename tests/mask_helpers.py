"""Silhouettes as a learned segmenter gives them, shared by the motion-image and
database tests."""

from __future__ import annotations

import cv2
import numpy as np


def edge_flicker(masks: np.ndarray, share: float, seed: int = 0) -> np.ndarray:
    """(F, H, W) bool: ``masks`` with, in every frame, ``share`` of the pixels on either
    side of the silhouette's edge (the 3×3 band around it) flipped at random — a still
    person's mask from a network that answers each frame's sensor noise a little
    differently."""
    rng = np.random.default_rng(seed)
    out = np.asarray(masks, bool).copy()
    kernel = np.ones((3, 3), np.uint8)
    for frame in out:
        person = frame.astype(np.uint8)
        band = cv2.dilate(person, kernel) != cv2.erode(person, kernel)
        frame[band & (rng.random(frame.shape) < share)] ^= True
    return out
