"""Geometry checks shared by the avatar and proxy-body tests."""

from __future__ import annotations

import numpy as np


def winding_numbers(points: np.ndarray, vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(P,) generalised winding number of each point w.r.t. a triangle mesh (1 inside)."""
    tri = np.asarray(vertices, np.float64)[faces]
    out = []
    for p in np.asarray(points, np.float64).reshape(-1, 3):
        a, b, c = np.moveaxis(tri - p, 1, 0)
        la, lb, lc = (np.linalg.norm(x, axis=1) for x in (a, b, c))
        det = np.einsum("ij,ij->i", a, np.cross(b, c))
        den = (
            la * lb * lc
            + np.einsum("ij,ij->i", a, b) * lc
            + np.einsum("ij,ij->i", a, c) * lb
            + np.einsum("ij,ij->i", b, c) * la
        )
        out.append(np.arctan2(det, den).sum() / (2 * np.pi))
    return np.array(out)
