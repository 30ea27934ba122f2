"""Arrays stored in ``.npz`` files (masks, joints, dictionaries), read with care.

:func:`read_npz` opens the archive itself, reads each array's header first and refuses
object arrays and arrays larger than :data:`~eigmotion.limits.MAX_NPZ_ARRAY_BYTES`
before reading any data; whatever is wrong with the file (not a zip, truncated, a
``.npy`` renamed, a damaged member) becomes one :class:`~eigmotion.errors.VideoError`
naming the file.
"""

from __future__ import annotations

import math
import os
import zipfile
from pathlib import Path

import numpy as np

from eigmotion.errors import EigmotionError, InvalidParameterError, VideoError
from eigmotion.limits import MAX_NPZ_ARRAY_BYTES


def read_npz(
    path: str | os.PathLike, max_bytes: int = MAX_NPZ_ARRAY_BYTES
) -> dict[str, np.ndarray]:
    """Every array of an ``.npz`` file.

    Parameters
    ----------
    path : str or PathLike
    max_bytes : int
        Largest array accepted, bytes (from its header, before it is read).

    Returns
    -------
    dict of str to ndarray
        Keyed by the names ``np.savez`` was given.

    Raises
    ------
    VideoError
        Missing file, not an ``.npz`` archive, or a damaged one.
    InvalidParameterError
        An object (pickled) array, or an array larger than ``max_bytes``.
    """
    path = Path(path)
    if not path.is_file():
        raise VideoError(f"{path}: no such file")
    if not zipfile.is_zipfile(path):
        raise VideoError(f"{path}: not a readable .npz (not a zip archive of .npy arrays)")
    arrays = {}
    try:
        with zipfile.ZipFile(path) as archive:
            for member in archive.namelist():
                if not member.endswith(".npy"):
                    continue
                arrays[member[: -len(".npy")]] = _read_member(archive, member, path, max_bytes)
    except EigmotionError:
        raise
    except Exception as exc:  # noqa: BLE001 - zipfile/zlib/numpy raise many kinds here
        reason = str(exc) or type(exc).__name__
        raise VideoError(f"{path}: not a readable .npz ({reason})") from None
    return arrays


def _read_member(archive: zipfile.ZipFile, member: str, path: Path, max_bytes: int) -> np.ndarray:
    fmt = np.lib.format
    with archive.open(member) as stream:
        version = fmt.read_magic(stream)
        if version == (1, 0):
            shape, fortran_order, dtype = fmt.read_array_header_1_0(stream)
        else:
            shape, fortran_order, dtype = fmt.read_array_header_2_0(stream)
    if dtype.hasobject:
        raise InvalidParameterError(
            f"{path}: array {member!r} holds Python objects; only numbers are read"
        )
    n_bytes = math.prod(shape) * dtype.itemsize
    if n_bytes > max_bytes:
        raise InvalidParameterError(
            f"{path}: array {member!r} of shape {shape} takes {n_bytes / 2**20:,.0f} MiB; "
            f"at most {max_bytes / 2**20:,.0f} MiB are read"
        )
    with archive.open(member) as stream:
        return fmt.read_array(stream, allow_pickle=False)


def scalar(value: np.ndarray, what: str) -> float:
    """A stored scalar (a 0-d or one-element real array) as a float.

    Raises
    ------
    InvalidParameterError
        Several values, none, or not a real number (complex, text, bool).
    """
    array = np.asarray(value)
    if array.size != 1 or not (
        np.issubdtype(array.dtype, np.integer) or np.issubdtype(array.dtype, np.floating)
    ):
        raise InvalidParameterError(
            f"{what} must be one real number, got a {array.dtype} array of shape {array.shape}"
        )
    return float(array.reshape(()))
