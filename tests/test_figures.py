"""Figures: contact sheet layout, side-by-side clips, image files, image conversion."""

from __future__ import annotations

import math

import numpy as np
import pytest
from PIL import Image

from eigmotion.errors import InvalidParameterError
from eigmotion.imaging.figures import (
    SHEET_RGB,
    contact_sheet,
    save_image,
    side_by_side,
    stretched_frames,
    to_rgb8,
    with_captions,
)


def _tile(value, height=30, width=40):
    return np.full((height, width, 3), value, dtype=np.uint8)


# -- to_rgb8 -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "image, expected",
    [
        (np.full((2, 3), 9, np.uint8), [9, 9, 9]),
        (np.ones((2, 3), bool), [255, 255, 255]),
        (np.full((2, 3), 0.5), [128, 128, 128]),
        (np.full((2, 3), 7.0), [255, 255, 255]),  # floats are clipped to [0, 1]
        (np.full((2, 3, 4), 200, np.uint8), [200, 200, 200]),  # alpha dropped
        (np.full((2, 3, 1), 3, np.uint8), [3, 3, 3]),
    ],
)
def test_to_rgb8(image, expected):
    out = to_rgb8(image)
    assert out.shape == (2, 3, 3) and out.dtype == np.uint8
    assert out[1, 2].tolist() == expected


@pytest.mark.parametrize(
    "image", [np.zeros((2, 3, 2), np.uint8), np.zeros(5, np.uint8), np.zeros((2, 2), np.int64)]
)
def test_to_rgb8_rejects(image):
    with pytest.raises(InvalidParameterError):
        to_rgb8(image)


# -- contact sheet -------------------------------------------------------------------------


@pytest.mark.parametrize("n_images, n_cols", [(1, 4), (3, 4), (8, 4), (9, 4), (5, 2), (6, 1)])
@pytest.mark.parametrize("pad_px", [0, 4])
def test_contact_sheet_layout(n_images, n_cols, pad_px):
    images = [_tile(20 * (i + 1)) for i in range(n_images)]
    sheet = contact_sheet(images, n_cols, pad_px=pad_px)
    cols = min(n_cols, n_images)
    rows = math.ceil(n_images / cols)
    assert sheet.shape == (rows * 30 + (rows + 1) * pad_px, cols * 40 + (cols + 1) * pad_px, 3)
    for i in range(n_images):  # each image sits in its cell, row by row
        r, c = divmod(i, cols)
        y0, x0 = pad_px + r * (30 + pad_px), pad_px + c * (40 + pad_px)
        assert np.all(sheet[y0 : y0 + 30, x0 : x0 + 40] == 20 * (i + 1))
    if rows * cols > n_images:  # empty cells stay background
        y0 = pad_px + (rows - 1) * (30 + pad_px)
        x0 = pad_px + (cols - 1) * (40 + pad_px)
        assert np.all(sheet[y0 : y0 + 30, x0 : x0 + 40] == SHEET_RGB)


def test_contact_sheet_labels_and_title_add_bands_with_text():
    images = [_tile(0, 60, 80) for _ in range(5)]
    plain = contact_sheet(images, 3)
    labelled = contact_sheet(images, 3, labels=[f"{i / 30:.2f} s" for i in range(5)])
    titled = contact_sheet(images, 3, labels=["a"] * 5, title="walk 02_01")
    assert labelled.shape[1] == plain.shape[1] == titled.shape[1]
    band = (labelled.shape[0] - plain.shape[0]) // 2
    assert band > 0 and labelled.shape[0] == plain.shape[0] + 2 * band
    assert titled.shape[0] == labelled.shape[0] + band
    # the label band under the first image holds dark text pixels
    first_band = labelled[4 + 60 : 4 + 60 + band, 4 : 4 + 80]
    assert (first_band.min(axis=-1) < 100).sum() > 10
    title_band = titled[:band]
    assert (title_band.min(axis=-1) < 100).sum() > 10


def test_contact_sheet_centres_smaller_images_and_mixes_kinds():
    mask = np.zeros((10, 20), bool)
    mask[2:8, 5:15] = True
    sheet = contact_sheet([_tile(50, 30, 40), mask, np.full((30, 40), 0.0)], 3, pad_px=0)
    assert sheet.shape == (30, 120, 3)
    cell = sheet[:, 40:80]
    assert np.all(cell[10 + 2 : 10 + 8, 10 + 5 : 10 + 15] == 255)  # mask centred, white
    assert np.all(cell[:10] == SHEET_RGB)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"images": []}, "at least one"),
        ({"images": [np.zeros((4, 4))], "n_cols": 0}, "n_cols"),
        ({"images": [np.zeros((4, 4))] * 2, "labels": ["one"]}, "one string per image"),
        ({"images": [np.zeros((4, 4))], "pad_px": -1}, "pad_px"),
    ],
)
def test_contact_sheet_errors(kwargs, match):
    with pytest.raises(InvalidParameterError, match=match):
        contact_sheet(**kwargs)


# -- side by side --------------------------------------------------------------------------


def _numbered_clip(n_frames, height, width, channels=True):
    """Frame f filled with the value 10 f (so a frame's index can be read back)."""
    shape = (n_frames, height, width, 3) if channels else (n_frames, height, width)
    clip = np.zeros(shape, np.uint8)
    for f in range(n_frames):
        clip[f] = 10 * f
    return clip


def test_side_by_side_shape_and_time_alignment():
    long = _numbered_clip(9, 40, 60)
    short = _numbered_clip(3, 20, 20, channels=False)
    still = _numbered_clip(1, 80, 40)
    out = side_by_side([long, short, still], height_px=40, pad_px=2)
    widths = [60, 40, 20]  # aspect kept at height 40
    assert out.shape == (9, 40 + 4, sum(widths) + 4 * 2, 3)
    x_short = 2 + 60 + 2
    for f in range(9):
        assert out[f, 2 + 20, 2 + 30, 0] == 10 * f
        # 3 frames stretched over 9: output f shows round(f * 2 / 8)
        assert out[f, 2 + 20, x_short + 20, 0] == 10 * round(f * 2 / 8)
        assert out[f, 2 + 20, x_short + 40 + 2 + 10, 0] == 0  # the still panel
    assert np.all(out[:, :2] == SHEET_RGB)  # padding


def test_side_by_side_titles_on_every_frame():
    clips = [_numbered_clip(4, 50, 50), np.ones((4, 50, 50), bool)]
    plain = side_by_side(clips)
    titled = side_by_side(clips, titles=["input", "silhouettes"])
    band = titled.shape[1] - plain.shape[1]
    assert band > 0 and titled.shape[2] == plain.shape[2]
    assert (titled[:, :band].min(axis=-1) < 100).sum(axis=(1, 2)).min() > 10
    np.testing.assert_array_equal(titled[0, :band], titled[3, :band])


def test_side_by_side_default_height_is_the_tallest():
    out = side_by_side([_numbered_clip(2, 30, 30), _numbered_clip(2, 60, 30)], pad_px=0)
    assert out.shape == (2, 60, 60 + 30, 3)


@pytest.mark.parametrize(
    "panels, kwargs, match",
    [
        ([], {}, "at least one panel"),
        ([np.zeros((4, 4))], {}, "panel 0"),
        ([np.zeros((2, 4, 4))], {"titles": ["a", "b"]}, "one string per panel"),
        ([np.zeros((2, 4, 4))], {"height_px": 0}, "height_px"),
    ],
)
def test_side_by_side_errors(panels, kwargs, match):
    with pytest.raises(InvalidParameterError, match=match):
        side_by_side(panels, **kwargs)


# -- save_image ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    "image",
    [np.arange(60, dtype=np.uint8).reshape(4, 5, 3), np.eye(4, dtype=bool)],
)
def test_save_image_png_round_trip(tmp_path, image):
    path = save_image(image, tmp_path / "sub" / "img.png")
    np.testing.assert_array_equal(np.asarray(Image.open(path)), to_rgb8(image))


def test_save_image_unknown_extension(tmp_path):
    with pytest.raises(InvalidParameterError, match="cannot write"):
        save_image(np.zeros((4, 4), np.uint8), tmp_path / "img.xyz")


# -- captions -------------------------------------------------------------------------------


def test_captions_are_written_under_each_frame():
    frames = np.zeros((4, 30, 200, 3), np.uint8)
    out = with_captions(frames, ["walk", "walk", "", "wave"])
    assert out.shape[0] == 4 and out.shape[2:] == (200, 3) and out.shape[1] > 30
    np.testing.assert_array_equal(out[:, :30], frames)
    band = out[:, 30:]
    written = (band != np.array(SHEET_RGB, np.uint8)).any(axis=(1, 2, 3))
    assert written.tolist() == [True, True, False, True]
    np.testing.assert_array_equal(band[0], band[1])
    assert (band[0] != band[3]).any()


@pytest.mark.parametrize(
    ("frames", "captions", "match"),
    [
        (np.zeros((2, 30, 40, 3), np.uint8), ["a"], "one string per frame"),
        (np.zeros((2, 30, 40), np.uint8), ["a", "b"], r"\(F, H, W, 3\) uint8"),
        (np.zeros((2, 30, 40, 3)), ["a", "b"], r"\(F, H, W, 3\) uint8"),
    ],
)
def test_caption_errors(frames, captions, match):
    with pytest.raises(InvalidParameterError, match=match):
        with_captions(frames, captions)


def test_each_frame_of_a_replay_is_captioned_with_its_segment():
    from eigmotion.pose.replay import segment_captions
    from eigmotion.retrieval.results import Segment

    segments = [Segment(0, 3, "walk", 0.2), Segment(3, 5, "wave", 0.1), Segment(6, 7, "kick", 1)]
    captions = segment_captions(segments, 7, "wave")
    # Frame ranges include both ends: frames 0, 1 and 2 are "frames 0-2".
    assert captions[:3] == ["answer: wave   frames 0-2: walk"] * 3
    assert captions[3:5] == ["answer: wave   frames 3-4: wave"] * 2
    assert captions[5] == "answer: wave"  # no segment there
    assert captions[6] == "answer: wave   frame 6: kick"


def test_replay_captions_must_be_one_per_mask():
    from eigmotion.pose.replay import replay_video

    masks = np.zeros((3, 8, 8), bool)
    with pytest.raises(InvalidParameterError, match="one string per mask: 2 for 3"):
        picture = np.zeros((8, 8), np.uint8)
        replay_video(None, None, masks, picture, "x.mp4", 15.0, captions=["a", "b"])


def test_stretched_frames_cover_both_ends_in_order():
    assert stretched_frames(5, 3).tolist() == [0, 0, 1, 2, 2]  # round half to even
    assert stretched_frames(3, 5).tolist() == [0, 2, 4]
    assert stretched_frames(1, 4).tolist() == [0]
    assert stretched_frames(4, 1).tolist() == [0, 0, 0, 0]
