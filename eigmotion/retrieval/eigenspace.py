"""The eigenspace: motion images (unit vectors) → points in a k-dimensional space.

Step 4 of the retrieval engine (Karhunen–Loève expansion).  With ``P`` training
vectors ``x_1 … x_P`` of ``D`` pixels each and their mean ``c``::

    X = (x_1 − c, …, x_P − c)          (D, P)
    Q = X Xᵀ                           (D, D), the scatter matrix
    E = (e_1 … e_k)                    eigenvectors of the k largest eigenvalues of Q
    g = Eᵀ (x − c)                     the point of an image, (k,)

Motion databases hold far fewer images than pixels (``P ≪ D``: thousands of images of
65,536 pixels), so :meth:`Eigenspace.fit` eigen-decomposes the ``P × P`` Gram matrix
``Xᵀ X`` instead of ``Q``; both share their non-zero eigenvalues, and ``e_j = X v_j /
√λ_j`` for each Gram eigenvector ``v_j``.  When ``P > D`` it decomposes ``Q`` directly.
Products are accumulated in float64 in column blocks, so memory stays near the size
of the input.

Eigenvector signs are fixed deterministically (the largest-magnitude coordinate of each
``e_j`` is positive, as scikit-learn's ``svd_flip`` does), so rebuilding a database from
the same images gives the same points and the same B-tree keys.  Only eigenvalues that
are repeated exactly leave their eigenvectors undetermined.

:func:`pack_array` / :func:`unpack_array` turn arrays into plain dictionaries of
numbers and bytes, the form the store keeps; :meth:`Eigenspace.to_state` and
:meth:`Eigenspace.from_state` use them, so no class of this package is ever pickled.
"""

from __future__ import annotations

import math
from numbers import Integral, Real
from typing import ClassVar

import numpy as np

from eigmotion.errors import InvalidParameterError, NotFittedError
from eigmotion.validation import Interval, validate_params

#: Version of the dictionary written by :meth:`Eigenspace.to_state`.
STATE_VERSION = 1

#: Dtypes :func:`unpack_array` accepts (little-endian, as :func:`pack_array` writes).
_PACKED_DTYPES = ("<f4", "<f8", "<i4", "<i8", "|u1", "|b1")

#: Float64 elements per working block (64 MiB), bounding temporary memory.
_BLOCK_ELEMENTS = 1 << 23


def pack_array(array: np.ndarray) -> dict:
    """An array as a plain dictionary: ``{"dtype": str, "shape": tuple, "data": bytes}``.

    Parameters
    ----------
    array : ndarray
        Any shape; dtype float32, float64, int32, int64, uint8 or bool.

    Returns
    -------
    dict
        ``dtype`` the little-endian dtype string (``"<f4"``), ``shape`` a tuple of
        ints, ``data`` the C-order bytes.  Only built-in types: safe to pickle into a
        database without naming any module of this package or of numpy.
    """
    a = np.asarray(array)
    dtype = a.dtype.newbyteorder("<") if a.dtype.kind in "fiub" else a.dtype
    if dtype.str not in _PACKED_DTYPES:
        raise InvalidParameterError(
            f"pack_array: dtype {a.dtype} is not one of float32, float64, int32, int64, uint8, bool"
        )
    data = np.ascontiguousarray(a, dtype=dtype).tobytes()
    return {"dtype": dtype.str, "shape": tuple(int(n) for n in a.shape), "data": data}


def unpack_array(state: dict, name: str = "array") -> np.ndarray:
    """The array of a dictionary written by :func:`pack_array` (a writable copy).

    Parameters
    ----------
    state : dict
        With ``dtype``, ``shape`` and ``data``.
    name : str
        What the array is, for error messages.

    Returns
    -------
    ndarray
        Of the stored dtype (native byte order) and shape.

    Raises
    ------
    InvalidParameterError
        A missing field, an unknown dtype, or data whose length disagrees with the
        shape.
    """
    if not isinstance(state, dict) or not {"dtype", "shape", "data"} <= set(state):
        raise InvalidParameterError(f"{name}: expected a dict with dtype, shape and data")
    if state["dtype"] not in _PACKED_DTYPES:
        raise InvalidParameterError(f"{name}: unknown dtype {state['dtype']!r}")
    dtype = np.dtype(state["dtype"])
    shape = tuple(int(n) for n in state["shape"])
    if any(n < 0 for n in shape):
        raise InvalidParameterError(f"{name}: negative dimension in shape {shape}")
    expected = math.prod(shape) * dtype.itemsize
    data = state["data"]
    if not isinstance(data, bytes | bytearray) or len(data) != expected:
        got = len(data) if isinstance(data, bytes | bytearray) else type(data).__name__
        raise InvalidParameterError(
            f"{name}: {got} bytes of data for shape {shape} and dtype {dtype} (expected {expected})"
        )
    return np.frombuffer(data, dtype=dtype).reshape(shape).astype(dtype.newbyteorder("="))


def _check_matrix(X, name: str, n_features: int | None = None) -> np.ndarray:
    a = np.asarray(X)
    if a.ndim != 2:
        hint = " (use x.reshape(1, -1) for a single vector)" if a.ndim == 1 else ""
        raise InvalidParameterError(f"{name} must be 2-D (n, d), got shape {a.shape}{hint}")
    if not np.issubdtype(a.dtype, np.number) or np.issubdtype(a.dtype, np.complexfloating):
        raise InvalidParameterError(f"{name} must hold real numbers, got dtype {a.dtype}")
    if n_features is not None and a.shape[1] != n_features:
        raise InvalidParameterError(
            f"{name} has {a.shape[1]} columns; the eigenspace was fitted on {n_features}"
        )
    if not np.all(np.isfinite(a)):
        bad = int(np.flatnonzero(~np.all(np.isfinite(a), axis=1))[0])
        raise InvalidParameterError(f"{name} row {bad} holds NaN or infinity")
    return a


def _column_blocks(n_rows: int, n_cols: int):
    width = max(1, _BLOCK_ELEMENTS // max(n_rows, 1))
    for start in range(0, n_cols, width):
        yield slice(start, min(start + width, n_cols))


def _row_blocks(n_rows: int, n_cols: int):
    height = max(1, _BLOCK_ELEMENTS // max(n_cols, 1))
    for start in range(0, n_rows, height):
        yield slice(start, min(start + height, n_rows))


class Eigenspace:
    """Karhunen–Loève eigenspace of a set of vectors, in scikit-learn style.

    Parameters
    ----------
    n_components : int, optional
        Number ``k`` of eigenvectors kept.  ``None`` (default) picks the smallest
        ``k`` whose eigenvalues explain at least ``explained_variance`` of the total.
    explained_variance : float
        Fraction of the total variance, in (0, 1], that the kept eigenvectors must
        explain when ``n_components`` is ``None``.

    Attributes
    ----------
    mean_ : (D,) float64
        The mean vector ``c``.
    components_ : (k, D) float32
        The eigenvectors ``e_j`` as unit-norm rows, largest eigenvalue first.
    eigenvalues_ : (k,) float64
        Their eigenvalues of the scatter matrix ``Q = X Xᵀ`` (sum of squared
        coordinates along each axis over the training set; divide by ``P − 1`` for
        variances).
    explained_variance_ratio_ : (k,) float64
        Each eigenvalue over the sum of all eigenvalues (the total scatter).
    n_components_ : int
        ``k``.
    n_features_in_ : int
        ``D``.
    n_samples_ : int
        ``P``, the number of vectors fitted on.
    """

    #: The valid values of each parameter (see :mod:`eigmotion.validation`), checked
    #: by :meth:`fit`.
    _parameter_constraints: ClassVar[dict] = {
        "n_components": [Interval(Integral, 1, None, description="a positive integer"), None],
        "explained_variance": Interval(Real, 0.0, 1.0, closed="right", noun=""),
    }

    def __init__(self, n_components: int | None = None, explained_variance: float = 0.95):
        self.n_components = n_components
        self.explained_variance = explained_variance

    # -- parameters ---------------------------------------------------------------
    def _validate_params(self) -> None:
        validate_params(self, self._parameter_constraints)

    def _check_fitted(self) -> None:
        if not hasattr(self, "components_"):
            raise NotFittedError(
                "this Eigenspace is not fitted yet: call fit(X) or Eigenspace.from_state()"
            )

    # -- fitting ------------------------------------------------------------------
    def fit(self, X) -> Eigenspace:
        """Learn the mean and the leading eigenvectors of ``X``.

        Parameters
        ----------
        X : (P, D) array of float
            One vector per row (motion images: float32, unit norm), ``P >= 2``.

        Returns
        -------
        self : Eigenspace

        Raises
        ------
        InvalidParameterError
            A bad parameter, fewer than 2 rows, non-finite values, all rows equal, or
            ``n_components`` larger than the number of non-degenerate directions
            (at most ``P − 1``).
        """
        self._validate_params()
        X = _check_matrix(X, "X")
        n_samples, n_features = X.shape
        if n_samples < 2:
            raise InvalidParameterError(f"X needs at least 2 rows to fit, got {n_samples}")
        mean = X.sum(axis=0, dtype=np.float64) / n_samples

        if n_samples <= n_features:
            eigenvalues, components = self._fit_gram(X, mean)
        else:
            eigenvalues, components = self._fit_scatter(X, mean)
        total = float(eigenvalues.sum())
        if not total > 0.0:
            raise InvalidParameterError("X has no variance: all rows are equal")
        # Directions whose eigenvalue is rounding noise are not part of the data.
        rank = int(np.count_nonzero(eigenvalues > eigenvalues[0] * max(X.shape) * 1e-13))
        ratio = eigenvalues / total
        if self.n_components is not None:
            k = int(self.n_components)
            if k > rank:
                raise InvalidParameterError(
                    f"n_components={k} exceeds the {rank} non-degenerate directions of "
                    f"{n_samples} vectors"
                )
        else:
            cumulative = np.cumsum(ratio[:rank])
            target = float(self.explained_variance) * cumulative[-1] - 1e-12
            k = min(int(np.searchsorted(cumulative, target)) + 1, rank)

        components = components[:k]
        # svd_flip-style sign: the largest-magnitude coordinate of each axis is positive.
        pivots = np.argmax(np.abs(components), axis=1)
        signs = np.sign(components[np.arange(k), pivots])
        signs[signs == 0] = 1.0
        components *= signs[:, None]

        self.mean_ = mean
        self.components_ = components.astype(np.float32)
        self.eigenvalues_ = eigenvalues[:k].copy()
        self.explained_variance_ratio_ = ratio[:k].copy()
        self.n_components_ = k
        self.n_features_in_ = n_features
        self.n_samples_ = n_samples
        return self

    @staticmethod
    def _fit_gram(X: np.ndarray, mean: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Eigen-decompose the (P, P) Gram matrix; return (P,) values, (P, D) vectors."""
        n_samples, n_features = X.shape
        gram = np.zeros((n_samples, n_samples))
        for cols in _column_blocks(n_samples, n_features):
            block = X[:, cols].astype(np.float64) - mean[cols]
            gram += block @ block.T
        values, vectors = np.linalg.eigh(gram)
        values, vectors = values[::-1], vectors[:, ::-1]
        values = np.clip(values, 0.0, None)
        keep = values > 0.0
        scale = np.zeros_like(values)
        scale[keep] = 1.0 / np.sqrt(values[keep])
        components = np.zeros((n_samples, n_features))
        n_keep = int(np.count_nonzero(keep))
        for cols in _column_blocks(n_samples, n_features):
            block = X[:, cols].astype(np.float64) - mean[cols]
            components[:n_keep, cols] = (vectors[:, :n_keep] * scale[:n_keep]).T @ block
        norms = np.linalg.norm(components, axis=1)
        components[norms > 0] /= norms[norms > 0, None]
        return values, components

    @staticmethod
    def _fit_scatter(X: np.ndarray, mean: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Eigen-decompose the (D, D) scatter matrix; return (D,) values, (D, D) vectors."""
        n_samples, n_features = X.shape
        scatter = np.zeros((n_features, n_features))
        for rows in _row_blocks(n_samples, n_features):
            block = X[rows].astype(np.float64) - mean
            scatter += block.T @ block
        values, vectors = np.linalg.eigh(scatter)
        return np.clip(values[::-1], 0.0, None), vectors[:, ::-1].T.copy()

    # -- projection ---------------------------------------------------------------
    def transform(self, X) -> np.ndarray:
        """Points of vectors in the eigenspace: ``g = Eᵀ (x − c)``.

        Parameters
        ----------
        X : (N, D) array of float

        Returns
        -------
        (N, k) float32
            Eigen-coordinates, computed in float64 and rounded once.
        """
        self._check_fitted()
        X = _check_matrix(X, "X", self.n_features_in_)
        basis = self.components_.astype(np.float64)
        out = np.empty((X.shape[0], self.n_components_), dtype=np.float32)
        for rows in _row_blocks(X.shape[0], X.shape[1]):
            out[rows] = (X[rows].astype(np.float64) - self.mean_) @ basis.T
        return out

    def inverse_transform(self, points) -> np.ndarray:
        """Vectors back from eigen-coordinates: ``c + E g``.

        Parameters
        ----------
        points : (N, k) array of float

        Returns
        -------
        (N, D) float32
        """
        self._check_fitted()
        g = _check_matrix(points, "points", self.n_components_).astype(np.float64)
        basis = self.components_.astype(np.float64)
        out = np.empty((g.shape[0], self.n_features_in_), dtype=np.float32)
        for rows in _row_blocks(g.shape[0], self.n_features_in_):
            out[rows] = g[rows] @ basis + self.mean_
        return out

    def reconstruction_error(self, X) -> np.ndarray:
        """Distance of each vector from the eigenspace: ``‖(x − c) − E Eᵀ (x − c)‖``.

        A new motion image far from the eigenspace is badly represented by its point
        (its distances to database points mean little): flag it, or rebuild.

        Parameters
        ----------
        X : (N, D) array of float

        Returns
        -------
        (N,) float64
            Euclidean norm of the residual, in the units of ``X`` (for unit vectors,
            between 0 and 2).
        """
        self._check_fitted()
        X = _check_matrix(X, "X", self.n_features_in_)
        basis = self.components_.astype(np.float64)
        out = np.empty(X.shape[0])
        for rows in _row_blocks(X.shape[0], X.shape[1]):
            centred = X[rows].astype(np.float64) - self.mean_
            residual = centred - (centred @ basis.T) @ basis
            out[rows] = np.linalg.norm(residual, axis=1)
        return out

    # -- storage ------------------------------------------------------------------
    def to_state(self) -> dict:
        """Everything learned, as a dictionary of plain numbers and packed arrays.

        Returns
        -------
        dict
            Keys ``state_version``, ``n_components`` (parameter), ``explained_variance``
            (parameter), ``n_samples``, ``mean``, ``components``, ``eigenvalues``,
            ``explained_variance_ratio`` (the last four packed by :func:`pack_array`).
        """
        self._check_fitted()
        return {
            "state_version": STATE_VERSION,
            "n_components": None if self.n_components is None else int(self.n_components),
            "explained_variance": float(self.explained_variance),
            "n_samples": int(self.n_samples_),
            "mean": pack_array(self.mean_),
            "components": pack_array(self.components_),
            "eigenvalues": pack_array(self.eigenvalues_),
            "explained_variance_ratio": pack_array(self.explained_variance_ratio_),
        }

    @classmethod
    def from_state(cls, state: dict) -> Eigenspace:
        """A fitted eigenspace from :meth:`to_state`'s dictionary.

        Raises
        ------
        InvalidParameterError
            A missing field, another state version, or arrays of inconsistent shapes.
        """
        required = (
            "state_version",
            "n_components",
            "explained_variance",
            "n_samples",
            "mean",
            "components",
            "eigenvalues",
            "explained_variance_ratio",
        )
        if not isinstance(state, dict):
            raise InvalidParameterError(f"eigenspace state must be a dict, got {type(state)}")
        missing = [name for name in required if name not in state]
        if missing:
            raise InvalidParameterError(f"eigenspace state lacks {missing}")
        if state["state_version"] != STATE_VERSION:
            raise InvalidParameterError(
                f"eigenspace state version {state['state_version']!r}; "
                f"this version reads {STATE_VERSION}"
            )
        self = cls(state["n_components"], state["explained_variance"])
        mean = unpack_array(state["mean"], "eigenspace mean").astype(np.float64)
        components = unpack_array(state["components"], "eigenspace components")
        eigenvalues = unpack_array(state["eigenvalues"], "eigenspace eigenvalues")
        ratio = unpack_array(state["explained_variance_ratio"], "eigenspace variance ratio")
        if components.ndim != 2 or mean.shape != (components.shape[1],):
            raise InvalidParameterError(
                f"eigenspace state: components {components.shape} and mean {mean.shape} disagree"
            )
        k = components.shape[0]
        if eigenvalues.shape != (k,) or ratio.shape != (k,):
            raise InvalidParameterError(
                f"eigenspace state: {k} components but eigenvalues {eigenvalues.shape}, "
                f"ratios {ratio.shape}"
            )
        self.mean_ = mean
        self.components_ = components.astype(np.float32)
        self.eigenvalues_ = eigenvalues.astype(np.float64)
        self.explained_variance_ratio_ = ratio.astype(np.float64)
        self.n_components_ = k
        self.n_features_in_ = components.shape[1]
        self.n_samples_ = int(state["n_samples"])
        return self

    def __repr__(self) -> str:
        params = (
            f"n_components={self.n_components!r}, explained_variance={self.explained_variance!r}"
        )
        if hasattr(self, "components_"):
            return f"Eigenspace({params}) fitted: k={self.n_components_}, D={self.n_features_in_}"
        return f"Eigenspace({params})"
