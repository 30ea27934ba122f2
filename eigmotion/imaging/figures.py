"""Figures: contact sheets, side-by-side videos and image files.

Every function takes images in any of the forms the pipeline produces and returns RGB
``uint8``:

* ``(H, W, 3)`` uint8 — RGB;
* ``(H, W)`` uint8 — grey;
* ``(H, W)`` or ``(H, W, 3)`` bool — masks, ``True`` white;
* ``(H, W)`` or ``(H, W, 3)`` float — intensities in [0, 1] (clipped), e.g. a motion
  image.

Text is drawn with OpenCV's Hershey font (ASCII only; other characters become ``?``).
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np
from PIL import Image

from eigmotion.errors import InvalidParameterError

#: Background of sheets and title bands (RGB), and the colour of text on it.
SHEET_RGB = (255, 255, 255)
TEXT_RGB = (20, 20, 20)

_FONT_HEIGHT_FRACTION = 0.07  # label text height as a fraction of the cell width


def to_rgb8(image: np.ndarray) -> np.ndarray:
    """One image as RGB uint8.

    Parameters
    ----------
    image : (H, W), (H, W, 1), (H, W, 3) or (H, W, 4) array
        uint8, bool (``True`` white) or float in [0, 1]; an alpha channel is dropped.

    Returns
    -------
    (H, W, 3) uint8

    Raises
    ------
    InvalidParameterError
        Another shape or dtype.
    """
    image = np.asarray(image)
    if image.ndim == 3 and image.shape[2] == 1:
        image = image[..., 0]
    elif image.ndim == 3 and image.shape[2] == 4:
        image = image[..., :3]
    if image.ndim not in (2, 3) or (image.ndim == 3 and image.shape[2] != 3):
        raise InvalidParameterError(
            f"an image must have shape (H, W) or (H, W, 3), got {image.shape}"
        )
    if image.shape[0] == 0 or image.shape[1] == 0:
        raise InvalidParameterError(f"an image must not be empty, got shape {image.shape}")
    if image.dtype == np.bool_:
        image = image.astype(np.uint8) * np.uint8(255)
    elif np.issubdtype(image.dtype, np.floating):
        image = np.round(np.clip(np.nan_to_num(image), 0.0, 1.0) * 255.0).astype(np.uint8)
    elif image.dtype != np.uint8:
        raise InvalidParameterError(
            f"an image must be uint8, bool or float in [0, 1], got dtype {image.dtype}"
        )
    if image.ndim == 2:
        image = np.repeat(image[..., None], 3, axis=2)
    return np.ascontiguousarray(image)


def _text_scale(cell_width_px: int) -> tuple[float, int, int]:
    """(font scale, thickness, band height px) for labels under a cell this wide."""
    target_px = max(8.0, _FONT_HEIGHT_FRACTION * cell_width_px)
    (_, base_h), _ = cv2.getTextSize("Hg", cv2.FONT_HERSHEY_SIMPLEX, 1.0, 1)
    scale = target_px / base_h
    thickness = max(1, int(round(scale)))
    return scale, thickness, int(math.ceil(target_px * 1.9)) + 2


def _draw_text(
    canvas: np.ndarray,
    text: str,
    x0: int,
    y0: int,
    width: int,
    height: int,
    scale: float,
    thickness: int,
) -> None:
    """Draw ``text`` centred in the box (x0, y0, width, height), shrunk to fit."""
    text = text.encode("ascii", "replace").decode("ascii")
    font = cv2.FONT_HERSHEY_SIMPLEX
    (w, h), base = cv2.getTextSize(text, font, scale, thickness)
    if w > width - 4 and w > 0:
        scale *= (width - 4) / w
        (w, h), base = cv2.getTextSize(text, font, scale, thickness)
    x = x0 + max(0, (width - w) // 2)
    y = y0 + (height + h) // 2
    cv2.putText(canvas, text, (x, y), font, scale, TEXT_RGB, thickness, cv2.LINE_AA)


def contact_sheet(
    images: Sequence[np.ndarray],
    n_cols: int = 4,
    labels: Sequence[str] | None = None,
    title: str | None = None,
    pad_px: int = 4,
) -> np.ndarray:
    """Images on a grid, row by row, with optional labels and a title.

    Parameters
    ----------
    images : sequence of (Hi, Wi[, 3]) arrays
        Any form :func:`to_rgb8` accepts.  Each is centred in a cell of the largest
        height and width.
    n_cols : int
        Cells per row (fewer if there are fewer images).
    labels : sequence of str, optional
        One per image, written in a band under it.
    title : str, optional
        Written in a band above the grid.
    pad_px : int
        Gap between cells and around the grid, pixels.

    Returns
    -------
    (H, W, 3) uint8
        With ``rows = ceil(n / cols)``, ``cols = min(n_cols, n)``, cell size ``(h, w)``
        and label band ``b`` (0 without labels): ``W = cols * w + (cols + 1) * pad_px``
        and ``H = rows * (h + b) + (rows + 1) * pad_px`` plus the title band.

    Raises
    ------
    InvalidParameterError
        No images, bad images, ``n_cols < 1``, ``pad_px < 0`` or a label count that
        differs from the image count.
    """
    if len(images) == 0:
        raise InvalidParameterError("contact_sheet needs at least one image")
    if int(n_cols) < 1:
        raise InvalidParameterError(f"n_cols must be >= 1, got {n_cols}")
    if int(pad_px) < 0:
        raise InvalidParameterError(f"pad_px must be >= 0, got {pad_px}")
    if labels is not None and len(labels) != len(images):
        raise InvalidParameterError(
            f"labels must hold one string per image: {len(labels)} labels for {len(images)} images"
        )
    rgb = [to_rgb8(im) for im in images]
    n = len(rgb)
    cols = min(int(n_cols), n)
    rows = math.ceil(n / cols)
    pad = int(pad_px)
    cell_h = max(im.shape[0] for im in rgb)
    cell_w = max(im.shape[1] for im in rgb)
    scale, thickness, band = _text_scale(cell_w)
    label_h = band if labels is not None else 0
    title_h = band if title else 0
    height = title_h + rows * (cell_h + label_h) + (rows + 1) * pad
    width = cols * cell_w + (cols + 1) * pad
    sheet = np.empty((height, width, 3), dtype=np.uint8)
    sheet[:] = SHEET_RGB
    if title:
        _draw_text(sheet, title, 0, 0, width, title_h, scale, thickness)
    for i, im in enumerate(rgb):
        r, c = divmod(i, cols)
        y0 = title_h + pad + r * (cell_h + label_h + pad)
        x0 = pad + c * (cell_w + pad)
        dy, dx = (cell_h - im.shape[0]) // 2, (cell_w - im.shape[1]) // 2
        sheet[y0 + dy : y0 + dy + im.shape[0], x0 + dx : x0 + dx + im.shape[1]] = im
        if labels is not None:
            _draw_text(sheet, str(labels[i]), x0, y0 + cell_h, cell_w, label_h, scale, thickness)
    return sheet


def _as_clip(panel: np.ndarray, index: int) -> np.ndarray:
    """(F, H, W[, C]) panel → (F, H, W, 3) uint8."""
    panel = np.asarray(panel)
    if panel.ndim not in (3, 4) or panel.shape[0] < 1:
        raise InvalidParameterError(
            f"panel {index} must have shape (F, H, W, 3) or (F, H, W) with F >= 1 (a still "
            f"image is image[None]), got {panel.shape}"
        )
    return np.stack([to_rgb8(frame) for frame in panel])


def _resize(image: np.ndarray, height: int, width: int) -> np.ndarray:
    if image.shape[:2] == (height, width):
        return image
    shrink = height < image.shape[0]
    interpolation = cv2.INTER_AREA if shrink else cv2.INTER_LINEAR
    return cv2.resize(image, (width, height), interpolation=interpolation)


def side_by_side(
    panels: Sequence[np.ndarray],
    titles: Sequence[str] | None = None,
    height_px: int | None = None,
    pad_px: int = 4,
) -> np.ndarray:
    """Clips next to each other, scaled to one height and stretched to one timeline.

    Used for input | silhouettes | motion image | replay comparisons.

    Parameters
    ----------
    panels : sequence of (Fi, Hi, Wi, 3) or (Fi, Hi, Wi) arrays
        Clips (any dtype :func:`to_rgb8` accepts; 3-D arrays are clips of grey images
        or masks).  A panel of one frame (a still image, ``image[None]``) is shown in
        every frame.
    titles : sequence of str, optional
        One per panel, written in a band above it.
    height_px : int, optional
        Common panel height; default the tallest panel's.  Widths keep each panel's
        aspect ratio.
    pad_px : int
        Gap between panels and around them, pixels.

    Returns
    -------
    (F, H, W, 3) uint8
        ``F = max Fi``.  Output frame ``f`` shows frame ``round(f (Fi - 1) / (F - 1))``
        of panel ``i``, so clips of different lengths (or frame rates) covering the
        same time span stay aligned.

    Raises
    ------
    InvalidParameterError
        No panels, bad panel shapes, a title count that differs from the panel count,
        or a non-positive height.
    """
    if len(panels) == 0:
        raise InvalidParameterError("side_by_side needs at least one panel")
    if titles is not None and len(titles) != len(panels):
        raise InvalidParameterError(
            f"titles must hold one string per panel: {len(titles)} titles for {len(panels)} panels"
        )
    if int(pad_px) < 0:
        raise InvalidParameterError(f"pad_px must be >= 0, got {pad_px}")
    clips = [_as_clip(p, i) for i, p in enumerate(panels)]
    height = int(height_px) if height_px is not None else max(c.shape[1] for c in clips)
    if height < 1:
        raise InvalidParameterError(f"height_px must be >= 1, got {height_px}")
    widths = [max(1, int(round(c.shape[2] * height / c.shape[1]))) for c in clips]
    n_frames = max(c.shape[0] for c in clips)
    pad = int(pad_px)
    scale, thickness, band = _text_scale(min(widths))
    title_h = band if titles is not None else 0
    out_h = title_h + height + 2 * pad
    out_w = sum(widths) + (len(clips) + 1) * pad
    out = np.empty((n_frames, out_h, out_w, 3), dtype=np.uint8)
    out[:] = SHEET_RGB
    x0 = pad
    for i, (clip, width) in enumerate(zip(clips, widths, strict=True)):
        if titles is not None:
            _draw_text(out[0], str(titles[i]), x0, 0, width, title_h, scale, thickness)
        resized = {}
        for f, s in enumerate(stretched_frames(n_frames, clip.shape[0])):
            if s not in resized:
                resized = {s: _resize(clip[s], height, width)}  # frames come in order
            out[f, title_h + pad : title_h + pad + height, x0 : x0 + width] = resized[s]
        x0 += width + pad
    if titles is not None and n_frames > 1:
        out[1:, :title_h] = out[0, :title_h]
    return out


def stretched_frames(n_out: int, n_in: int) -> np.ndarray:
    """(n_out,) int: the frame of a clip of ``n_in`` frames that each of ``n_out``
    frames covering the same time span shows, ``round(f (n_in - 1) / (n_out - 1))``
    (as :func:`side_by_side` stretches its panels)."""
    return np.round(np.arange(n_out) * (n_in - 1) / max(n_out - 1, 1)).astype(np.int64)


def with_captions(frames: np.ndarray, captions: Sequence[str]) -> np.ndarray:
    """A video with a band under it that says what each frame shows.

    Parameters
    ----------
    frames : (F, H, W, 3) uint8
        RGB frames (e.g. :func:`side_by_side`'s).
    captions : sequence of F str
        One per frame; an empty one leaves the band blank.

    Returns
    -------
    (F, H + band, W, 3) uint8
        The band is :data:`SHEET_RGB`, as tall as :func:`side_by_side`'s titles for a
        panel a quarter of the width.

    Raises
    ------
    InvalidParameterError
        Frames of another shape or dtype, or a caption count that is not the frame
        count.
    """
    frames = np.asarray(frames)
    if frames.ndim != 4 or frames.shape[3] != 3 or frames.dtype != np.uint8:
        raise InvalidParameterError(
            f"frames must be (F, H, W, 3) uint8, got {frames.dtype} {frames.shape}"
        )
    if len(captions) != len(frames):
        raise InvalidParameterError(
            f"captions must hold one string per frame: {len(captions)} for {len(frames)} frames"
        )
    n, h, w, _ = frames.shape
    scale, thickness, band = _text_scale(w // 4)
    out = np.empty((n, h + band, w, 3), np.uint8)
    out[:, :h] = frames
    out[:, h:] = SHEET_RGB
    drawn: dict[str, np.ndarray] = {}
    for f, caption in enumerate(captions):
        if caption not in drawn:
            strip = np.empty((band, w, 3), np.uint8)
            strip[:] = SHEET_RGB
            _draw_text(strip, caption, 0, 0, w, band, scale, thickness)
            drawn = {caption: strip}  # captions come in runs
        out[f, h:] = drawn[caption]
    return out


def save_image(image: np.ndarray, path: str | os.PathLike) -> Path:
    """Write one image (PNG, JPEG, …, by extension), creating parent folders.

    Parameters
    ----------
    image : (H, W[, 3]) array
        Any form :func:`to_rgb8` accepts.
    path : str or PathLike

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    InvalidParameterError
        A bad image, or an extension Pillow cannot write.
    """
    path = Path(path)
    rgb = to_rgb8(image)
    extensions = Image.registered_extensions()
    if path.suffix.lower() not in extensions or extensions[path.suffix.lower()] not in Image.SAVE:
        raise InvalidParameterError(
            f"{path}: cannot write images of type {path.suffix or '(no extension)'!r}; "
            "use .png or .jpg"
        )
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(rgb).save(path)
    return path
