"""Declared constraints on parameters, shared by the configurations and the estimators.

A class lists the valid values of its parameters in one class-level mapping, in the
manner of scikit-learn's ``_parameter_constraints``, and checks them all at once::

    class MotionImageConfig:
        _parameter_constraints = {
            "size": Interval(Integral, 8, 512),
            "frame": Options(str, ["image", "person"]),
            ...
        }

        def __post_init__(self):
            validate_params(self, self._parameter_constraints)

A constraint is one of

* :class:`Interval`: integers or finite real numbers between two bounds;
* :class:`Options`: one of a few values;
* :class:`SequenceOf`: a non-empty list or tuple of values that each meet a constraint;
* ``None``: the value ``None``;
* a list of these: any one of them.

:func:`validate` and :func:`validate_params` raise
:class:`~eigmotion.errors.InvalidParameterError` with a message that names the
parameter, what it must be and the value it got::

    size must be an integer in [8, 512], got 3
    log_sigma_px must be a number in [0.3, 4], got 0.0
    n_components must be a positive integer or None, got 0

Checks that relate two parameters (``lo < hi``, a bound that depends on another
parameter) are left to the class, after the declared ones.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from numbers import Integral, Real

import numpy as np

from eigmotion.errors import InvalidParameterError

__all__ = [
    "Constraint",
    "Interval",
    "Options",
    "SequenceOf",
    "describe",
    "is_valid",
    "validate",
    "validate_params",
]

_CLOSED = ("both", "left", "right", "neither")


class Constraint:
    """A set of valid values, and the words that describe it in a message.

    Subclasses define :meth:`is_satisfied_by` and :meth:`__str__`; the text completes
    ``"{name} must be ..."``.
    """

    def is_satisfied_by(self, value) -> bool:
        """Whether ``value`` is valid."""
        raise NotImplementedError

    def __str__(self) -> str:
        raise NotImplementedError

    def __repr__(self) -> str:
        return f"<{type(self).__name__}: {self}>"


class Interval(Constraint):
    """Numbers of one kind between two bounds.

    Parameters
    ----------
    type : {numbers.Integral, numbers.Real}
        ``Integral``: integers (``int`` and NumPy integers), never a ``bool``.
        ``Real``: finite real numbers (ints, floats and their NumPy kinds), never a
        ``bool``, NaN or infinity.
    left, right : float or None
        The bounds; ``None``: unbounded on that side.
    closed : {"both", "left", "right", "neither"}
        Which bounds belong to the interval.
    noun : str, optional
        What the value is, put before the bounds in the description; by default
        ``"an integer"`` or ``"a number"``, ``""`` for none.
    description : str, optional
        The whole description instead (``"a positive integer"``).

    Notes
    -----
    The description is the noun followed by ``in [left, right]`` (brackets as
    closed), or by ``>= left``, ``> left``, ``<= right`` or ``< right`` when one side is
    unbounded.  Integer bounds are written as they are, real ones with ``:g``:
    ``Interval(Real, 0.3, 4)`` is ``"a number in [0.3, 4]"``, ``Interval(Real, 0, None,
    closed="neither", noun="")`` is ``"> 0"``.
    """

    def __init__(
        self,
        type: type,
        left: float | None,
        right: float | None,
        *,
        closed: str = "both",
        noun: str | None = None,
        description: str | None = None,
    ):
        if type not in (Integral, Real):
            raise ValueError(f"type must be numbers.Integral or numbers.Real, got {type!r}")
        if closed not in _CLOSED:
            raise ValueError(f"closed must be one of {list(_CLOSED)}, got {closed!r}")
        if left is not None and right is not None and right < left:
            raise ValueError(f"right ({right}) is below left ({left})")
        self.type = type
        self.left = left
        self.right = right
        self.closed = closed
        self.noun = ("an integer" if type is Integral else "a number") if noun is None else noun
        self.description = description

    def is_satisfied_by(self, value) -> bool:
        if isinstance(value, bool | np.bool_) or not isinstance(value, self.type):
            return False
        if self.type is Real and not math.isfinite(value):
            return False
        left_closed = self.closed in ("both", "left")
        right_closed = self.closed in ("both", "right")
        if self.left is not None and not (value >= self.left if left_closed else value > self.left):
            return False
        if self.right is not None and not (
            value <= self.right if right_closed else value < self.right
        ):
            return False
        return True

    def _bound(self, bound: float) -> str:
        return str(bound) if self.type is Integral else f"{bound:g}"

    def __str__(self) -> str:
        if self.description is not None:
            return self.description
        left_closed = self.closed in ("both", "left")
        right_closed = self.closed in ("both", "right")
        if self.left is not None and self.right is not None:
            bounds = (
                f"in {'[' if left_closed else '('}{self._bound(self.left)}, "
                f"{self._bound(self.right)}{']' if right_closed else ')'}"
            )
        elif self.left is not None:
            bounds = f"{'>=' if left_closed else '>'} {self._bound(self.left)}"
        elif self.right is not None:
            bounds = f"{'<=' if right_closed else '<'} {self._bound(self.right)}"
        else:
            bounds = ""
        return f"{self.noun} {bounds}".strip()


class Options(Constraint):
    """One of a few values.

    Parameters
    ----------
    type : type
        The type every valid value has (``str``).
    options : list or tuple
        The valid values, written in the description as given: ``Options(str,
        ["a", "b"])`` is ``"one of ['a', 'b']"``, ``Options(str, ("a", "b"))`` is
        ``"one of ('a', 'b')"``.
    """

    def __init__(self, type: type, options: Sequence):
        if not isinstance(options, list | tuple) or not options:
            raise ValueError(f"options must be a non-empty list or tuple, got {options!r}")
        self.type = type
        self.options = tuple(options)
        self._shown = repr(options)

    def is_satisfied_by(self, value) -> bool:
        return isinstance(value, self.type) and value in self.options

    def __str__(self) -> str:
        return f"one of {self._shown}"


class SequenceOf(Constraint):
    """A non-empty list, tuple or 1-D array whose items all meet one constraint.

    Parameters
    ----------
    items : constraint
        What each item must be; its description is this constraint's (give it a
        plural noun: ``SequenceOf(Interval(Real, 0.2, 5, noun="factors"))`` is
        ``"factors in [0.2, 5]"``).
    """

    def __init__(self, items):
        self.items = items

    def is_satisfied_by(self, value) -> bool:
        if isinstance(value, np.ndarray):
            if value.ndim != 1:
                return False
        elif not isinstance(value, list | tuple):
            return False
        return len(value) > 0 and all(is_valid(item, self.items) for item in value)

    def __str__(self) -> str:
        return describe(self.items)


def _alternatives(constraint) -> list:
    return list(constraint) if isinstance(constraint, list) else [constraint]


def is_valid(value, constraint) -> bool:
    """Whether ``value`` meets ``constraint`` (a constraint, ``None`` or a list of them)."""
    for option in _alternatives(constraint):
        if option is None:
            if value is None:
                return True
        elif option.is_satisfied_by(value):
            return True
    return False


def describe(constraint) -> str:
    """The words for ``constraint`` in a message: alternatives joined by ``" or "``."""
    return " or ".join(
        "None" if option is None else str(option) for option in _alternatives(constraint)
    )


def validate(name: str, value, constraint) -> None:
    """Check one parameter.

    Parameters
    ----------
    name : str
        The parameter's name, as the message gives it.
    value : object
    constraint : Constraint, None or list of them
        A list accepts a value that meets any one of its items; ``None`` accepts
        ``None``.

    Raises
    ------
    InvalidParameterError
        ``"{name} must be {description}, got {value!r}"``.
    """
    if not is_valid(value, constraint):
        raise InvalidParameterError(f"{name} must be {describe(constraint)}, got {value!r}")


def validate_params(params, constraints: Mapping[str, object], *, context: str = "") -> None:
    """Check several parameters, in the order of ``constraints``.

    Parameters
    ----------
    params : object or mapping
        Where the values are: a mapping's items, or else an object's attributes.
    constraints : mapping of str to constraint
        Parameter name → its constraint (see :func:`validate`).
    context : str
        Put before the parameter's name in the message (``"garment 'x': "``).

    Raises
    ------
    InvalidParameterError
        On the first parameter that fails its constraint (see :func:`validate`).
    """
    for name, constraint in constraints.items():
        value = params[name] if isinstance(params, Mapping) else getattr(params, name)
        validate(f"{context}{name}", value, constraint)
