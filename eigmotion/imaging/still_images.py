"""Still images: one image file read as RGB, and the images of a folder in frame order.

PNGs of 8-bit samples are read by OpenCV (already loaded by any clip; Pillow's import
costs a cold query about 18 ms), every other image by Pillow, imported only then.  Every
image's size is checked against :data:`~eigmotion.limits.MAX_FRAME_PIXELS` from its
header, before it is decoded.
"""

from __future__ import annotations

import os
import re
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np

from eigmotion.errors import EigmotionError, InvalidParameterError, VideoError
from eigmotion.limits import MAX_FRAME_PIXELS, check_frame_pixels

if TYPE_CHECKING:
    from PIL import Image

#: Extensions of the still images an image folder may hold.
IMAGE_EXTENSIONS = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp")

_NUMBER = re.compile(r"(\d+)")


@contextmanager
def opened_image(path: Path) -> Iterator[Image.Image]:
    """``Image.open(path)``, with Pillow's own decompression-bomb warning silenced and
    its error (an image far beyond :data:`~eigmotion.limits.MAX_FRAME_PIXELS`) turned
    into the same InvalidParameterError as any image beyond the limit."""
    from PIL import Image  # here: a video query never loads Pillow

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            image = Image.open(path)
    except Image.DecompressionBombError:
        raise InvalidParameterError(
            f"{path}: a frame of more than {2 * Image.MAX_IMAGE_PIXELS:,} pixels; at most "
            f"{MAX_FRAME_PIXELS / 1e6:g} million pixels per frame are read"
        ) from None
    with image:
        yield image


def pil_rgb(image: Image.Image, what: Path) -> np.ndarray:
    """An opened Pillow image (or GIF frame) as (H, W, 3) uint8, its size checked
    against :data:`~eigmotion.limits.MAX_FRAME_PIXELS` before it is decoded."""
    check_frame_pixels(image.width, image.height, str(what))
    return np.asarray(image.convert("RGB"))


def decoder_reason(exc: Exception) -> str:
    """What a decoder's exception says, or its type when it says nothing."""
    return str(exc) or type(exc).__name__


def _natural_key(name: str) -> list:
    return [int(part) if part.isdigit() else part.lower() for part in _NUMBER.split(name)]


def image_files(folder: str | os.PathLike) -> list[Path]:
    """The still images of a folder in frame order.

    Parameters
    ----------
    folder : str or PathLike

    Returns
    -------
    list of Path
        Files with an extension in :data:`IMAGE_EXTENSIONS`, sorted by name with digit
        runs compared as numbers; possibly empty.
    """
    folder = Path(folder)
    files = [p for p in folder.iterdir() if p.is_file() and p.suffix.lower() in IMAGE_EXTENSIONS]
    return sorted(files, key=lambda p: _natural_key(p.name))


def read_image_rgb(path: str | os.PathLike) -> np.ndarray:
    """Read one still image.

    Parameters
    ----------
    path : str or PathLike
        Any image Pillow reads (``.png``, ``.jpg``, ``.bmp``, ``.tif``, ``.webp`` …).

    Returns
    -------
    (H, W, 3) uint8
        RGB.

    Raises
    ------
    VideoError
        Not a readable image.
    InvalidParameterError
        More than :data:`~eigmotion.limits.MAX_FRAME_PIXELS` pixels (checked from the
        header, before decoding).
    """
    path = Path(path)
    try:
        plain = _read_plain_png(path)
        if plain is not None:
            return plain
        with opened_image(path) as image:
            return pil_rgb(image, path)
    except EigmotionError:
        raise
    except (FileNotFoundError, IsADirectoryError, PermissionError):
        raise
    except Exception as exc:  # noqa: BLE001 - Pillow raises many kinds on a damaged file
        raise VideoError(f"{path}: not a readable image ({decoder_reason(exc)})") from None


#: The first bytes of every PNG file, then its header chunk's length and name.
_PNG_START = b"\x89PNG\r\n\x1a\n\x00\x00\x00\x0dIHDR"


def _read_plain_png(path: Path) -> np.ndarray | None:
    """(H, W, 3) uint8 RGB of a PNG of 8-bit samples, read by OpenCV (already loaded:
    Pillow's import costs a cold query about 18 ms); ``None`` for any other file, a
    PNG of other samples or one OpenCV cannot read, which Pillow then reads.  The
    same pixels as Pillow's ``convert("RGB")``: grey replicated, palette expanded,
    alpha dropped.  The size is checked from the header before decoding."""
    with open(path, "rb") as file:
        head = file.read(len(_PNG_START) + 9)
    if len(head) < len(_PNG_START) + 9 or not head.startswith(_PNG_START):
        return None
    width = int.from_bytes(head[16:20], "big")
    height = int.from_bytes(head[20:24], "big")
    if head[24] != 8:  # bits per sample: 16-bit and packed images go through Pillow
        return None
    check_frame_pixels(width, height, str(path))
    bgr = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if bgr is None or bgr.shape[:2] != (height, width):
        return None
    return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)
