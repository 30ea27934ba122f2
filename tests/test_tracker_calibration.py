"""Tracker cameras: the calibration JSON and chessboard calibration on synthetic boards."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from eigmotion.cli.main import main
from eigmotion.errors import InvalidParameterError
from eigmotion.imaging.cameras import intrinsics, look_at
from eigmotion.mocap.rotations import euler_to_matrix
from eigmotion.tracking.calibration import (
    BOARD_TO_WORLD,
    Calibration,
    CameraPair,
    board_points,
    calibrate_camera,
    check_pattern,
    find_board_corners,
    load_calibration,
    parse_calibration,
    parse_pattern,
    save_calibration,
)

PATTERN = (9, 6)
SQUARE_M = 0.08


def render_board(K, R_board, t_board, pattern, square_m, width, height, px_per_square=24):
    """A grey image of a chessboard with pose (R_board, t_board) in camera coordinates.

    Board squares ``(a, b)`` for ``a in -1..cols-1``, ``b in -1..rows-1`` span
    ``[a, a+1] × [b, b+1]`` squares; the one at the origin corner ``(-1, -1)`` is dark;
    a one-square white margin surrounds the board.
    """
    cols, rows = pattern
    n_a, n_b = cols + 3, rows + 3
    tex = np.full((n_b * px_per_square, n_a * px_per_square), 255, np.uint8)
    for b in range(-1, rows):
        for a in range(-1, cols):
            if (a + b) % 2 == 0:
                y0, x0 = (b + 2) * px_per_square, (a + 2) * px_per_square
                tex[y0 : y0 + px_per_square, x0 : x0 + px_per_square] = 0
    s = square_m / px_per_square
    tex_to_board = np.array(
        [[s, 0, -2 * square_m + 0.5 * s], [0, s, -2 * square_m + 0.5 * s], [0, 0, 1]]
    )
    board_to_image = K @ np.column_stack([R_board[:, 0], R_board[:, 1], t_board])
    return cv2.warpPerspective(
        tex,
        board_to_image @ tex_to_board,
        (width, height),
        flags=cv2.INTER_AREA,
        borderMode=cv2.BORDER_CONSTANT,
        borderValue=128,
    )


def synthetic_views(camera, rng, n_tilted=5):
    """The floor view (first) and tilted close-up views of the board for one camera."""
    floor = render_board(
        camera.K,
        camera.R @ BOARD_TO_WORLD,
        camera.t,
        PATTERN,
        SQUARE_M,
        camera.width,
        camera.height,
    )
    views = [floor]
    centre = np.array([(PATTERN[0] - 1) / 2, (PATTERN[1] - 1) / 2, 0.0]) * SQUARE_M
    for _ in range(n_tilted):
        R = euler_to_matrix(rng.uniform(-35, 35, 3), "XYZ")
        target = np.array([rng.uniform(-0.3, 0.3), rng.uniform(-0.2, 0.2), rng.uniform(1.2, 1.8)])
        views.append(
            render_board(
                camera.K, R, target - R @ centre, PATTERN, SQUARE_M, camera.width, camera.height
            )
        )
    return views


def walkway_cameras():
    """Two cameras on both sides of a walkway, both seeing the board on the floor."""
    K = intrinsics(640, 480, 50.0)
    return [
        look_at([1.2, 1.6, -2.2], [0.3, 0.0, 0.2], K, 640, 480, name="left"),
        look_at([-0.6, 1.7, 2.6], [0.3, 0.0, 0.2], K, 640, 480, name="right"),
    ]


@pytest.fixture(scope="module")
def board_images():
    rng = np.random.default_rng(3)
    return {cam.name: (cam, synthetic_views(cam, rng)) for cam in walkway_cameras()}


def test_corner_order_is_fixed_on_the_board(board_images):
    """Both cameras, looking from opposite sides, number the corners alike."""
    for cam, views in board_images.values():
        corners = find_board_corners(views[0], PATTERN)
        world = board_points(PATTERN, SQUARE_M).astype(float) @ BOARD_TO_WORLD.T
        expected, _ = cam.project(world)
        assert np.abs(corners - expected).max() < 0.6


@pytest.mark.parametrize("name", ["left", "right"])
def test_calibration_recovers_known_cameras(board_images, name):
    truth, views = board_images[name]
    cam, rms = calibrate_camera(views, PATTERN, SQUARE_M, floor_index=0, name=name)
    assert rms < 0.5
    np.testing.assert_allclose(cam.K, truth.K, rtol=0.01, atol=2.0)
    angle = np.rad2deg(np.arccos(np.clip((np.trace(cam.R @ truth.R.T) - 1) / 2, -1, 1)))
    assert angle < 0.5
    assert np.linalg.norm(cam.center - truth.center) < 0.03


def test_calibrate_command_writes_json(tmp_path, board_images, capsys):
    for name, (_, views) in board_images.items():
        folder = tmp_path / "images" / name
        folder.mkdir(parents=True)
        cv2.imwrite(str(folder / "floor.png"), views[0])
        for i, view in enumerate(views[1:]):
            cv2.imwrite(str(folder / f"view{i}.png"), view)
    out = tmp_path / "cams.json"
    code = main(
        [
            "calibrate",
            str(tmp_path / "images" / "left"),
            str(tmp_path / "images" / "right"),
            "--pattern",
            "9x6",
            "--square-m",
            str(SQUARE_M),
            "--out",
            str(out),
        ]
    )
    assert code == 0
    cams = load_calibration(out).cameras
    assert [c.name for c in cams] == ["left", "right"]
    for cam in cams:
        truth = board_images[cam.name][0]
        assert np.linalg.norm(cam.center - truth.center) < 0.03
    assert "reprojection error" in capsys.readouterr().out


def test_calibrate_command_without_floor_image(tmp_path, board_images, capsys):
    folder = tmp_path / "cam0"
    folder.mkdir()
    for i, view in enumerate(board_images["left"][1][1:3]):
        cv2.imwrite(str(folder / f"view{i}.png"), view)
    code = main(["calibrate", str(folder), "--out", str(tmp_path / "c.json")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "floor" in err[0]


def test_missing_board_is_reported():
    blank = np.full((240, 320), 128, np.uint8)
    with pytest.raises(InvalidParameterError, match="no 9x6 chessboard"):
        find_board_corners(blank, PATTERN, "blank.png")


@pytest.mark.parametrize(
    "text, ok", [("9x6", True), ("7X4", True), ("8x8", False), ("9x7", False), ("9", False)]
)
def test_pattern_parsing(text, ok):
    if ok:
        assert parse_pattern(text) == tuple(int(v) for v in text.lower().split("x"))
    else:
        with pytest.raises(InvalidParameterError):
            parse_pattern(text)


def test_pattern_must_tell_ends_apart():
    with pytest.raises(InvalidParameterError, match="even"):
        check_pattern((6, 6))


def test_calibration_json_round_trip(tmp_path):
    cams = walkway_cameras()
    calib = Calibration(tuple(cams), (CameraPair((0, 1), (-1.0, -2.0, 3.0, 2.0)),))
    path = save_calibration(calib, tmp_path / "c.json")
    again = load_calibration(path)
    for a, b in zip(cams, again.cameras, strict=True):
        np.testing.assert_allclose(a.K, b.K)
        np.testing.assert_allclose(a.R, b.R)
        np.testing.assert_allclose(a.t, b.t)
        assert (a.width, a.height, a.name) == (b.width, b.height, b.name)
    assert again.pairs[0].cameras == (0, 1)
    assert again.pairs[0].region == (-1.0, -2.0, 3.0, 2.0)


def _doc():
    cam = walkway_cameras()[0]
    return {
        "cameras": [
            {
                "name": "a",
                "K": cam.K.tolist(),
                "R": cam.R.tolist(),
                "t": cam.t.tolist(),
                "width": 640,
                "height": 480,
            }
        ]
    }


@pytest.mark.parametrize(
    "mutate, message",
    [
        (lambda d: d.pop("cameras"), "cameras"),
        (lambda d: d["cameras"].clear(), "empty"),
        (lambda d: d["cameras"][0].pop("K"), "missing K"),
        (lambda d: d["cameras"][0].__setitem__("t", [1, 2]), "t has shape"),
        (lambda d: d["cameras"][0].__setitem__("R", np.eye(3).tolist() + [[0, 0, 0]]), "R has"),
        (lambda d: d["cameras"][0].__setitem__("R", (2 * np.eye(3)).tolist()), "rotation"),
        (lambda d: d["cameras"][0].__setitem__("K", [["a"] * 3] * 3), "numbers"),
        (lambda d: d.__setitem__("pairs", [{"cameras": [0, 3]}]), "pair 0"),
    ],
)
def test_bad_calibration_files_name_what_is_wrong(tmp_path, mutate, message):
    doc = _doc()
    mutate(doc)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(InvalidParameterError, match=message) as info:
        load_calibration(path)
    assert "bad.json" in str(info.value)


def test_calibration_file_errors(tmp_path):
    with pytest.raises(InvalidParameterError, match="not found"):
        load_calibration(tmp_path / "none.json")
    (tmp_path / "x.json").write_text("{\n  oops")
    with pytest.raises(InvalidParameterError, match=r"x.json:2"):
        load_calibration(tmp_path / "x.json")
    assert len(parse_calibration(_doc()).cameras) == 1
