"""The declared constraints of eigmotion.validation: what they accept and what they say."""

from __future__ import annotations

from fractions import Fraction
from numbers import Integral, Real

import numpy as np
import pytest

from eigmotion.errors import InvalidParameterError
from eigmotion.pose.continuous_pose import ContinuousPoseConfig
from eigmotion.retrieval.eigenspace import Eigenspace
from eigmotion.retrieval.keys import Quantizer
from eigmotion.retrieval.library_views import BuildConfig
from eigmotion.retrieval.motion_image import MotionImageConfig
from eigmotion.segmentation.config import SilhouetteConfig
from eigmotion.tracking.tracker import TrackerConfig
from eigmotion.validation import (
    Interval,
    Options,
    SequenceOf,
    describe,
    is_valid,
    validate,
    validate_params,
)

# -- what each kind of constraint accepts -------------------------------------------------


@pytest.mark.parametrize(
    ("constraint", "good", "bad"),
    [
        (Interval(Integral, 8, 512), [8, 512, 100, np.int64(9), np.uint8(8)], [7, 513, 9.0]),
        (Interval(Integral, 1, None), [1, 10**12], [0, -1, 1.5, "3", None]),
        (Interval(Integral, None, 0), [0, -5], [1]),
        (Interval(Real, 0.3, 4), [0.3, 4, 1, np.float32(2.5), Fraction(1, 2)], [0.29, 4.01]),
        (Interval(Real, 0, 0.5, closed="left"), [0, 0.49], [0.5, -1e-9]),
        (Interval(Real, 0, 1, closed="right"), [1, 1e-9], [0, 1.01]),
        (Interval(Real, 0, 1, closed="neither"), [0.5], [0, 1]),
        (Interval(Real, 0, None, closed="neither"), [1e-300, 1e300], [0, -1]),
        (Interval(Real, None, None), [0, -1e300, 7], ["1", None, 1j]),
        (Options(str, ["a", "b"]), ["a", "b", np.str_("a")], ["c", 1, None, ["a"]]),
        (SequenceOf(Interval(Real, 0.2, 5)), [(1.0,), [0.2, 5], np.array([1.0, 2.0])], []),
        (
            SequenceOf(Interval(Real, 0.2, 5)),
            [],
            [(), [], (0.1,), "ab", 1.0, np.ones((1, 1)), (1.0, float("nan")), (True,)],
        ),
        ([None, Interval(Integral, 1, None)], [None, 1], [0, "None"]),
    ],
)
def test_constraint_accepts_and_refuses(constraint, good, bad):
    for value in good:
        assert is_valid(value, constraint), value
        validate("p", value, constraint)
    for value in bad:
        assert not is_valid(value, constraint), value
        with pytest.raises(InvalidParameterError, match="^p must be "):
            validate("p", value, constraint)


@pytest.mark.parametrize("value", [True, False, np.bool_(True)])
@pytest.mark.parametrize("kind", [Integral, Real])
def test_bools_are_not_numbers(kind, value):
    assert not is_valid(value, Interval(kind, None, None))
    assert not is_valid(value, Interval(kind, 0, 1))


@pytest.mark.parametrize("value", [float("nan"), float("inf"), -np.inf, np.float32("nan")])
def test_nan_and_infinity_are_refused(value):
    assert not is_valid(value, Interval(Real, None, None))
    assert not is_valid(value, Interval(Real, 0, None, closed="neither"))


def test_integers_only_for_integral():
    assert not is_valid(3.0, Interval(Integral, 1, 5))
    assert is_valid(3.0, Interval(Real, 1, 5))


# -- the words ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("constraint", "text"),
    [
        (Interval(Integral, 8, 512), "an integer in [8, 512]"),
        (Interval(Integral, 1, None), "an integer >= 1"),
        (Interval(Integral, 1, None, closed="neither"), "an integer > 1"),
        (Interval(Integral, None, 9), "an integer <= 9"),
        (Interval(Integral, None, 9, closed="left"), "an integer < 9"),
        (Interval(Real, 0.3, 4.0), "a number in [0.3, 4]"),
        (Interval(Real, 1e-6, 0.5), "a number in [1e-06, 0.5]"),
        (Interval(Real, 0, 0.5, closed="left"), "a number in [0, 0.5)"),
        (Interval(Real, 0, 1, closed="right", noun=""), "in (0, 1]"),
        (Interval(Real, 0, 1, closed="neither"), "a number in (0, 1)"),
        (Interval(Real, 0, None, closed="neither", noun=""), "> 0"),
        (Interval(Real, 0, None, noun=""), ">= 0"),
        (Interval(Real, None, None), "a number"),
        (Interval(Real, 0.3, 3, noun="a factor"), "a factor in [0.3, 3]"),
        (Interval(Integral, 1, None, description="a positive integer"), "a positive integer"),
        (Options(str, ["a", "b"]), "one of ['a', 'b']"),
        (Options(str, ("a", "b")), "one of ('a', 'b')"),
        (SequenceOf(Interval(Real, 0.2, 5, noun="factors")), "factors in [0.2, 5]"),
        (None, "None"),
        ([Interval(Integral, 1, None), None], "an integer >= 1 or None"),
        ([None, Interval(Real, 0, 1, closed="right", noun="")], "None or in (0, 1]"),
    ],
)
def test_descriptions(constraint, text):
    assert describe(constraint) == text


def test_message_names_parameter_range_and_value():
    with pytest.raises(InvalidParameterError) as info:
        validate("size", 3, Interval(Integral, 8, 512))
    assert str(info.value) == "size must be an integer in [8, 512], got 3"
    with pytest.raises(InvalidParameterError) as info:
        validate("frame", "world", Options(str, ["image", "person"]))
    assert str(info.value) == "frame must be one of ['image', 'person'], got 'world'"


def test_validate_params_reads_objects_and_mappings_in_order():
    constraints = {"a": Interval(Integral, 0, None), "b": Interval(Real, 0, 1)}
    validate_params({"a": 1, "b": 0.5, "c": "ignored"}, constraints)
    with pytest.raises(InvalidParameterError, match=r"^a must be an integer >= 0, got -1$"):
        validate_params({"a": -1, "b": 2.0}, constraints)

    class Params:
        a = 2
        b = 2.0

    with pytest.raises(InvalidParameterError, match=r"^thing: b must be a number in \[0, 1\]"):
        validate_params(Params(), constraints, context="thing: ")


@pytest.mark.parametrize(
    "make",
    [
        lambda: Interval(int, 0, 1),
        lambda: Interval(Real, 0, 1, closed="open"),
        lambda: Interval(Real, 2, 1),
        lambda: Options(str, []),
        lambda: Options(str, {"a", "b"}),
    ],
)
def test_bad_constraints_are_programming_errors(make):
    with pytest.raises(ValueError):
        make()


# -- the classes that declare their constraints -------------------------------------------


@pytest.mark.parametrize(
    "cls",
    [
        SilhouetteConfig,
        MotionImageConfig,
        BuildConfig,
        TrackerConfig,
        ContinuousPoseConfig,
        Eigenspace,
        Quantizer,
    ],
)
def test_defaults_meet_the_declared_constraints(cls):
    instance = cls()
    for name, constraint in cls._parameter_constraints.items():
        assert is_valid(getattr(instance, name), constraint), (cls.__name__, name)


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda: MotionImageConfig(size=3), "size must be an integer in [8, 512], got 3"),
        (
            lambda: MotionImageConfig(log_sigma_px=0.0),
            "log_sigma_px must be a number in [0.3, 4], got 0.0",
        ),
        (
            lambda: SilhouetteConfig(high_factor=2.0),
            "high_factor must be a number in [3, 100], got 2.0",
        ),
        (lambda: BuildConfig(window_s=0.0), "window_s must be > 0, got 0.0"),
        (
            lambda: BuildConfig(n_components=0),
            "n_components must be a positive integer or None, got 0",
        ),
        (
            lambda: TrackerConfig(body_scale=5.0),
            "body_scale must be None or a factor in [0.3, 3], got 5.0",
        ),
        (lambda: TrackerConfig(layer_step=0), "layer_step must be an integer >= 1, got 0"),
        (
            lambda: ContinuousPoseConfig(scales=(0.1,)),
            "scales must be factors in [0.2, 5], got (0.1,)",
        ),
        (
            lambda: Quantizer(n_sections=1).fit(np.zeros((2, 4))),
            "n_sections (R) must be an integer >= 2, got 1",
        ),
        (
            lambda: Eigenspace(explained_variance=1.5).fit(np.eye(3)),
            "explained_variance must be in (0, 1], got 1.5",
        ),
    ],
)
def test_configuration_messages(make, message):
    with pytest.raises(InvalidParameterError) as info:
        make()
    assert str(info.value) == message
