"""Calibrated cameras for the tracker: the JSON file, and checkerboard calibration.

The calibration file (JSON) holds one entry per camera, in OpenCV's convention
(world → camera: ``x_cam = R @ X_world + t``), metres, world Y up, the floor at
``y = 0``::

    {"cameras": [{"name": "left", "K": [[fx, 0, cx], [0, fy, cy], [0, 0, 1]],
                  "R": [[...], [...], [...]], "t": [tx, ty, tz],
                  "width": 320, "height": 240}, ...],
     "pairs": [{"cameras": [0, 1], "region": [x_min, z_min, x_max, z_max]}, ...]}

``pairs`` is optional: with more than two cameras, each pair of cameras owns a region
of the stage (a rectangle on the floor, metres) and the tracker uses the pair whose
region holds the person (see :mod:`eigmotion.tracking.position`).

Checkerboard calibration (:func:`calibrate_cameras`) finds each camera's intrinsics
from several views of a printed chessboard (OpenCV ``findChessboardCorners`` and
``calibrateCamera``, lens distortion fixed at zero because :class:`~eigmotion.imaging.cameras.
Camera` has no distortion model) and its extrinsics from one view of the board lying
flat on the floor, seen by every camera: that board defines the world frame.

World frame from the floor board: origin at the board's origin corner (the inner
corner next to the board's dark corner square), world X along the board's rows of
``pattern[0]`` corners, world Z along its columns, world Y up out of the board.  The
board must have one even and one odd number of inner corners (e.g. 9 × 6), so that
its two dark-or-light corner squares tell its two ends apart for every camera.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from eigmotion.errors import InvalidParameterError
from eigmotion.imaging.cameras import Camera

#: Board frame (x along rows, y along columns, z into the board seen from the front)
#: → world frame (x along rows, y up, z along columns).
BOARD_TO_WORLD = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


@dataclass(frozen=True, eq=False)
class CameraPair:
    """Two cameras that together cover one region of the stage.

    Parameters
    ----------
    cameras : (int, int)
        Indices into the calibration's camera list.
    region : (4,) float or None
        ``(x_min, z_min, x_max, z_max)`` of the floor rectangle the pair owns, metres;
        ``None``: chosen automatically (the pair that sees the person most centrally).
    """

    cameras: tuple[int, int]
    region: tuple[float, float, float, float] | None = None


@dataclass(frozen=True, eq=False)
class Calibration:
    """Cameras of one capture setup, plus the optional camera pairs."""

    cameras: tuple[Camera, ...]
    pairs: tuple[CameraPair, ...] = ()

    def __len__(self) -> int:
        return len(self.cameras)


def _matrix(value, shape: tuple[int, ...], what: str) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InvalidParameterError(f"{what} must be numbers of shape {shape}") from None
    if arr.shape != shape:
        raise InvalidParameterError(f"{what} has shape {arr.shape}; expected {shape}")
    return arr


def parse_calibration(doc: dict, path: str | Path | None = None) -> Calibration:
    """A :class:`Calibration` from the decoded JSON document (see module docstring).

    Raises
    ------
    InvalidParameterError
        Missing keys, wrong shapes, a matrix that is not a rotation, bad pair indices;
        the message names the file and the camera.
    """
    where = f"{path}: " if path is not None else ""
    if not isinstance(doc, dict) or not isinstance(doc.get("cameras"), list):
        raise InvalidParameterError(f"{where}expected an object with a 'cameras' list")
    if not doc["cameras"]:
        raise InvalidParameterError(f"{where}the 'cameras' list is empty")
    cameras = []
    for i, entry in enumerate(doc["cameras"]):
        label = f"{where}camera {i}"
        if not isinstance(entry, dict):
            raise InvalidParameterError(f"{label}: expected an object")
        missing = [k for k in ("K", "R", "t", "width", "height") if k not in entry]
        if missing:
            raise InvalidParameterError(f"{label}: missing {', '.join(missing)}")
        name = str(entry.get("name", f"cam{i}"))
        try:
            cameras.append(
                Camera(
                    _matrix(entry["K"], (3, 3), f"{label} K"),
                    _matrix(entry["R"], (3, 3), f"{label} R"),
                    _matrix(entry["t"], (3,), f"{label} t"),
                    int(entry["width"]),
                    int(entry["height"]),
                    name,
                )
            )
        except (TypeError, ValueError) as exc:
            raise InvalidParameterError(f"{label} ({name!r}): {exc}") from None
    pairs = []
    for i, entry in enumerate(doc.get("pairs", []) or []):
        label = f"{where}pair {i}"
        try:
            idx = tuple(int(c) for c in entry["cameras"])
        except (KeyError, TypeError, ValueError):
            raise InvalidParameterError(f"{label}: 'cameras' must be two camera indices") from None
        if len(idx) != 2 or idx[0] == idx[1] or not all(0 <= c < len(cameras) for c in idx):
            raise InvalidParameterError(
                f"{label}: cameras {list(idx)} must be two different indices in "
                f"0..{len(cameras) - 1}"
            )
        region = entry.get("region")
        if region is not None:
            region = tuple(float(v) for v in _matrix(region, (4,), f"{label} region"))
            if not (region[0] < region[2] and region[1] < region[3]):
                raise InvalidParameterError(
                    f"{label}: region must be [x_min, z_min, x_max, z_max] with min < max"
                )
        pairs.append(CameraPair(idx, region))
    return Calibration(tuple(cameras), tuple(pairs))


def load_calibration(path: str | Path) -> Calibration:
    """Read a calibration JSON file (see the module docstring for its layout)."""
    path = Path(path)
    try:
        doc = json.loads(path.read_text())
    except FileNotFoundError:
        raise InvalidParameterError(f"{path}: calibration file not found") from None
    except json.JSONDecodeError as exc:
        raise InvalidParameterError(f"{path}:{exc.lineno}: not valid JSON: {exc.msg}") from None
    except ValueError as exc:  # bad UTF-8, a number of thousands of digits
        raise InvalidParameterError(f"{path}: not valid JSON: {exc}") from None
    return parse_calibration(doc, path)


def load_cameras(path: str | Path) -> tuple[Camera, ...]:
    """The cameras of a calibration JSON file, in file order."""
    return load_calibration(path).cameras


def calibration_document(calibration: Calibration) -> dict:
    """The JSON-ready dictionary of a calibration (inverse of :func:`parse_calibration`)."""
    doc = {
        "convention": "OpenCV: x_cam = R @ X_world + t; metres; world Y up, floor y = 0",
        "cameras": [
            {
                "name": cam.name,
                "K": cam.K.tolist(),
                "R": cam.R.tolist(),
                "t": cam.t.tolist(),
                "width": cam.width,
                "height": cam.height,
            }
            for cam in calibration.cameras
        ],
    }
    if calibration.pairs:
        doc["pairs"] = [
            {"cameras": list(p.cameras)} | ({} if p.region is None else {"region": list(p.region)})
            for p in calibration.pairs
        ]
    return doc


def save_calibration(calibration: Calibration | Sequence[Camera], path: str | Path) -> Path:
    """Write a calibration (or a list of cameras) as JSON; returns the path."""
    if not isinstance(calibration, Calibration):
        calibration = Calibration(tuple(calibration))
    path = Path(path)
    path.write_text(json.dumps(calibration_document(calibration), indent=2) + "\n")
    return path


# -- checkerboards ------------------------------------------------------------------


def check_pattern(pattern: Sequence[int]) -> tuple[int, int]:
    """Validate a board's inner-corner counts ``(columns, rows)``.

    One count must be even and the other odd, so the board's two ends differ.
    """
    try:
        cols, rows = (int(v) for v in pattern)
    except (TypeError, ValueError):
        raise InvalidParameterError(
            f"pattern must be two inner-corner counts like (9, 6), got {pattern!r}"
        ) from None
    if cols < 2 or rows < 2:
        raise InvalidParameterError(f"pattern {cols}x{rows}: need at least 2 corners each way")
    if (cols + rows) % 2 == 0:
        raise InvalidParameterError(
            f"pattern {cols}x{rows}: one count must be even and the other odd (e.g. 9x6), "
            "otherwise the board's two ends cannot be told apart"
        )
    return cols, rows


def parse_pattern(text: str) -> tuple[int, int]:
    """``"9x6"`` → ``(9, 6)`` (inner corners per row, rows), validated."""
    parts = str(text).lower().replace("×", "x").split("x")
    if len(parts) != 2:
        raise InvalidParameterError(f"pattern {text!r}: expected COLUMNSxROWS, e.g. 9x6")
    try:
        return check_pattern((int(parts[0]), int(parts[1])))
    except ValueError:
        raise InvalidParameterError(f"pattern {text!r}: expected COLUMNSxROWS, e.g. 9x6") from None


def board_points(pattern: Sequence[int], square_m: float) -> np.ndarray:
    """(N, 3) float32 inner-corner positions in the board frame, metres.

    Corner ``i + cols * j`` is at ``(i * square_m, j * square_m, 0)``, the order in
    which :func:`find_board_corners` returns them.
    """
    cols, rows = check_pattern(pattern)
    if not (np.isfinite(square_m) and square_m > 0):
        raise InvalidParameterError(f"square_m must be > 0 metres, got {square_m!r}")
    jj, ii = np.mgrid[0:rows, 0:cols]
    pts = np.stack([ii.ravel(), jj.ravel(), np.zeros(ii.size)], axis=1) * square_m
    return pts.astype(np.float32)


def _gray(image: np.ndarray) -> np.ndarray:
    image = np.asarray(image)
    if image.ndim == 3 and image.shape[2] == 3:
        return cv2.cvtColor(image.astype(np.uint8), cv2.COLOR_RGB2GRAY)
    if image.ndim == 2:
        return image.astype(np.uint8)
    raise InvalidParameterError(f"image must be (H, W) or (H, W, 3) uint8, got shape {image.shape}")


def _sample(gray: np.ndarray, point: np.ndarray) -> float:
    """Mean intensity of a 3 × 3 patch around ``point`` (u, v), or NaN outside."""
    u, v = int(round(point[0])), int(round(point[1]))
    h, w = gray.shape
    if not (1 <= u < w - 1 and 1 <= v < h - 1):
        return float("nan")
    return float(gray[v - 1 : v + 2, u - 1 : u + 2].mean())


def find_board_corners(
    image: np.ndarray, pattern: Sequence[int], name: str = "image"
) -> np.ndarray:
    """Inner corners of a chessboard, in a fixed order on the board.

    Parameters
    ----------
    image : (H, W, 3) uint8 RGB or (H, W) uint8
    pattern : (int, int)
        Inner corners per row and number of rows, e.g. ``(9, 6)``.
    name : str
        Used in error messages (e.g. the file name).

    Returns
    -------
    (cols * rows, 2) float32
        Pixel positions (u, v), row by row, so that corner ``i + cols * j`` is board
        point ``(i, j)`` of :func:`board_points`: the first corner is the one next to
        the dark corner square, and the board's x then y axes appear counter-clockwise
        in the image (x right, y down) as seen from the board's printed side.

    Raises
    ------
    InvalidParameterError
        The board is not found.
    """
    cols, rows = check_pattern(pattern)
    gray = _gray(image)
    flags = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
    found, corners = cv2.findChessboardCorners(gray, (cols, rows), flags=flags)
    if not found:
        raise InvalidParameterError(f"{name}: no {cols}x{rows} chessboard found")
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 50, 1e-4)
    # The refinement window must stay inside one square, or it drifts to other corners.
    grid0 = corners.reshape(rows, cols, 2)
    spacing = min(
        np.linalg.norm(np.diff(grid0, axis=0), axis=-1).min(),
        np.linalg.norm(np.diff(grid0, axis=1), axis=-1).min(),
    )
    half = int(np.clip(0.4 * spacing, 2, 5))
    corners = cv2.cornerSubPix(gray, corners, (half, half), (-1, -1), criteria)
    grid = corners.reshape(rows, cols, 2).astype(np.float64)
    # Handedness: seen from the printed side, board x × board y points away from the
    # camera, i.e. the image cross product (x right, y down) is positive.
    dx = grid[0, -1] - grid[0, 0]
    dy = grid[-1, 0] - grid[0, 0]
    if dx[0] * dy[1] - dx[1] * dy[0] < 0:
        grid = grid[:, ::-1]
    # The 180° ambiguity: the origin corner must touch the dark corner square.
    first = grid[0, 0] - 0.5 * ((grid[0, 1] - grid[0, 0]) + (grid[1, 0] - grid[0, 0]))
    last = grid[-1, -1] + 0.5 * ((grid[-1, -1] - grid[-1, -2]) + (grid[-1, -1] - grid[-2, -1]))
    a, b = _sample(gray, first), _sample(gray, last)
    if np.isfinite(a) and np.isfinite(b) and a > b:
        grid = grid[::-1, ::-1]
    return grid.reshape(-1, 2).astype(np.float32)


def calibrate_camera(
    images: Sequence[np.ndarray],
    pattern: Sequence[int],
    square_m: float,
    floor_index: int = 0,
    name: str = "",
    image_names: Sequence[str] | None = None,
) -> tuple[Camera, float]:
    """One camera from several chessboard views, one of them on the floor.

    Parameters
    ----------
    images : sequence of (H, W, 3) or (H, W) uint8
        Views of the board in varied poses (tilted, at several places in the image);
        all of one size.  At least 3 are advised for stable intrinsics.
    pattern : (int, int)
        Inner corners, e.g. ``(9, 6)``.
    square_m : float
        Side of one square, metres.
    floor_index : int
        Which image shows the board lying on the floor: it defines the world frame
        (see the module docstring).
    name : str
        The camera's name.
    image_names : sequence of str, optional
        Names for error messages.

    Returns
    -------
    camera : Camera
    rms_px : float
        Root-mean-square reprojection error over all views, pixels.
    """
    if len(images) == 0:
        raise InvalidParameterError(f"camera {name!r}: no images")
    if not 0 <= floor_index < len(images):
        raise InvalidParameterError(
            f"camera {name!r}: floor_index {floor_index} outside 0..{len(images) - 1}"
        )
    names = (
        list(image_names) if image_names is not None else [f"image {i}" for i in range(len(images))]
    )
    sizes = {np.asarray(im).shape[:2] for im in images}
    if len(sizes) != 1:
        raise InvalidParameterError(f"camera {name!r}: images differ in size {sorted(sizes)}")
    height, width = sizes.pop()
    obj = board_points(pattern, square_m)
    img_pts = [find_board_corners(im, pattern, n) for im, n in zip(images, names, strict=True)]
    flags = (
        cv2.CALIB_ZERO_TANGENT_DIST
        | cv2.CALIB_FIX_K1
        | cv2.CALIB_FIX_K2
        | cv2.CALIB_FIX_K3
        | cv2.CALIB_FIX_ASPECT_RATIO
    )
    if len(images) < 3:
        # Too few views to pin the principal point down: keep it at the image centre.
        flags |= cv2.CALIB_FIX_PRINCIPAL_POINT
    f0 = float(max(width, height))
    K0 = np.array([[f0, 0, (width - 1) / 2.0], [0, f0, (height - 1) / 2.0], [0, 0, 1.0]])
    rms, K, _dist, rvecs, tvecs = cv2.calibrateCamera(
        [obj] * len(img_pts),
        [p.reshape(-1, 1, 2) for p in img_pts],
        (width, height),
        K0,
        np.zeros(5),
        flags=flags | cv2.CALIB_USE_INTRINSIC_GUESS,
    )
    R_board, _ = cv2.Rodrigues(rvecs[floor_index])
    R = R_board @ BOARD_TO_WORLD.T
    t = np.asarray(tvecs[floor_index], dtype=np.float64).reshape(3)
    camera = Camera(K, R, t, width, height, name)
    if camera.center[1] <= 0:
        raise InvalidParameterError(
            f"camera {name!r}: the floor board in {names[floor_index]} puts the camera "
            "below the floor; is that image really of the board lying on the floor?"
        )
    return camera, float(rms)


def calibrate_cameras(
    groups: dict[str, Sequence[str | Path]],
    pattern: Sequence[int] = (9, 6),
    square_m: float = 0.025,
    floor_name: str = "floor",
) -> tuple[Calibration, dict[str, float]]:
    """Calibrate several cameras from image files grouped by camera.

    Parameters
    ----------
    groups : dict of str to sequence of paths
        Camera name → its image files.  In each group, the image whose file stem
        starts with ``floor_name`` shows the board on the floor (all cameras see the
        same board there, which defines the common world frame).
    pattern, square_m :
        See :func:`calibrate_camera`.
    floor_name : str
        Stem prefix of the floor image in each group.

    Returns
    -------
    calibration : Calibration
        Cameras in the order of ``groups``.
    rms_px : dict of str to float
        Reprojection error per camera, pixels.
    """
    cameras, errors = [], {}
    for cam_name, paths in groups.items():
        paths = [Path(p) for p in paths]
        floor = [i for i, p in enumerate(paths) if p.stem.startswith(floor_name)]
        if len(floor) != 1:
            raise InvalidParameterError(
                f"camera {cam_name!r}: expected exactly one image named {floor_name}* "
                f"(the board on the floor) among {[p.name for p in paths]}, found {len(floor)}"
            )
        images = []
        for p in paths:
            image = cv2.imread(str(p), cv2.IMREAD_GRAYSCALE)
            if image is None:
                raise InvalidParameterError(f"{p}: not a readable image")
            images.append(image)
        cam, rms = calibrate_camera(
            images, pattern, square_m, floor[0], cam_name, [str(p) for p in paths]
        )
        cameras.append(cam)
        errors[cam_name] = rms
    return Calibration(tuple(cameras)), errors


def group_images_by_camera(paths: Sequence[str | Path]) -> dict[str, list[Path]]:
    """Group image files by their folder: ``cam0/a.png, cam1/b.png`` → two cameras.

    Returns
    -------
    dict of str to list of Path
        Camera name (the folder's name, or its whole path where two folders share a
        name) → its files sorted by name; folders in sorted order.
    """
    by_folder: dict[Path, list[Path]] = {}
    for p in sorted(Path(p) for p in paths):
        if not p.is_file():
            raise InvalidParameterError(f"{p}: not an image file")
        by_folder.setdefault(p.parent, []).append(p)
    if not by_folder:
        raise InvalidParameterError("no images given")
    names = [folder.name or "." for folder in by_folder]
    return {
        (name if names.count(name) == 1 else str(folder)): files
        for name, (folder, files) in zip(names, by_folder.items(), strict=True)
    }
