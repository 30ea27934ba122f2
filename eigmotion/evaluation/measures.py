"""Small measures the motion-image and video benchmarks report, and their baseline."""

from __future__ import annotations

import numpy as np

#: The patent's plain after-image: image frame, equal weights, no filter, 64×64, no
#: mean-silhouette term.  The baseline every configuration is compared with.
PLAIN_CONFIG = dict(
    frame="image", weighting="uniform", filter="none", size=64, silhouette_weight=0.0
)


def cosine_distance(a: np.ndarray, b: np.ndarray) -> float:
    """1 − cos of the angle between two vectors."""
    return float(1.0 - np.dot(a, b) / (np.linalg.norm(a) * np.linalg.norm(b)))


def iou(masks: np.ndarray, truth: np.ndarray) -> float:
    """Intersection over union per frame, averaged over the clip."""
    union = np.maximum((masks | truth).sum(axis=(1, 2)), 1)
    return float(((masks & truth).sum(axis=(1, 2)) / union).mean())


def ratio(ours: float, baseline: float) -> float:
    """``ours / baseline`` (nan when the baseline is 0)."""
    return float(ours) / float(baseline) if baseline else float("nan")
