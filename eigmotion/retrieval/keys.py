"""B-tree keys: the first K eigen-coordinates, each cut into R sections.

Step 5 of the retrieval engine.  A point ``g`` (k eigen-coordinates, k >= K) gets a
section number ``s_a`` in ``0 … R−1`` on each of its first K axes; the digits form the
K-digit, base-R key ``S = s_1 s_2 … s_K`` (first axis most significant), stored as one
``int64`` so that the B-tree (``LOBTree``) orders keys exactly as the digit tuples
order lexicographically.  All points sharing a key share a bin; all keys sharing a
prefix of ``d`` digits form one contiguous key range, which the search walks through
with B-tree range queries.

Section boundaries (:class:`Quantizer`, ``method``):

``"quantile"`` (default)
    Boundaries at the ``j/R`` quantiles of the fitted points on each axis, so every
    section of an axis holds the same number of points.
``"equal"``
    The patent's equal width ``L = (max − min) / R`` between the smallest and largest
    fitted coordinate of each axis.

Either way the outermost sections are open-ended: a new point beyond the fitted range
falls in section 0 or R−1.  A section ``j`` of axis ``a`` covers
``edges[a, j−1] <= g_a < edges[a, j]``.  ``docs/retrieval.md`` compares the two by the
number of entries the exact search examines.
"""

from __future__ import annotations

from numbers import Integral
from typing import ClassVar

import numpy as np

from eigmotion.errors import InvalidParameterError, NotFittedError
from eigmotion.retrieval.eigenspace import pack_array, unpack_array
from eigmotion.validation import Interval, Options, validate

METHODS = ("quantile", "equal")

#: Version of the dictionary written by :meth:`Quantizer.to_state`.
STATE_VERSION = 1

_KEY_LIMIT = 2**63

#: ``R``, the sections per axis, and ``K``, the axes of a key (see
#: :mod:`eigmotion.validation`).
_N_SECTIONS = Interval(Integral, 2, None)
_N_AXES = Interval(Integral, 1, None)


def check_key_space(n_sections: int, n_axes: int) -> None:
    """Check that ``R`` sections on ``K`` axes give keys that fit in an int64.

    Parameters
    ----------
    n_sections : int
        ``R``, at least 2.
    n_axes : int
        ``K``, at least 1.

    Raises
    ------
    InvalidParameterError
        ``R < 2``, ``K < 1``, or ``R**K >= 2**63``; the message names R and K.
    """
    validate("n_sections (R)", n_sections, _N_SECTIONS)
    validate("n_axes (K)", n_axes, _N_AXES)
    if int(n_sections) ** int(n_axes) >= _KEY_LIMIT:
        raise InvalidParameterError(
            f"R={n_sections} sections on K={n_axes} axes give R**K = "
            f"{int(n_sections) ** int(n_axes)} keys, more than an int64 holds (2**63); "
            "lower R or K"
        )


def encode(sections, n_sections: int) -> np.ndarray:
    """Keys of section-number rows: ``Σ_a s_a · R^(K−1−a)``.

    Parameters
    ----------
    sections : (N, K) array of int
        Section numbers, each in ``0 … R−1``; column 0 is the most significant digit.
    n_sections : int
        ``R``.

    Returns
    -------
    (N,) int64
        Keys in ``0 … R**K − 1``; ``encode(a) < encode(b)`` exactly when row ``a``
        precedes row ``b`` lexicographically.

    Raises
    ------
    InvalidParameterError
        A section number outside ``0 … R−1``, a non-integer array, or ``R**K >= 2**63``.
    """
    s = np.asarray(sections)
    if s.ndim != 2:
        raise InvalidParameterError(f"sections must be 2-D (N, K), got shape {s.shape}")
    check_key_space(n_sections, s.shape[1])
    if s.size and not np.issubdtype(s.dtype, np.integer):
        raise InvalidParameterError(f"sections must be integers, got dtype {s.dtype}")
    if s.size and (s.min() < 0 or s.max() >= n_sections):
        row = int(np.flatnonzero(np.any((s < 0) | (s >= n_sections), axis=1))[0])
        raise InvalidParameterError(
            f"sections row {row} = {s[row].tolist()} has a digit outside 0..{n_sections - 1}"
        )
    keys = np.zeros(s.shape[0], dtype=np.int64)
    for column in s.T.astype(np.int64):
        keys *= n_sections
        keys += column
    return keys


def decode(keys, n_sections: int, n_axes: int) -> np.ndarray:
    """Section numbers of keys (inverse of :func:`encode`).

    Parameters
    ----------
    keys : (N,) array of int
        Each in ``0 … R**K − 1``.
    n_sections, n_axes : int
        ``R`` and ``K``.

    Returns
    -------
    (N, K) int64
    """
    check_key_space(n_sections, n_axes)
    k = np.asarray(keys)
    if k.ndim != 1 or (k.size and not np.issubdtype(k.dtype, np.integer)):
        raise InvalidParameterError(f"keys must be a 1-D integer array, got {k.dtype} {k.shape}")
    k = k.astype(np.int64)
    if k.size and (k.min() < 0 or k.max() >= n_sections**n_axes):
        raise InvalidParameterError(
            f"keys must lie in 0..{n_sections**n_axes - 1} for R={n_sections}, K={n_axes}"
        )
    out = np.empty((k.shape[0], n_axes), dtype=np.int64)
    for axis in range(n_axes - 1, -1, -1):
        k, out[:, axis] = np.divmod(k, n_sections)
    return out


def key_prefix(keys, n_sections: int, n_axes: int, n_digits: int) -> np.ndarray:
    """The first ``n_digits`` digits of each key, as a number: ``key // R^(K−d)``.

    Parameters
    ----------
    keys : (N,) array of int
    n_sections, n_axes : int
        ``R`` and ``K``.
    n_digits : int
        ``d`` in ``0 … K``.

    Returns
    -------
    (N,) int64
    """
    check_key_space(n_sections, n_axes)
    if not 0 <= n_digits <= n_axes:
        raise InvalidParameterError(f"n_digits must be in 0..{n_axes}, got {n_digits}")
    return np.asarray(keys, dtype=np.int64) // (n_sections ** (n_axes - n_digits))


def prefix_range(prefix: int, n_sections: int, n_axes: int, n_digits: int) -> tuple[int, int]:
    """The smallest and largest key starting with a ``d``-digit prefix.

    Use for B-tree range queries: ``tree.keys(*prefix_range(p, R, K, d))`` gives every
    occupied key of that prefix, in order.

    Returns
    -------
    (int, int)
        ``(p · R^(K−d), (p + 1) · R^(K−d) − 1)``.
    """
    check_key_space(n_sections, n_axes)
    if not 0 <= n_digits <= n_axes:
        raise InvalidParameterError(f"n_digits must be in 0..{n_axes}, got {n_digits}")
    width = n_sections ** (n_axes - n_digits)
    if not 0 <= prefix < n_sections**n_digits:
        raise InvalidParameterError(
            f"prefix {prefix} is not a {n_digits}-digit base-{n_sections} number"
        )
    return int(prefix) * width, (int(prefix) + 1) * width - 1


class Quantizer:
    """Section boundaries on the first K eigen-axes, and the keys they give.

    Parameters
    ----------
    n_axes : int
        ``K``, the number of leading eigen-axes in the key.
    n_sections : int
        ``R``, sections per axis.  ``R**K`` must stay below ``2**63``.
    method : {"quantile", "equal"}
        Where the boundaries go (see the module docstring).

    Attributes
    ----------
    edges_ : (K, R−1) float64
        Inner boundaries per axis, non-decreasing along each row.
    """

    #: The valid values of each parameter (see :mod:`eigmotion.validation`), checked
    #: by :meth:`fit`: ``n_sections`` and ``n_axes`` through :func:`check_key_space`,
    #: which names them R and K and also bounds ``R**K``.
    _parameter_constraints: ClassVar[dict] = {
        "n_sections": _N_SECTIONS,
        "n_axes": _N_AXES,
        "method": Options(str, METHODS),
    }

    def __init__(self, n_axes: int = 4, n_sections: int = 8, method: str = "quantile"):
        self.n_axes = n_axes
        self.n_sections = n_sections
        self.method = method

    def _validate_params(self) -> None:
        check_key_space(self.n_sections, self.n_axes)
        validate("method", self.method, self._parameter_constraints["method"])

    def _check_fitted(self) -> None:
        if not hasattr(self, "edges_"):
            raise NotFittedError("this Quantizer is not fitted yet: call fit(points)")

    def _check_points(self, points, name: str = "points") -> np.ndarray:
        p = np.asarray(points)
        if p.ndim != 2 or p.shape[1] < self.n_axes:
            raise InvalidParameterError(
                f"{name} must be 2-D (N, k) with k >= K = {self.n_axes}, got shape {p.shape}"
            )
        if not np.issubdtype(p.dtype, np.floating) and not np.issubdtype(p.dtype, np.integer):
            raise InvalidParameterError(f"{name} must be real numbers, got dtype {p.dtype}")
        head = p[:, : self.n_axes]
        if not np.all(np.isfinite(head)):
            row = int(np.flatnonzero(~np.all(np.isfinite(head), axis=1))[0])
            raise InvalidParameterError(f"{name} row {row} holds NaN or infinity")
        return head

    def fit(self, points) -> Quantizer:
        """Place the section boundaries from a set of points.

        Parameters
        ----------
        points : (N, k) array of float
            Eigen-coordinates, ``k >= K``, ``N >= 1``; only the first K columns are
            used.

        Returns
        -------
        self : Quantizer
        """
        self._validate_params()
        head = self._check_points(points).astype(np.float64)
        if head.shape[0] == 0:
            raise InvalidParameterError("points is empty: cannot place section boundaries")
        fractions = np.arange(1, self.n_sections) / self.n_sections
        if self.method == "quantile":
            edges = np.quantile(head, fractions, axis=0).T
        else:
            low, high = head.min(axis=0), head.max(axis=0)
            edges = low[:, None] + (high - low)[:, None] * fractions[None, :]
        self.edges_ = np.maximum.accumulate(np.ascontiguousarray(edges), axis=1)
        return self

    def sections(self, points) -> np.ndarray:
        """Section number of each point on each key axis.

        Parameters
        ----------
        points : (N, k) array of float, k >= K

        Returns
        -------
        (N, K) int64
            Values in ``0 … R−1``.
        """
        self._check_fitted()
        head = self._check_points(points)
        out = np.empty((head.shape[0], self.n_axes), dtype=np.int64)
        for axis in range(self.n_axes):
            out[:, axis] = np.searchsorted(self.edges_[axis], head[:, axis], side="right")
        return out

    def keys(self, points) -> np.ndarray:
        """B-tree keys of points: ``encode(sections(points))``.

        Parameters
        ----------
        points : (N, k) array of float, k >= K

        Returns
        -------
        (N,) int64
        """
        return encode(self.sections(points), self.n_sections)

    def section_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bound of every section, infinite at the open ends.

        Returns
        -------
        low, high : (K, R) float64
            Section ``j`` of axis ``a`` covers ``low[a, j] <= g_a < high[a, j]``.
        """
        self._check_fitted()
        inf = np.full((self.n_axes, 1), np.inf)
        return np.hstack([-inf, self.edges_]), np.hstack([self.edges_, inf])

    def to_state(self) -> dict:
        """Parameters and boundaries as a dictionary of plain values and packed arrays."""
        self._check_fitted()
        return {
            "state_version": STATE_VERSION,
            "n_axes": int(self.n_axes),
            "n_sections": int(self.n_sections),
            "method": str(self.method),
            "edges": pack_array(self.edges_),
        }

    @classmethod
    def from_state(cls, state: dict) -> Quantizer:
        """A fitted quantizer from :meth:`to_state`'s dictionary.

        Raises
        ------
        InvalidParameterError
            A missing field, another state version, or boundaries of the wrong shape.
        """
        if not isinstance(state, dict):
            raise InvalidParameterError(f"quantizer state must be a dict, got {type(state)}")
        missing = [
            n
            for n in ("state_version", "n_axes", "n_sections", "method", "edges")
            if n not in state
        ]
        if missing:
            raise InvalidParameterError(f"quantizer state lacks {missing}")
        if state["state_version"] != STATE_VERSION:
            raise InvalidParameterError(
                f"quantizer state version {state['state_version']!r}; "
                f"this version reads {STATE_VERSION}"
            )
        self = cls(state["n_axes"], state["n_sections"], state["method"])
        self._validate_params()
        edges = unpack_array(state["edges"], "quantizer edges").astype(np.float64)
        if edges.shape != (self.n_axes, self.n_sections - 1):
            raise InvalidParameterError(
                f"quantizer edges have shape {edges.shape}, expected "
                f"({self.n_axes}, {self.n_sections - 1})"
            )
        self.edges_ = edges
        return self

    def __repr__(self) -> str:
        return (
            f"Quantizer(n_axes={self.n_axes!r}, n_sections={self.n_sections!r}, "
            f"method={self.method!r})"
        )
