"""Temporal decision over a whole clip: a Viterbi path through each frame's best
candidates instead of the greedy frame-by-frame choice.

Each estimate keeps the ``k`` best postures its search scored
(:attr:`~eigmotion.tracking.tracker.Estimate.alternatives`); the path maximises the sum
of their similarity scores minus a transition cost between consecutive postures,
``weight × d1(a, b) / scale_deg`` (:func:`~eigmotion.tracking.postures.d1_distance`,
degrees).  The greedy estimate is always one of a frame's candidates, so with weight 0
the path is the greedy one.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from eigmotion.errors import InvalidParameterError
from eigmotion.tracking.postures import d1_matrix


def viterbi_path(
    candidates: Sequence[np.ndarray],
    scores: Sequence[np.ndarray],
    vectors: np.ndarray,
    weight: float,
    scale_deg: float = 30.0,
) -> np.ndarray:
    """The best sequence of candidates, one per frame.

    Parameters
    ----------
    candidates : sequence of F (K_f,) int
        Dictionary entries considered at each frame (K_f >= 1).
    scores : sequence of F (K_f,) float
        Their similarity scores (higher is better).
    vectors : (N, D) float
        The dictionary's posture vectors, degrees (``PostureDictionary.vectors``).
    weight : float
        Score lost per ``scale_deg`` of d1 between consecutive postures (>= 0).
    scale_deg : float
        d1 that costs ``weight``, degrees.

    Returns
    -------
    (F,) int64
        Index into ``candidates[f]`` chosen at each frame.

    Raises
    ------
    InvalidParameterError
        Lengths that differ, a frame without candidates, a negative weight.
    """
    if len(candidates) != len(scores):
        raise InvalidParameterError("one score array per frame's candidates is needed")
    if not (np.isfinite(weight) and weight >= 0):
        raise InvalidParameterError(f"the transition weight must be >= 0, got {weight}")
    n = len(candidates)
    if n == 0:
        return np.zeros(0, dtype=np.int64)
    if any(len(c) == 0 or len(c) != len(s) for c, s in zip(candidates, scores, strict=True)):
        raise InvalidParameterError("every frame needs candidates, each with a score")
    total = np.asarray(scores[0], dtype=np.float64)
    back = []
    for f in range(1, n):
        cost = weight / scale_deg * d1_matrix(vectors[candidates[f - 1]], vectors[candidates[f]])
        through = total[:, None] - cost  # (K_prev, K_cur)
        best_prev = np.argmax(through, axis=0)
        back.append(best_prev)
        total = through[best_prev, np.arange(len(candidates[f]))] + np.asarray(
            scores[f], dtype=np.float64
        )
    path = np.empty(n, dtype=np.int64)
    path[-1] = int(np.argmax(total))
    for f in range(n - 1, 0, -1):
        path[f - 1] = back[f - 1][path[f]]
    return path


def along_best_path(estimates: Sequence, vectors: np.ndarray, weight: float) -> list:
    """The estimates of a clip with each replaced by its alternative on the Viterbi path.

    Parameters
    ----------
    estimates : sequence of Estimate
        :class:`~eigmotion.tracking.tracker.Estimate` per frame; those with no
        ``alternatives`` (the person not seen) keep their entry as their one candidate,
        and frames before the person was first seen (entry -1) are left out.
    vectors : (N, D) float
        The dictionary's posture vectors, degrees.
    weight : float
        Score lost per 30° of d1 between consecutive postures.

    Returns
    -------
    list of Estimate
    """
    keep = [i for i, e in enumerate(estimates) if e.entry >= 0]
    out = list(estimates)
    if not keep:
        return out
    options = []
    for i in keep:
        e = estimates[i]
        if len(e.alternatives):
            options.append((e.alternatives, e.alternative_scores, e.alternative_positions_m))
        else:
            options.append((np.array([e.entry]), np.zeros(1), e.position_m[None]))
    path = viterbi_path([o[0] for o in options], [o[1] for o in options], vectors, weight)
    for i, (entries, scores, positions), k in zip(keep, options, path, strict=True):
        e = estimates[i]
        if int(entries[k]) != e.entry:
            out[i] = replace(
                e, entry=int(entries[k]), score=float(scores[k]), position_m=positions[k].copy()
            )
    return out
