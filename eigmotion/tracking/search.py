"""Searching candidate postures for the best silhouette score (the paper's section 2.4.4).

Scoring a posture (rendering its silhouettes and comparing them) is the expensive step,
so the search decides which postures to score:

* :func:`two_layer_search` — the paper's 2-layer tree over the candidates sorted by
  closeness to the previous posture: every ``layer_step``-th candidate (``t``) is in
  layer 1, every other one hangs under its nearest layer-1 posture; layer 1 is
  scored, then the children of the ``top_k`` (``k``) best layer-1 postures; the best
  of everything scored wins.
* :func:`exhaustive_search` — every candidate scored (the reference).
* :func:`beam_search` — coarse to fine over a whole dictionary, for the first frame:
  farthest-point representatives of the postures are scored, the best clusters are
  split again, down to single postures.

A scoring function takes an (E,) int array of postures and returns their (E,) float
scores (higher is better); the searches call it once per layer, so that it can render
a whole layer's silhouettes in one batch.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from eigmotion.errors import InvalidParameterError

ScoreFunction = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True, eq=False)
class SearchResult:
    """Outcome of a search.

    Attributes
    ----------
    best : int
        The posture with the highest score (ties: the first scored).
    score : float
        Its score.
    evaluated : (E,) int64
        Every posture scored, in scoring order (each once).
    scores : (E,) float64
        Their scores.
    """

    best: int
    score: float
    evaluated: np.ndarray
    scores: np.ndarray

    @property
    def n_evaluations(self) -> int:
        return len(self.evaluated)


def _result(evaluated: list[np.ndarray], scores: list[np.ndarray]) -> SearchResult:
    ev = np.concatenate(evaluated).astype(np.int64)
    sc = np.concatenate(scores).astype(np.float64)
    if len(ev) == 0:
        raise InvalidParameterError("nothing to search: no candidate postures")
    i = int(np.argmax(sc))
    return SearchResult(int(ev[i]), float(sc[i]), ev, sc)


def _score(score_fn: ScoreFunction, items: np.ndarray) -> np.ndarray:
    scores = np.asarray(score_fn(items), dtype=np.float64).reshape(-1)
    if scores.shape != (len(items),):
        raise InvalidParameterError(
            f"the scoring function returned {scores.shape[0]} scores for {len(items)} postures"
        )
    return scores


@dataclass(frozen=True, eq=False)
class TwoLayerTree:
    """The paper's 2-layer search tree over sorted candidates.

    Attributes
    ----------
    candidates : (M,) int64
        Postures, nearest to the previous posture first.
    layer1 : (L,) int64
        Positions in ``candidates`` of the layer-1 postures (every ``t``-th).
    parent : (M,) int64
        Per candidate, the position in ``layer1`` of the layer-1 posture it hangs
        under (its own position in ``layer1`` for a layer-1 posture).
    """

    candidates: np.ndarray
    layer1: np.ndarray
    parent: np.ndarray

    def children(self, layer1_slot: int) -> np.ndarray:
        """(n,) int64 positions in ``candidates`` of a layer-1 posture's children."""
        mine = np.flatnonzero(self.parent == layer1_slot)
        return mine[mine != self.layer1[layer1_slot]]


def build_two_layer_tree(
    candidates: np.ndarray, distances: np.ndarray, layer_step: int = 3
) -> TwoLayerTree:
    """Arrange sorted candidates into the 2-layer tree.

    Parameters
    ----------
    candidates : (M,) int
        Postures, nearest to the previous posture first.
    distances : (M, M) float
        Distances between the candidates (only the columns of layer-1 postures are
        read): each non-layer-1 candidate hangs under the nearest layer-1 posture
        (ties: the earlier one).
    layer_step : int
        ``t``: positions ``0, t, 2t, …`` form layer 1.

    Returns
    -------
    TwoLayerTree
    """
    candidates = np.asarray(candidates, dtype=np.int64).reshape(-1)
    m = len(candidates)
    if int(layer_step) != layer_step or layer_step < 1:
        raise InvalidParameterError(f"layer_step (t) must be an integer >= 1, got {layer_step!r}")
    distances = np.asarray(distances, dtype=np.float64)
    if distances.shape != (m, m):
        raise InvalidParameterError(f"distances must be ({m}, {m}), got {distances.shape}")
    layer1 = np.arange(0, m, int(layer_step), dtype=np.int64)
    parent = np.argmin(distances[:, layer1], axis=1).astype(np.int64)
    parent[layer1] = np.arange(len(layer1))
    return TwoLayerTree(candidates, layer1, parent)


def two_layer_search(tree: TwoLayerTree, score_fn: ScoreFunction, top_k: int = 3) -> SearchResult:
    """Score layer 1, then the children of its ``top_k`` best postures; best of all.

    Parameters
    ----------
    tree : TwoLayerTree
    score_fn : callable
        (E,) int postures → (E,) float scores.
    top_k : int
        ``k`` ≥ 1; with ``k`` ≥ the size of layer 1 every candidate is scored.

    Returns
    -------
    SearchResult
    """
    if int(top_k) != top_k or top_k < 1:
        raise InvalidParameterError(f"top_k (k) must be an integer >= 1, got {top_k!r}")
    first = tree.candidates[tree.layer1]
    first_scores = _score(score_fn, first)
    order = np.argsort(-first_scores, kind="stable")[: int(top_k)]
    children = [tree.children(int(slot)) for slot in order]
    second = tree.candidates[np.concatenate(children)] if children else np.zeros(0, np.int64)
    second_scores = _score(score_fn, second) if len(second) else np.zeros(0)
    return _result([first, second], [first_scores, second_scores])


def exhaustive_search(candidates: np.ndarray, score_fn: ScoreFunction) -> SearchResult:
    """Score every candidate; the reference the tree search is measured against."""
    candidates = np.asarray(candidates, dtype=np.int64).reshape(-1)
    return _result([candidates], [_score(score_fn, candidates)])


def farthest_point_sample(
    items: np.ndarray, distance_to: Callable[[int, np.ndarray], np.ndarray], n: int
) -> tuple[np.ndarray, np.ndarray]:
    """Farthest-point sampling: ``n`` spread-out items and each item's nearest pick.

    Parameters
    ----------
    items : (N,) int
    distance_to : callable
        ``distance_to(a, items) -> (N,)`` distances from item ``a`` to ``items``.
    n : int
        Number of representatives (all items when N <= n).

    Returns
    -------
    picks : (n,) int64
        Positions in ``items`` of the representatives, the first item first.
    owner : (N,) int64
        Per item, the position in ``picks`` of its nearest representative.
    """
    items = np.asarray(items, dtype=np.int64)
    n = min(int(n), len(items))
    picks = [0]
    nearest = distance_to(int(items[0]), items)
    owner = np.zeros(len(items), dtype=np.int64)
    while len(picks) < n:
        nxt = int(np.argmax(nearest))
        if nearest[nxt] <= 0:
            break
        d = distance_to(int(items[nxt]), items)
        closer = d < nearest
        owner[closer] = len(picks)
        nearest = np.minimum(nearest, d)
        picks.append(nxt)
    return np.asarray(picks, dtype=np.int64), owner


@dataclass(frozen=True, eq=False)
class ClusterNode:
    """A posture standing for the postures of its subtree.

    Attributes
    ----------
    item : int
        The representative posture.
    children : tuple of ClusterNode
        Clusters of the other postures it stands for (empty for a single posture).
    """

    item: int
    children: tuple[ClusterNode, ...] = ()


def build_cluster_tree(
    items: np.ndarray,
    distance_to: Callable[[int, np.ndarray], np.ndarray],
    branching: int = 24,
) -> tuple[ClusterNode, ...]:
    """Hierarchical clusters for :func:`beam_search`, built once per dictionary.

    The items are split into ``branching`` clusters around farthest-point
    representatives, each cluster's other members again, down to single postures.

    Parameters
    ----------
    items : (N,) int
    distance_to : callable
        ``distance_to(a, items) -> (len(items),)`` posture distances (e.g. d1).
    branching : int
        Clusters per split, ≥ 2.

    Returns
    -------
    tuple of ClusterNode
        The top level (at most ``branching`` nodes).
    """
    if int(branching) != branching or branching < 2:
        raise InvalidParameterError(f"branching must be an integer >= 2, got {branching!r}")
    items = np.asarray(items, dtype=np.int64).reshape(-1)

    def split(group: np.ndarray) -> tuple[ClusterNode, ...]:
        if len(group) <= branching:
            return tuple(ClusterNode(int(g)) for g in group)
        picks, owner = farthest_point_sample(group, distance_to, branching)
        nodes = []
        for slot, pick in enumerate(picks):
            members = group[(owner == slot) & (np.arange(len(group)) != pick)]
            nodes.append(ClusterNode(int(group[pick]), split(members) if len(members) else ()))
        return tuple(nodes)

    return split(items)


def beam_search(
    tree: tuple[ClusterNode, ...], score_fn: ScoreFunction, beam: int = 3
) -> SearchResult:
    """Coarse-to-fine search over many postures (the first frame, with no previous one).

    The top clusters' representatives are scored; the ``beam`` best clusters are
    opened and their sub-clusters' representatives scored, and so on down to single
    postures.

    Parameters
    ----------
    tree : tuple of ClusterNode
        From :func:`build_cluster_tree`.
    score_fn : callable
        (E,) int postures → (E,) float scores.
    beam : int
        Clusters opened per level, ≥ 1.

    Returns
    -------
    SearchResult
        About ``branching × beam × depth`` postures scored.
    """
    if int(beam) != beam or beam < 1:
        raise InvalidParameterError(f"beam must be an integer >= 1, got {beam!r}")
    scored: dict[int, float] = {}
    evaluated, scores = [], []
    level = list(tree)
    while level:
        reps = np.array([node.item for node in level], dtype=np.int64)
        new = np.array([r for r in dict.fromkeys(reps.tolist()) if r not in scored], np.int64)
        if len(new):
            new_scores = _score(score_fn, new)
            scored.update(zip(new.tolist(), new_scores.tolist(), strict=True))
            evaluated.append(new)
            scores.append(new_scores)
        rep_scores = np.array([scored[r] for r in reps.tolist()])
        order = np.argsort(-rep_scores, kind="stable")
        opened = [level[i] for i in order if level[i].children][: int(beam)]
        level = [child for node in opened for child in node.children]
    return _result(evaluated, scores)
