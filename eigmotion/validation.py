"""Checks of scalar parameters, shared by the configurations and entry points.

Each raises :class:`~eigmotion.errors.InvalidParameterError` with a message that names
the parameter, the range it must lie in and the value it got.
"""

from __future__ import annotations

import math

import numpy as np

from eigmotion.errors import InvalidParameterError


def check_int(name: str, value, lo: int, hi: int) -> None:
    """An integer (not a bool) in ``[lo, hi]``.

    Raises
    ------
    InvalidParameterError
        ``"{name} must be an integer in [lo, hi], got {value!r}"``.
    """
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or not lo <= value <= hi:
        raise InvalidParameterError(f"{name} must be an integer in [{lo}, {hi}], got {value!r}")


def check_real(name: str, value, lo: float, hi: float, hi_open: bool = False) -> None:
    """A finite real number (not a bool) in ``[lo, hi]``, or ``[lo, hi)`` with ``hi_open``.

    Raises
    ------
    InvalidParameterError
        ``"{name} must be a number in [lo, hi], got {value!r}"`` (``hi)`` when open).
    """
    ok = isinstance(value, int | float | np.integer | np.floating) and not isinstance(value, bool)
    ok = ok and math.isfinite(value) and lo <= value and (value < hi if hi_open else value <= hi)
    if not ok:
        bracket = ")" if hi_open else "]"
        raise InvalidParameterError(
            f"{name} must be a number in [{lo:g}, {hi:g}{bracket}, got {value!r}"
        )


def check_in_range(name: str, value: float, lo: float, hi: float) -> None:
    """Any value ``np.isfinite`` takes (a bool or a NumPy scalar too) that is finite
    and in ``[lo, hi]``.

    Raises
    ------
    InvalidParameterError
        ``"{name} must be in [lo, hi], got {value!r}"``.
    """
    if not (np.isfinite(value) and lo <= value <= hi):
        raise InvalidParameterError(f"{name} must be in [{lo:g}, {hi:g}], got {value!r}")


def check_choice(name: str, value, choices: tuple[str, ...]) -> None:
    """One of ``choices``.

    Raises
    ------
    InvalidParameterError
        ``"{name} must be one of [choices], got {value!r}"``.
    """
    if value not in choices:
        raise InvalidParameterError(f"{name} must be one of {list(choices)}, got {value!r}")
