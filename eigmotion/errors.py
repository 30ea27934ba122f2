"""The project's exception hierarchy.

Every error a user can cause derives from :class:`EigmotionError` and also from a
built-in exception type, so callers may catch either.  The command line turns any
``EigmotionError`` into one line on stderr and exit code 2.
"""

from __future__ import annotations

from pathlib import Path


class EigmotionError(Exception):
    """Base class of every error raised on bad input or misuse."""


class MotionFormatError(EigmotionError, ValueError):
    """A motion file (BVH, ASF, AMC) that cannot be parsed.

    Parameters
    ----------
    message : str
        What is wrong and what was expected.
    path : str or Path, optional
        The file being read.
    line : int, optional
        1-based line number where the problem was found.
    """

    def __init__(self, message: str, path: str | Path | None = None, line: int | None = None):
        self.path = None if path is None else str(path)
        self.line = line
        where = ""
        if self.path is not None:
            where = self.path if line is None else f"{self.path}:{line}"
            where += ": "
        elif line is not None:
            where = f"line {line}: "
        super().__init__(f"{where}{message}")


class SkeletonMappingError(EigmotionError, KeyError):
    """Joint names that cannot be mapped onto the canonical skeleton."""

    def __str__(self) -> str:  # KeyError would repr() the message
        return str(self.args[0]) if self.args else ""


class InvalidParameterError(EigmotionError, ValueError):
    """A parameter outside its valid range (the message names both)."""


class NotFittedError(EigmotionError, AttributeError):
    """An estimator used before ``fit``."""


class VideoError(EigmotionError, ValueError):
    """A clip that cannot be read or holds no usable person."""


class StillPersonError(VideoError):
    """A person found in the clip who does not move enough to give a motion image.

    Not a fault of the clip: ``eigmotion query`` answers it as no motion of the library
    (:func:`~eigmotion.retrieval.results.still_answer_json`).  The message says how much
    the silhouettes changed against the least a motion needs.
    """


class SceneMismatchError(VideoError):
    """Frames that differ from the empty scene they are compared with over most of the
    picture: an image of another scene, a moving camera, or a cut to another shot.

    Parameters
    ----------
    message : str
    difference : float
        The frames' median colour difference from the scene, ΔE.
    """

    def __init__(self, message: str, difference: float):
        super().__init__(message)
        self.difference = difference


class DatabaseError(EigmotionError, RuntimeError):
    """A motion database that is missing, of another schema, or inconsistent."""


class ClusterError(EigmotionError, ConnectionError):
    """A Dask scheduler that cannot be reached or has no workers, or Dask not installed."""
