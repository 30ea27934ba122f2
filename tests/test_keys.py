"""R-ary keys: encode/decode properties, quantizer boundaries, key-space limits."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from eigmotion.errors import InvalidParameterError, NotFittedError
from eigmotion.retrieval.keys import (
    Quantizer,
    check_key_space,
    decode,
    encode,
    key_prefix,
    prefix_range,
)


@st.composite
def section_tables(draw):
    """(sections (N, K) int64, R) with R**K < 2**63."""
    n_sections = draw(st.integers(2, 64))
    max_axes = 1
    while n_sections ** (max_axes + 1) < 2**63:
        max_axes += 1
    n_axes = draw(st.integers(1, max_axes))
    rows = draw(
        st.lists(
            st.lists(st.integers(0, n_sections - 1), min_size=n_axes, max_size=n_axes),
            min_size=1,
            max_size=20,
        )
    )
    return np.array(rows, dtype=np.int64).reshape(-1, n_axes), n_sections


@settings(max_examples=200, deadline=None)
@given(section_tables())
def test_encode_decode_round_trip(table):
    sections, n_sections = table
    keys = encode(sections, n_sections)
    assert keys.dtype == np.int64
    assert np.all(keys >= 0)
    np.testing.assert_array_equal(decode(keys, n_sections, sections.shape[1]), sections)


@settings(max_examples=200, deadline=None)
@given(section_tables())
def test_keys_order_like_digit_tuples(table):
    sections, n_sections = table
    keys = encode(sections, n_sections).tolist()
    rows = [tuple(r) for r in sections.tolist()]
    for i in range(len(rows)):
        for j in range(len(rows)):
            assert (keys[i] < keys[j]) == (rows[i] < rows[j])


@settings(max_examples=100, deadline=None)
@given(section_tables(), st.data())
def test_prefix_range_holds_exactly_the_prefix(table, data):
    sections, n_sections = table
    n_axes = sections.shape[1]
    digits = data.draw(st.integers(0, n_axes))
    keys = encode(sections, n_sections)
    prefixes = key_prefix(keys, n_sections, n_axes, digits)
    for prefix, key in zip(prefixes.tolist(), keys.tolist(), strict=True):
        low, high = prefix_range(prefix, n_sections, n_axes, digits)
        assert low <= key <= high
        np.testing.assert_array_equal(
            decode(np.array([low, high]), n_sections, n_axes)[:, :digits],
            sections[keys.tolist().index(key)][None, :digits].repeat(2, axis=0),
        )


@pytest.mark.parametrize(
    ("n_sections", "n_axes", "ok"),
    [(2, 62, True), (2, 63, False), (8, 20, True), (8, 21, False), (16, 15, True), (16, 16, False)],
)
def test_key_space_limit(n_sections, n_axes, ok):
    if ok:
        check_key_space(n_sections, n_axes)
    else:
        with pytest.raises(InvalidParameterError, match=f"R={n_sections}.*K={n_axes}"):
            check_key_space(n_sections, n_axes)


@pytest.mark.parametrize(("n_sections", "n_axes"), [(1, 3), (0, 3), (4, 0), (2.5, 2)])
def test_key_space_rejects_bad_r_k(n_sections, n_axes):
    with pytest.raises(InvalidParameterError):
        check_key_space(n_sections, n_axes)


def test_encode_rejects_digits_out_of_range():
    with pytest.raises(InvalidParameterError, match="row 1"):
        encode(np.array([[0, 1], [4, 0]]), 4)
    with pytest.raises(InvalidParameterError, match="integers"):
        encode(np.array([[0.5, 1.0]]), 4)
    with pytest.raises(InvalidParameterError, match="lie in"):
        decode(np.array([16]), 4, 2)


@pytest.mark.parametrize("method", ["quantile", "equal"])
@pytest.mark.parametrize(("n_axes", "n_sections"), [(1, 2), (3, 8), (5, 16)])
def test_quantizer_sections(rng, method, n_axes, n_sections):
    points = rng.standard_normal((4000, 6)) * np.array([3.0, 2.0, 1.5, 1.0, 0.5, 0.2])
    q = Quantizer(n_axes, n_sections, method).fit(points)
    assert q.edges_.shape == (n_axes, n_sections - 1)
    assert np.all(np.diff(q.edges_, axis=1) >= 0)
    sections = q.sections(points)
    assert sections.shape == (4000, n_axes) and sections.min() >= 0
    assert sections.max() <= n_sections - 1
    low, high = q.section_bounds()
    axes = np.arange(n_axes)
    head = points[:, :n_axes]
    assert np.all(low[axes, sections] <= head) and np.all(head < high[axes, sections])
    counts = np.stack([np.bincount(s, minlength=n_sections) for s in sections.T])
    if method == "quantile":  # every section of an axis holds N / R points
        assert np.all(np.abs(counts - 4000 / n_sections) <= 2)
    else:  # equal widths between the extremes
        width = (head.max(0) - head.min(0)) / n_sections
        np.testing.assert_allclose(
            np.diff(q.edges_, axis=1), width[:, None].repeat(n_sections - 2, 1)
        )
    np.testing.assert_array_equal(q.keys(points), encode(sections, n_sections))


def test_points_outside_the_fitted_range_fall_in_the_end_sections():
    q = Quantizer(2, 4, "equal").fit(np.array([[0.0, 0.0], [4.0, 4.0]]))
    np.testing.assert_array_equal(q.sections(np.array([[-100.0, 100.0]])), [[0, 3]])


def test_quantizer_state_round_trip(rng):
    points = rng.standard_normal((100, 4))
    q = Quantizer(3, 5, "equal").fit(points)
    again = Quantizer.from_state(q.to_state())
    np.testing.assert_array_equal(again.edges_, q.edges_)
    np.testing.assert_array_equal(again.keys(points), q.keys(points))
    state = q.to_state()
    state["edges"] = q.to_state()["edges"] | {"shape": (4, 4)}
    with pytest.raises(InvalidParameterError):
        Quantizer.from_state(state)


def test_quantizer_errors(rng):
    with pytest.raises(NotFittedError):
        Quantizer().sections(np.zeros((1, 4)))
    with pytest.raises(InvalidParameterError, match="k >= K = 4"):
        Quantizer(4, 8).fit(np.zeros((10, 3)))
    with pytest.raises(InvalidParameterError, match="method"):
        Quantizer(2, 8, "log").fit(np.zeros((10, 3)))
    with pytest.raises(InvalidParameterError, match="R=16 sections on K=16"):
        Quantizer(16, 16).fit(np.zeros((10, 16)))
    with pytest.raises(InvalidParameterError, match="row 2"):
        Quantizer(1, 2).fit(np.array([[0.0], [1.0], [np.inf]]))
