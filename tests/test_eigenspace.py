"""Eigenspace (Karhunen–Loève): against scikit-learn's PCA, contract, storage."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.decomposition import PCA

from eigmotion.errors import EigmotionError, InvalidParameterError, NotFittedError
from eigmotion.retrieval.eigenspace import Eigenspace, pack_array, unpack_array


def unit_rows(n_rows: int, n_features: int, rank: int, rng) -> np.ndarray:
    """(n_rows, n_features) float32 unit vectors near a rank-``rank`` subspace."""
    basis = rng.standard_normal((rank, n_features))
    weights = rng.standard_normal((n_rows, rank)) / np.arange(1, rank + 1)
    x = weights @ basis + 0.01 * rng.standard_normal((n_rows, n_features))
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    return x.astype(np.float32)


def plain_only(value) -> bool:
    if isinstance(value, dict):
        return all(isinstance(k, str) and plain_only(v) for k, v in value.items())
    if isinstance(value, list | tuple):
        return all(plain_only(v) for v in value)
    return isinstance(value, bool | int | float | str | bytes | type(None))


@pytest.mark.parametrize(("n_rows", "n_features"), [(60, 500), (300, 40)])
def test_matches_sklearn_pca(rng, n_rows, n_features):
    # 60 x 500 takes the Gram-matrix path, 300 x 40 the scatter-matrix path.
    x = unit_rows(n_rows, n_features, 12, rng)
    ours = Eigenspace(n_components=10).fit(x)
    ref = PCA(n_components=10, svd_solver="full").fit(x.astype(np.float64))
    np.testing.assert_allclose(ours.mean_, ref.mean_, atol=1e-7)
    # Same sign convention as sklearn's svd_flip: rows equal, not just up to sign.
    np.testing.assert_allclose(ours.components_, ref.components_, atol=2e-5)
    np.testing.assert_allclose(ours.eigenvalues_, ref.explained_variance_ * (n_rows - 1), rtol=1e-6)
    np.testing.assert_allclose(
        ours.explained_variance_ratio_, ref.explained_variance_ratio_, rtol=1e-6
    )
    np.testing.assert_allclose(ours.transform(x), ref.transform(x), atol=2e-5)


@pytest.mark.parametrize("explained", [0.5, 0.8, 0.95, 0.999, 1.0])
def test_explained_variance_picks_smallest_k(rng, explained):
    x = unit_rows(80, 300, 20, rng)
    space = Eigenspace(explained_variance=explained).fit(x)
    full = Eigenspace(n_components=79).fit(x)
    cumulative = np.cumsum(full.explained_variance_ratio_)
    k = space.n_components_
    assert cumulative[k - 1] >= explained - 1e-9
    if k > 1:
        assert cumulative[k - 2] < explained
    assert space.components_.shape == (k, 300)
    assert space.components_.dtype == np.float32


def test_components_orthonormal_and_sorted(rng):
    space = Eigenspace(n_components=15).fit(unit_rows(50, 400, 30, rng))
    gram = space.components_.astype(np.float64) @ space.components_.T
    np.testing.assert_allclose(gram, np.eye(15), atol=1e-6)
    assert np.all(np.diff(space.eigenvalues_) <= 0)


def test_rebuild_is_deterministic_under_row_order(rng):
    x = unit_rows(40, 256, 8, rng)
    a = Eigenspace(n_components=6).fit(x)
    b = Eigenspace(n_components=6).fit(x[rng.permutation(40)])
    # Same points (and hence keys) up to rounding: signs do not flip.
    np.testing.assert_allclose(a.transform(x), b.transform(x), atol=1e-5)


def test_transform_round_trip_and_reconstruction_error(rng):
    x = unit_rows(30, 200, 5, rng)
    space = Eigenspace(n_components=29).fit(x)  # all directions: exact representation
    np.testing.assert_allclose(space.inverse_transform(space.transform(x)), x, atol=2e-5)
    assert np.all(space.reconstruction_error(x) < 1e-4)

    small = Eigenspace(n_components=3).fit(x)
    outside = unit_rows(4, 200, 5, np.random.default_rng(7))
    err = small.reconstruction_error(outside)
    residual = outside - small.inverse_transform(small.transform(outside))
    np.testing.assert_allclose(err, np.linalg.norm(residual, axis=1), atol=1e-5)
    assert np.all(err > 0.05)


def test_state_round_trip_is_plain_and_exact(rng):
    x = unit_rows(25, 128, 6, rng)
    space = Eigenspace(n_components=4).fit(x)
    state = space.to_state()
    assert plain_only(state)
    again = Eigenspace.from_state(state)
    np.testing.assert_array_equal(again.transform(x), space.transform(x))
    assert again.n_components_ == 4 and again.n_samples_ == 25


@pytest.mark.parametrize(
    "broken",
    [
        lambda s: s.pop("components"),
        lambda s: s.update(state_version=99),
        lambda s: s.update(mean=pack_array(np.zeros(3))),
        lambda s: s["eigenvalues"].update(data=b"\x00" * 3),
    ],
)
def test_from_state_rejects_damaged_states(rng, broken):
    state = Eigenspace(n_components=3).fit(unit_rows(10, 20, 4, rng)).to_state()
    broken(state)
    with pytest.raises(InvalidParameterError):
        Eigenspace.from_state(state)


def test_unfitted_use_raises():
    space = Eigenspace()
    for call in (space.transform, space.reconstruction_error, space.inverse_transform):
        with pytest.raises(NotFittedError, match="not fitted"):
            call(np.zeros((1, 3)))
    with pytest.raises(AttributeError):  # also a built-in, as sklearn does
        space.to_state()


@pytest.mark.parametrize(
    ("params", "match"),
    [
        ({"n_components": 0}, "n_components"),
        ({"n_components": 2.5}, "n_components"),
        ({"n_components": True}, "n_components"),
        ({"explained_variance": 0.0}, "explained_variance"),
        ({"explained_variance": 1.5}, "explained_variance"),
        ({"n_components": 50}, "exceeds the 9 non-degenerate"),
    ],
)
def test_bad_parameters(rng, params, match):
    with pytest.raises(InvalidParameterError, match=match):
        Eigenspace(**params).fit(unit_rows(10, 30, 5, rng))


@pytest.mark.parametrize(
    ("x", "match"),
    [
        (np.zeros(5), "2-D"),
        (np.zeros((1, 5)), "at least 2 rows"),
        (np.array([[0.0, 1.0], [np.nan, 0.0]]), "row 1"),
        (np.ones((4, 3)), "no variance"),
    ],
)
def test_bad_input(x, match):
    with pytest.raises(EigmotionError, match=match):
        Eigenspace(n_components=1).fit(x)


def test_transform_checks_width(rng):
    space = Eigenspace(n_components=2).fit(unit_rows(10, 30, 5, rng))
    with pytest.raises(InvalidParameterError, match="30"):
        space.transform(np.zeros((2, 29)))


@pytest.mark.parametrize(
    "array",
    [
        np.arange(12, dtype=np.float32).reshape(3, 4),
        np.linspace(0, 1, 5),
        np.arange(6, dtype=np.int64).reshape(2, 3),
        np.array([True, False]),
        np.zeros((0, 4), dtype=np.float32),
        np.arange(4, dtype=">f8"),
    ],
)
def test_pack_unpack_round_trip(array):
    state = pack_array(array)
    assert plain_only(state)
    back = unpack_array(state)
    np.testing.assert_array_equal(back, array)
    assert back.dtype == array.dtype.newbyteorder("=")


def test_unpack_rejects_bad_data():
    state = pack_array(np.zeros(4, dtype=np.float32))
    state["data"] = state["data"][:-1]
    with pytest.raises(InvalidParameterError, match="15 bytes"):
        unpack_array(state, "mean")
    with pytest.raises(InvalidParameterError, match="dtype"):
        pack_array(np.array(["a"]))
