"""Labels ranked from per-motion distances: the nearest motions' labels, in order."""

from __future__ import annotations

import numpy as np


def per_motion_min(distances: np.ndarray, motion_of: np.ndarray, n_motions: int) -> np.ndarray:
    """(n_motions,) float64: each motion's smallest distance (inf for motions absent)."""
    out = np.full(n_motions, np.inf)
    np.minimum.at(out, motion_of, distances)
    return out


def ranked_labels_of(distances: np.ndarray, labels: np.ndarray, n: int = 3) -> list[str]:
    """The first ``n`` distinct labels of the motions, nearest first."""
    out: list[str] = []
    for i in np.argsort(distances, kind="stable"):
        if not np.isfinite(distances[i]):
            break
        if labels[i] not in out:
            out.append(str(labels[i]))
        if len(out) == n:
            break
    return out
