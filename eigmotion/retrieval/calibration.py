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
        One distance per whole-motion entry, eigenspace units (each measured in the
        points' own dtype, as a query's search measures it); None for a database of
        one performance, which has nothing to compare with but itself.
    """
    if len(np.unique(performance_of)) == 1:
        return None
    points = np.asarray(points)
    several_bodies = body_of is not None and len(np.unique(body_of)) > 1
    body_of = np.asarray(body_of) if several_bodies else np.zeros(len(points), np.int64)
    if alike is None:
        alike = np.eye(int(body_of.max()) + 1, dtype=bool)
    found = []
    for performance in np.unique(performance_of[whole]):
        mine = performance_of == performance
        for body in np.unique(body_of[whole & mine]):
            queries = np.flatnonzero(whole & mine & (body_of == body))
            others = points[~mine & ~alike[body][body_of] if several_bodies else ~mine]
            for block in np.array_split(queries, -(-len(queries) // _QUERY_BLOCK)):
                found.append(_nearest_distances(points[block], others))
    return np.concatenate(found).astype(np.float64)


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
#: the (block × entries) matrix of :func:`leave_one_motion_out_threshold`.
_QUERY_BLOCK = 256


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


def _nearest_distances(queries: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(Q,) Euclidean distance from each of ``queries`` (Q, k) to its nearest among
    ``points`` (N, k).  The nearest is found by one float64 matrix product for all
    the pairs; its distance is then the norm of the difference in the points' own
    dtype (float32 for a database's points).

    Not :func:`~eigmotion.retrieval.brute_force.brute_force`: that takes the square
    root of the float32 sum in float64, and its float32 nearest may differ from this
    float64 one at a near tie, so the distances (and the thresholds and quantiles
    stored from them) would differ in their last bits from those of the databases
    already built."""
    q64, p64 = queries.astype(np.float64), points.astype(np.float64)
    squared = (
        np.einsum("ij,ij->i", q64, q64)[:, None]
        + np.einsum("ij,ij->i", p64, p64)[None, :]
        - 2.0 * q64 @ p64.T
    )
    return np.linalg.norm(points[np.argmin(squared, axis=1)] - queries, axis=1)


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
