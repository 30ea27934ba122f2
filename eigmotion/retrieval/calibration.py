"""The "unknown" threshold and ``p_known``: how far new performances of the library's
own motions lie from the database.

A build measures, for each whole-motion entry, its distance to the nearest entry of
the other performances rendered on bodies unlike its own in build and outfit
(:func:`leave_one_motion_out_distances`); the :data:`THRESHOLD_QUANTILE` of those
distances is the database's threshold and their quantiles at
:data:`CALIBRATION_LEVELS` are stored beside it (:func:`calibration_quantiles`).  A
query reads them back (:func:`stored_quantiles`) for the threshold at another false
rejection (:func:`threshold_for_false_rejection`) and for its ``p_known``
(:func:`share_known`).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from eigmotion.errors import DatabaseError

#: Quantile of the leave-one-motion-out distances that sets the "unknown" threshold.
THRESHOLD_QUANTILE = 0.95
#: Levels at which the build stores the quantiles of those distances: 0, 0.5, ...,
#: 100 %.  Level 190 is :data:`THRESHOLD_QUANTILE` exactly.
CALIBRATION_LEVELS = np.arange(201) / 200


def leave_one_motion_out_distances(
    points: np.ndarray,
    performance_of: np.ndarray,
    whole: np.ndarray,
    body_of: np.ndarray | None = None,
    alike: np.ndarray | None = None,
) -> np.ndarray | None:
    """How far new performances of the library's motions lie from the database.

    Each whole-motion entry is queried as a query would be, against every entry of
    the OTHER performances rendered on bodies UNLIKE its own (as if that performance
    were new, by someone whose body and clothes the database does not hold, as in
    every real query): its nearest distance is what a known motion done by someone
    else looks like.  The "unknown" threshold is the :data:`THRESHOLD_QUANTILE` of these
    distances (:func:`leave_one_motion_out_threshold`), and their quantiles, stored
    (:func:`calibration_quantiles`), give each answer its ``p_known``.

    Parameters
    ----------
    points : (N, k) float
    performance_of : (N,) int
        Performance index of each entry: a motion and its mirror image are one
        performance (the mirror of a walk seen from the left is the walk seen from
        the right).
    whole : (N,) bool
        Entries that cover a whole motion.
    body_of : (N,) int, optional
        The body (shape and outfit, an index into ``BuildConfig.bodies``) each entry
        was rendered on.  Not given, or one body in all: every body of the other
        performances is compared with.
    alike : (B, B) bool, optional
        ``alike[i, j]``: body ``j`` counts as the same person's as body ``i`` and is
        left out of body ``i``'s comparisons (:meth:`~eigmotion.retrieval.
        library_views.BuildConfig.alike_bodies`: the same build or the same outfit).
        Not given: each body is alike only to itself.

    Returns
    -------
    (M,) float64 or None
        One distance per whole-motion entry, in the entries' order, eigenspace units
        (each measured in the points' own dtype, as a query's search measures it); an
        entry with no other performance on a body unlike its own has none.  None when
        no entry has one (a database of one performance has nothing to compare with
        but itself).
    """
    if len(np.unique(performance_of)) == 1:
        return None
    points = np.asarray(points)
    performance_of = np.asarray(performance_of, dtype=np.int64)
    several_bodies = body_of is not None and len(np.unique(body_of)) > 1
    body_of = np.asarray(body_of) if several_bodies else np.zeros(len(points), np.int64)
    if alike is None:
        alike = np.eye(int(body_of.max()) + 1, dtype=bool)
    # Body by body: the entries it is compared with are gathered once, and each block
    # of its whole-motion entries is compared with all of them by one float64 matrix
    # product, the block's own performances left out as the nearest is picked.  The
    # distance to the nearest is then the norm of the difference in the points' own
    # dtype, as the databases built so far measured it to the bit (not
    # brute_force's, which takes the float32 sum's root in float64).
    p64 = points.astype(np.float64)
    norms = np.einsum("ij,ij->i", p64, p64)
    queries = np.flatnonzero(whole)
    distances = np.full(len(queries), np.nan)
    for body in np.unique(body_of[whole]):
        unlike = ~alike[body][body_of] if several_bodies else np.ones(len(points), bool)
        others = np.flatnonzero(unlike)
        others64, others_norms = p64[others], norms[others]
        others_performance = performance_of[others]
        mine = np.flatnonzero(body_of[queries] == body)
        for block in np.array_split(mine, -(-len(mine) // _QUERY_BLOCK)):
            rows = queries[block]
            nearest = np.empty(len(rows), dtype=np.int64)
            _nearest_kernel()(
                p64[rows] @ others64.T, norms[rows], others_norms,
                performance_of[rows], others_performance, nearest,
            )  # fmt: skip
            found = nearest >= 0
            distances[block[found]] = np.linalg.norm(
                points[others[nearest[found]]] - points[rows[found]], axis=1
            )
    distances = distances[~np.isnan(distances)]
    return distances if len(distances) else None


def leave_one_motion_out_threshold(
    points: np.ndarray,
    performance_of: np.ndarray,
    whole: np.ndarray,
    body_of: np.ndarray | None = None,
    alike: np.ndarray | None = None,
) -> float:
    """The "unknown" threshold from the database itself: the
    :data:`THRESHOLD_QUANTILE` of :func:`leave_one_motion_out_distances` (same
    parameters) — about that share of new performances of library motions is accepted.

    Returns
    -------
    float
        For a database of one performance, twice its largest distance from the
        centre of its entries: the threshold then accepts anything as near as the
        database is wide.
    """
    distances = leave_one_motion_out_distances(points, performance_of, whole, body_of, alike)
    return threshold_from_distances(distances, points)


def threshold_from_distances(distances: np.ndarray | None, points: np.ndarray) -> float:
    """:func:`leave_one_motion_out_threshold` from its distances (None for one
    performance) and the (N, k) points (what a build stores, from the distances it
    also keeps the quantiles of)."""
    if distances is None:
        points = np.asarray(points)
        return float(2.0 * np.linalg.norm(points - points.mean(axis=0), axis=1).max())
    return float(np.quantile(distances, THRESHOLD_QUANTILE))


def calibration_quantiles(distances: np.ndarray | None) -> list[float] | None:
    """The quantiles of :func:`leave_one_motion_out_distances` at
    :data:`CALIBRATION_LEVELS`, as the store keeps them: (201,) float, eigenspace
    units, non-decreasing; None where there are no distances."""
    if distances is None:
        return None
    return np.quantile(distances, CALIBRATION_LEVELS).tolist()


#: Whole-motion entries whose distances to the rest are computed together: bounds
#: the (block × entries) matrix of :func:`leave_one_motion_out_distances` (128 rows of
#: a default database's 90,000 entries to compare with: 92 MB).
_QUERY_BLOCK = 128


def stored_quantiles(uri: str, stored: dict) -> np.ndarray | None:
    """The build's :func:`calibration_quantiles` read back and checked: (201,) float,
    or None for a database built without them."""
    quantiles = stored.get("calibration_quantiles")
    if quantiles is None:
        return None
    try:
        quantiles = np.asarray(quantiles, dtype=np.float64)
    except (TypeError, ValueError):
        quantiles = np.empty(0)
    if (
        quantiles.shape != CALIBRATION_LEVELS.shape
        or not np.all(np.isfinite(quantiles))
        or np.any(np.diff(quantiles) < 0)
    ):
        raise DatabaseError(
            f"{uri}: the stored calibration quantiles are damaged (expected "
            f"{len(CALIBRATION_LEVELS)} finite, non-decreasing distances); build it again"
        )
    return quantiles


@lru_cache(maxsize=1)
def _nearest_kernel():
    """:func:`_nearest_of_other_performances` compiled (numba is imported here: a query,
    which reads the calibration, never loads it)."""
    from numba import njit

    return njit(cache=True, nogil=True)(_nearest_of_other_performances)


def _nearest_of_other_performances(
    products, query_norms, others_norms, query_performance, others_performance, out
):  # pragma: no cover - JIT
    """The nearest entry of another performance for each query, from a matrix product.

    ``products`` (Q, N) float64 holds ``q · p`` for every (query, entry) pair, the norms
    (Q,) and (N,) ``q · q`` and ``p · p``; the squared distance of a pair is taken as
    ``(q · q + p · p) - 2 q · p``, as numpy would evaluate it.  Fills ``out`` (Q,)
    int64 with the index of the first entry of least squared distance among those
    whose performance differs from the query's, or -1 when there is none.  Written for
    numba: plain loops.
    """
    for i in range(products.shape[0]):
        best = np.inf
        nearest = -1
        own = query_performance[i]
        for j in range(products.shape[1]):
            if others_performance[j] == own:
                continue
            squared = (query_norms[i] + others_norms[j]) - 2.0 * products[i, j]
            if squared < best:
                best = squared
                nearest = j
        out[i] = nearest


def threshold_for_false_rejection(quantiles: np.ndarray, false_rejection: float) -> float:
    """The distance beyond which about ``false_rejection`` of new performances of the
    library's motions lie, from the build's :func:`calibration_quantiles`.

    Parameters
    ----------
    quantiles : (201,) float
        :func:`stored_quantiles`, eigenspace units.
    false_rejection : float
        In (0, 1).

    Returns
    -------
    float
        Eigenspace units.
    """
    # The share beyond quantile i is CALIBRATION_LEVELS[200 - i]: read backwards, so
    # that 0.05 gives the 95th percentile to the bit (1 - 0.05 is not 0.95).
    beyond = quantiles[::-1]
    return float(np.interp(false_rejection, CALIBRATION_LEVELS, beyond))


def share_known(quantiles: np.ndarray, distance: float) -> float:
    """The share of new performances of the library's motions that lie at least
    ``distance`` (eigenspace units) from the database, in [0, 1], from the build's
    (201,) :func:`calibration_quantiles`.  ``distance <=
    threshold_for_false_rejection(quantiles, r)`` exactly when ``share_known(quantiles,
    distance) >= r``."""
    shares_beyond = CALIBRATION_LEVELS[::-1]
    return float(np.interp(distance, quantiles, shares_beyond))
