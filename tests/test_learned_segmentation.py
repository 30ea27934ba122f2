"""The learned front end: the shipped person segmentation network, its masks, the
people it counts, and the query's ``--segmenter`` switch.

The clips are the bundled samples (the avatar rendered over a textured scene); the
masks cut by subtracting their empty-scene images are the reference.
"""

from __future__ import annotations

import importlib.util
import json
import re
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest

from eigmotion.cli.main import main
from eigmotion.errors import InvalidParameterError, VideoError
from eigmotion.imaging.media import read_frame_sample, read_frames, write_video
from eigmotion.imaging.still_images import read_image_rgb
from eigmotion.retrieval.database import QUERY_SILHOUETTE_CONFIG, MotionDatabase
from eigmotion.retrieval.results import lost_person_warning
from eigmotion.segmentation import learned
from eigmotion.segmentation.background import seen_scene
from eigmotion.segmentation.config import SilhouetteConfig
from eigmotion.segmentation.fused import (
    SCENE_NEAR_PX,
    SCENE_PIECE_SHARE,
    _scene_pieces,
    fuse_masks,
    without_seen_scene,
)
from eigmotion.segmentation.learned import (
    MODEL_PATH,
    crop_input,
    crop_probabilities_back,
    model_input,
    people_in_view,
    person_in_frame,
    person_probabilities,
    resolve_segmenter,
)
from eigmotion.segmentation.subtraction import CHUNK_FRAMES, frame_chunks, subtract_scene
from eigmotion.segmentation.video import load_clip_masks

REPO = Path(__file__).resolve().parents[1]
SAMPLES = REPO / "database" / "samples"
QUERY_CONFIG = SilhouetteConfig(work_max_side_px=160)


@pytest.fixture(scope="module")
def db_path(four_motion_database):
    return four_motion_database


def _iou(a: np.ndarray, b: np.ndarray) -> float:
    return float((a & b).sum() / max((a | b).sum(), 1))


def test_the_network_ships_with_its_licence():
    assert MODEL_PATH.is_file() and MODEL_PATH.stat().st_size > 100_000
    licence = (MODEL_PATH.parent / "LICENSE").read_text(encoding="utf-8")
    assert "Apache License" in licence and "Version 2.0" in licence


def _cut_and_reference(clip: str):
    video = SAMPLES / f"{clip}.mp4"
    background = SAMPLES / f"{clip}_background.png"
    cut = load_clip_masks(video, None, QUERY_CONFIG, 15.0, segmenter="learned")
    reference = load_clip_masks(video, background, QUERY_CONFIG, 15.0, segmenter="subtraction")
    assert cut.segmenter == "learned" and reference.segmenter == "subtraction"
    assert cut.masks.shape == reference.masks.shape
    np.testing.assert_array_equal(cut.frame_indices, reference.frame_indices)
    overlap = np.array([_iou(a, b) for a, b in zip(cut.masks, reference.masks, strict=True)])
    return cut, overlap


def test_learned_masks_find_the_person_the_background_image_shows():
    """The kick sample: the avatar fills half the frame's height, in a pink dress over
    a pink wall.  The selfie network takes much of the rendered floor for the person
    in the first frames (left empty: over three times the clip's median area); the
    pose network loses the dress against the wall in a few frames."""
    cut, overlap = _cut_and_reference("kick")
    found = cut.masks.any(axis=(1, 2))
    assert np.count_nonzero(~found) <= 6
    assert np.median(overlap[found]) >= 0.7, f"median IoU {np.median(overlap[found]):.3f}"
    assert np.mean(overlap[found] >= 0.6) >= 0.7, np.round(overlap, 2)
    assert cut.people == 1


def test_the_second_pass_finds_a_distant_person():
    """The walk sample: the avatar walks away to a quarter of the frame's height.  The
    whole frame at 256×256 loses it in 19 of the 46 frames; the second pass, on a
    square around it, finds it in nearly all of them."""
    cut, overlap = _cut_and_reference("walk_3s")
    found = cut.masks.any(axis=(1, 2))
    assert np.count_nonzero(found) >= 42, f"{np.count_nonzero(found)} of {len(found)} frames"
    assert np.median(overlap) >= 0.75, f"median IoU {np.median(overlap):.3f}"
    assert np.median(overlap[-15:]) >= 0.75  # the last frames, where it is smallest


def _wide_shot(tmp_path: Path, clip: str) -> tuple[Path, Path, tuple[slice, slice]]:
    """The sample and its empty-scene image as a wide shot in high definition: each
    320 × 240 frame 1.6 times as large in the middle of a 1280 × 960 one, padded with
    its own edges (the walking avatar 100-190 px of 960 tall); the rows and columns it
    came from."""
    frames, fps = read_frames(SAMPLES / f"{clip}.mp4")

    def widened(image):
        large = cv2.resize(image, (512, 384), interpolation=cv2.INTER_CUBIC)
        return cv2.copyMakeBorder(large, 288, 288, 384, 384, cv2.BORDER_REPLICATE)

    video = write_video(np.stack([widened(f) for f in frames]), tmp_path / "wide.mp4", fps)
    scene = tmp_path / "wide_background.png"
    background = read_image_rgb(SAMPLES / f"{clip}_background.png")
    cv2.imwrite(str(scene), widened(background)[..., ::-1])
    return video, scene, (slice(288, 672), slice(384, 896))


def test_a_small_person_in_a_wide_high_definition_shot_is_found(tmp_path):
    """The walk sample in the middle of a 1280 × 960 frame: seen whole at 256 × 256,
    the avatar is a few pixels of the network's input, found in none of the 46
    frames (its faint traces gave boxes for 35 of them).  The first look at
    overlapping squares finds it, and where even that fails, the pose network's
    square follows the person of the frame before: all 46.  The masks match the
    sample's own where the sample lies, and with the empty-scene image (fused) keep
    what the learned ones find."""
    video, scene, (rows, cols) = _wide_shot(tmp_path, "walk_3s")
    cut = load_clip_masks(video, None, QUERY_CONFIG, 15.0, segmenter="learned")
    found = cut.masks.any(axis=(1, 2))
    assert np.count_nonzero(found) >= 44, f"{np.count_nonzero(found)} of {len(found)} frames"
    own, _ = _cut_and_reference("walk_3s")
    factor = 960 // cut.masks.shape[1]  # the frame at the working size
    here = cut.masks[:, rows.start // factor : rows.stop // factor,
                     cols.start // factor : cols.stop // factor]  # fmt: skip
    theirs = np.stack(
        [
            cv2.resize(m.view(np.uint8), here.shape[:0:-1], interpolation=cv2.INTER_AREA)
            for m in own.masks
        ]
    ).astype(bool)
    overlap = np.array([_iou(a, b) for a, b in zip(here, theirs, strict=True)])
    assert np.median(overlap) >= 0.8, f"median IoU {np.median(overlap):.3f}"
    fused = load_clip_masks(video, scene, QUERY_CONFIG, 15.0, segmenter="fused")
    assert fused.segmenter == "fused" and fused.masks.shape == cut.masks.shape
    assert np.count_nonzero(cut.masks & ~fused.masks) <= 0.01 * np.count_nonzero(cut.masks)


def test_the_look_at_squares_puts_the_person_back_in_place_and_skips_small_frames():
    """Frames of 128 pixels or less (the 64-pixel real clips) get no squares: one would
    cover them.  A larger frame's squares are half its longer side, half a square
    apart, and their probabilities go back where they were cut: the walk sample's
    first frame in the bottom-right quarter of a frame twice as large (its own edges
    around it) shows the avatar where the sample's masks have it."""
    assert learned._tiles_look(np.zeros((64, 64, 3), np.uint8), (64, 64)) is None
    assert learned._tiles_look(np.zeros((96, 128, 3), np.uint8), (96, 128)) is None
    centres = learned._tile_centres(480, 320.0)
    assert centres[0] == 160 and centres[-1] == 320 and len(centres) == 2
    frame = read_frame_sample(SAMPLES / "walk_3s.mp4", 15.0).frames[0]
    own = _cut_and_reference("walk_3s")[0].masks[0]  # (120, 160): the frame halved
    wide = cv2.copyMakeBorder(frame, 240, 0, 320, 0, cv2.BORDER_REPLICATE)
    probabilities = learned._tiles_look(wide, (120, 160))  # the wide frame quartered
    assert probabilities.shape == (120, 160)
    person, _ = person_in_frame(probabilities > learned.PERSON_PROBABILITY, QUERY_CONFIG)
    there = np.zeros_like(person)
    there[60:, 80:] = cv2.resize(own.view(np.uint8), (80, 60), interpolation=cv2.INTER_AREA)
    assert _iou(person, there) >= 0.65, _iou(person, there)


def test_frames_smaller_than_the_minimum_are_enlarged_by_a_whole_factor():
    """``work_min_side_px``: the smallest whole factor that brings the longer side to
    it; the working size is the enlarged frame's, shrunk as ever where the factor
    overshoots the maximum; 0, or a frame that large already, keeps the frame."""
    config = SilhouetteConfig(work_max_side_px=160, work_min_side_px=128)
    assert learned.enlargement(64, 64, config) == 2
    assert learned.enlargement(48, 64, config) == 2
    assert learned.enlargement(30, 40, config) == 4
    assert learned.enlargement(120, 160, config) == 1
    assert learned.enlargement(240, 100, config) == 1
    assert learned.working_size(64, 64, config) == (128, 128)
    assert learned.working_size(75, 100, config) == (75, 100)  # 200 px, halved again
    assert learned.working_size(240, 320, config) == (120, 160)
    assert learned.enlargement(64, 64, QUERY_SILHOUETTE_CONFIG) == 2
    assert learned.enlargement(64, 64, QUERY_CONFIG) == 1
    assert learned.working_size(64, 64, QUERY_CONFIG) == (64, 64)
    frame = np.arange(2 * 3 * 3, dtype=np.uint8).reshape(2, 3, 3)
    assert learned.enlarged(frame, 1) is frame
    assert learned.enlarged(frame, 3).shape == (6, 9, 3)
    larger = SilhouetteConfig(work_max_side_px=160, work_min_side_px=320)
    assert learned.enlargement(120, 160, larger) == 2
    assert learned.working_size(120, 160, larger) == (120, 160)  # enlarged, then halved
    with pytest.raises(InvalidParameterError, match="work_min_side_px"):
        SilhouetteConfig(work_min_side_px=-1)


@pytest.mark.skipif(
    importlib.util.find_spec("ai_edge_litert") is None,
    reason="the pose network runs through LiteRT (pip install ai-edge-litert)",
)
@pytest.mark.parametrize("segmenter", ["learned", "fused"])
def test_a_small_clip_is_cut_out_enlarged_and_its_landmarks_stay_in_its_pixels(tmp_path, segmenter):
    """The kick sample shrunk to 80 × 60 (its empty-scene image with it): at the
    query's minimum (128 px) its frames are enlarged twice before the networks see
    them, the masks come back at 160 × 120 and hold the person in nearly every frame,
    closer to the sample's own subtraction masks than without the enlargement, and
    the landmarks are in the small clip's own pixels, on the person those masks
    show."""
    frames, fps = read_frames(SAMPLES / "kick.mp4")
    small = np.stack([cv2.resize(f, (80, 60), interpolation=cv2.INTER_AREA) for f in frames])
    video = tmp_path / "kick_80x60.mp4"
    write_video(small, video, fps)
    scene = None
    if segmenter == "fused":
        scene = tmp_path / "scene.png"
        image = read_image_rgb(SAMPLES / "kick_background.png")[..., ::-1]
        cv2.imwrite(str(scene), cv2.resize(image, (80, 60), interpolation=cv2.INTER_AREA))
    cut = load_clip_masks(video, scene, QUERY_SILHOUETTE_CONFIG, 15.0, segmenter=segmenter)
    assert cut.segmenter == segmenter and cut.frame_size == (60, 80)
    assert cut.masks.shape[1:] == (120, 160)
    found = cut.masks.any(axis=(1, 2))
    assert np.count_nonzero(~found) <= 6, f"no person in {np.count_nonzero(~found)} frames"
    reference = load_clip_masks(
        SAMPLES / "kick.mp4",
        SAMPLES / "kick_background.png",
        QUERY_CONFIG,
        15.0,
        segmenter="subtraction",
    ).masks  # (F, 120, 160): the sample's frames halved, the small clip's doubled
    np.testing.assert_array_equal(cut.frame_indices, np.arange(len(found)) * 2)
    pairs = zip(cut.masks[found], reference[found], strict=True)
    overlap = np.array([_iou(a, b) for a, b in pairs])
    assert np.median(overlap) >= 0.65, f"median IoU {np.median(overlap):.3f}"
    if segmenter == "learned":  # not enlarged: the person a part of the networks' square
        plain = load_clip_masks(video, None, QUERY_CONFIG, 15.0, segmenter=segmenter).masks
        assert plain.shape[1:] == (60, 80)
        doubled = plain.repeat(2, axis=1).repeat(2, axis=2)
        before = np.median([_iou(a, b) for a, b in zip(doubled, reference, strict=True)])
        assert before < np.median(overlap) - 0.1, (before, np.median(overlap))
    seen = ~np.isnan(cut.landmarks[:, 0, 0])
    assert seen.sum() >= 0.8 * len(found)
    points = cut.landmarks[seen][:, [11, 12, 23, 24], :2]  # shoulders, hips
    assert np.all((points >= 0) & (points <= [80, 60]))
    grown = np.stack([cv2.dilate(m.view(np.uint8), np.ones((5, 5), np.uint8)) for m in reference])
    cells = np.minimum((points * 2).astype(int), [159, 119])
    inside = grown[np.flatnonzero(seen)[:, None], cells[..., 1], cells[..., 0]]
    assert inside.mean() >= 0.8, f"{inside.mean():.2f} of the landmarks on the person"


@pytest.mark.skipif(
    importlib.util.find_spec("ai_edge_litert") is None,
    reason="the pose network runs through LiteRT (pip install ai-edge-litert)",
)
def test_pose_landmarks_lie_on_the_person():
    """The kick sample: the pose network's landmarks, mapped back to the frame, land on
    the person the background image shows (hips and shoulders inside the reference
    mask grown by two pixels of the working size), the head above the hips and the
    ankles below them; its masks are the same as those of the query's front end."""
    video = SAMPLES / "kick.mp4"
    sample = read_frame_sample(video, 15.0)
    frames = np.stack([learned.stored_frame(f) for f in sample.frames])
    size = learned.working_size(*frames.shape[1:3], QUERY_CONFIG)
    masks, people, landmarks, world = learned.learned_masks_and_landmarks(
        frames, size, QUERY_CONFIG, second_look="pose"
    )
    assert landmarks.shape == (len(frames), 33, 4) and landmarks.dtype == np.float32
    reference = load_clip_masks(
        video, SAMPLES / "kick_background.png", QUERY_CONFIG, 15.0, segmenter="subtraction"
    ).masks
    seen = ~np.isnan(landmarks[:, 0, 0])
    assert seen.sum() >= 0.8 * len(frames), f"{seen.sum()} of {len(frames)} frames"
    grown = np.stack([cv2.dilate(m.view(np.uint8), np.ones((5, 5), np.uint8)) for m in reference])
    scale = size[1] / frames.shape[2]  # frame pixels to working-size pixels
    inside = []
    for i in np.flatnonzero(seen & reference.any(axis=(1, 2))):
        for joint in (11, 12, 23, 24):  # shoulders, hips
            x, y = landmarks[i, joint, :2] * scale
            inside.append(grown[i, min(int(y), size[0] - 1), min(int(x), size[1] - 1)] > 0)
        hips_y = landmarks[i, [23, 24], 1].mean()
        assert landmarks[i, 0, 1] < hips_y < landmarks[i, [27, 28], 1].mean()
    assert np.mean(inside) >= 0.9, f"{np.mean(inside):.2f} of the landmarks on the person"
    assert np.all((landmarks[seen, :, 2:] >= 0) & (landmarks[seen, :, 2:] <= 1))
    # the same frames' world landmarks: metres, centred between the hips, y down
    assert world.shape == (len(frames), 33, 3) and world.dtype == np.float32
    np.testing.assert_array_equal(np.isnan(world).any(axis=(1, 2)), ~seen)
    assert np.abs(world[seen][:, [23, 24]].mean(axis=1)).max() < 0.05
    assert np.all(world[seen][:, 0, 1] < -0.3), "the nose above the hips"
    height = world[seen][:, [27, 28], 1].mean(axis=1) - world[seen][:, 0, 1]
    assert 1.0 < np.median(height) < 2.0, height  # nose to ankles, the kick's leg raised
    expected, _ = learned.learned_masks(frames, size, QUERY_CONFIG)
    np.testing.assert_array_equal(masks, expected)
    assert people.max() == 1


@pytest.mark.skipif(
    importlib.util.find_spec("ai_edge_litert") is None,
    reason="the pose network runs through LiteRT (pip install ai-edge-litert)",
)
def test_the_square_follows_the_whole_person_where_the_first_look_lost_the_legs(monkeypatch):
    """Where the whole-frame look finds only the upper body (the selfie network, made
    for faces and shoulders, loses legs in dark trousers when the arms go up), the
    square around the box of the frame before, where the pose network saw the whole
    person, still holds the feet.  Here the first look's boxes are cut at the hips in
    every frame but the first."""
    video = SAMPLES / "kick.mp4"
    frames = np.stack([learned.stored_frame(f) for f in read_frame_sample(video, 15.0).frames])
    size = learned.working_size(*frames.shape[1:3], QUERY_CONFIG)
    whole, _, _, _ = learned.learned_masks_and_landmarks(frames, size, QUERY_CONFIG, "pose")
    boxes = learned._person_boxes  # the real first look, then its boxes cut

    def upper_halves(probabilities, config, frame_size):
        found = boxes(probabilities, config, frame_size)
        return found[:1] + [
            None if b is None else (b[0], b[1], b[2], (b[1] + b[3]) / 2) for b in found[1:]
        ]

    monkeypatch.setattr(learned, "_person_boxes", upper_halves)
    followed, _, _, _ = learned.learned_masks_and_landmarks(frames, size, QUERY_CONFIG, "pose")
    bottom = [
        (np.flatnonzero(a.any(axis=1))[-1], np.flatnonzero(b.any(axis=1))[-1])
        for a, b in zip(whole, followed, strict=True) if a.any() and b.any()
    ]  # fmt: skip
    reached = [b >= a - 0.05 * size[0] for a, b in bottom]
    assert len(bottom) >= 0.8 * len(frames) and np.mean(reached) >= 0.8, bottom


@pytest.mark.parametrize("second_look", learned.SECOND_LOOKS)
def test_where_the_second_look_finds_no_one_the_first_look_s_person_stands(
    monkeypatch, second_look
):
    """A person bent double is lost by both networks on the square around them, though
    the first look, at the whole frame, found them: that person stands, rather than an
    empty frame.  Here every square is cut from the frame's empty top-left corner."""
    if second_look == "pose" and learned.pose_network() is None:
        pytest.skip("the pose network runs through LiteRT (pip install ai-edge-litert)")
    sample = read_frame_sample(SAMPLES / "kick.mp4", 15.0)
    frames = np.stack([learned.stored_frame(f) for f in sample.frames[-6:]])
    size = learned.working_size(*frames.shape[1:3], QUERY_CONFIG)
    first = person_probabilities(np.stack([model_input(f) for f in frames]))
    h, w = size
    first_look = [
        person_in_frame(cv2.resize(p, (w, h)) > learned.PERSON_PROBABILITY, QUERY_CONFIG)[0]
        for p in first
    ]
    monkeypatch.setattr(
        learned,
        "_person_boxes",
        lambda probabilities, config, frame_size: [(0.0, 0.0, 8.0, 8.0)] * len(probabilities),
    )
    corner = crop_input(frames[0], (4.0, 4.0, learned.CROP_MIN_SIDE_PX))[0]
    assert (person_probabilities(corner[None])[0] <= learned.PERSON_PROBABILITY).all()
    masks, _, landmarks, _ = learned.learned_masks_and_landmarks(
        frames, size, QUERY_CONFIG, second_look
    )
    assert all(m.any() for m in first_look)
    np.testing.assert_array_equal(masks, np.stack(first_look))
    assert np.isnan(landmarks).all()


def test_without_the_pose_network_the_selfie_network_looks_twice(monkeypatch):
    """Where LiteRT is missing there is no pose network: the selfie network looks at
    the square too, no landmarks come back, and asking for the pose network says what
    to install."""
    sample = read_frame_sample(SAMPLES / "kick.mp4", 15.0)
    frames = np.stack([learned.stored_frame(f) for f in sample.frames[-6:]])
    size = learned.working_size(*frames.shape[1:3], QUERY_CONFIG)
    selfie, _, _, _ = learned.learned_masks_and_landmarks(frames, size, QUERY_CONFIG, "selfie")
    monkeypatch.setattr(learned, "pose_network", lambda: None)
    masks, people, landmarks, world = learned.learned_masks_and_landmarks(
        frames, size, QUERY_CONFIG
    )
    np.testing.assert_array_equal(masks, selfie)
    assert masks.any() and np.isnan(landmarks).all() and np.isnan(world).all()
    with pytest.raises(InvalidParameterError, match="LiteRT"):
        learned.learned_masks_and_landmarks(frames, size, QUERY_CONFIG, "pose")
    with pytest.raises(InvalidParameterError, match="second_look"):
        learned.learned_masks_and_landmarks(frames, size, QUERY_CONFIG, "grabcut")


def test_fused_masks_add_what_the_subtraction_finds_at_the_persons_edge():
    """A learned mask that rounds off an arm, where the subtraction loses the legs (the
    trousers the colour of the scene): the subtraction's arm is added where it lies
    within two pixels of the mask, not beyond; its shadow away from the person is not
    added, and a frame where the network found no one stays empty whatever the
    subtraction found (with nothing after it that shows the person)."""
    config = SilhouetteConfig()
    learned_mask = np.zeros((2, 120, 160), bool)
    learned_mask[0, 30:100, 60:85] = True  # the body
    subtracted = np.zeros_like(learned_mask)
    subtracted[0, 30:70, 61:84] = True  # the upper body, a pixel thinner: legs lost
    subtracted[0, 40:44, 84:110] = True  # an arm the network rounded off
    subtracted[0, 100:106, 100:150] = True  # a shadow on the floor, away from it
    subtracted[1, 30:100, 60:85] = True  # something moved where the network saw no one
    fused = fuse_masks(learned_mask, subtracted, config)
    assert fused[0, 30:100, 60:85].all() and fused[0, 40:44, 84:87].all()
    assert not fused[0, :, 88:].any() and not fused[0, 100:, :].any()
    assert not fused[0, 100:106, 100:150].any()
    assert not fused[1].any()
    with pytest.raises(InvalidParameterError, match="one shape"):
        fuse_masks(learned_mask, subtracted[:1], config)


def test_a_person_the_networks_lose_between_two_frames_comes_from_the_subtraction():
    """Seven frames; the networks find the person in 0-1 and 5-6 only. Between them the
    subtraction's person is taken where it stands in the box around theirs at about
    their size (frame 2, a step aside), not a shadow off to the side (3) nor a speck
    (4). After the person's last frame nothing is filled: nothing after it shows the
    person stayed."""
    config = SilhouetteConfig()
    learned_mask = np.zeros((7, 120, 160), bool)
    subtracted = np.zeros_like(learned_mask)
    for i in (0, 1, 5, 6):
        learned_mask[i, 30:100, 60:85] = subtracted[i, 30:100, 60:85] = True
    subtracted[2, 31:100, 63:88] = True  # the person, a step aside
    subtracted[3, 100:110, 120:159] = True  # a shadow beyond the box
    subtracted[4, 60:66, 70:76] = True  # a speck: not the person's size
    fused = fuse_masks(learned_mask, subtracted, config)
    assert np.array_equal(fused[2], subtracted[2])
    assert not fused[3].any() and not fused[4].any()
    assert np.array_equal(fused[[0, 1, 5, 6]], learned_mask[[0, 1, 5, 6]])
    ends = fuse_masks(learned_mask[:3], subtracted[:3], config)  # frame 2 the last
    assert not ends[2].any()


def test_where_the_network_lost_part_of_the_person_the_subtraction_s_pieces_come_whole():
    """Four frames of one person. In the third the network found only the upper body
    (colours like the scene's): there the subtraction's piece that touches it comes
    whole (the legs and an arm). In the first two the subtraction sees the body the
    network sees (covers 80 % of it or more): the arm the network lost comes whole, a
    line a pixel thick that touches the head (the seam of a wall) does not. In the
    last it covers less (the legs lost to it): the two-pixel rule. A piece apart from
    the body (a shadow) never comes."""
    config = SilhouetteConfig()
    learned_mask = np.zeros((4, 120, 160), bool)
    learned_mask[[0, 1, 3], 20:100, 60:85] = True  # the whole body
    learned_mask[2, 20:55, 60:85] = True  # the upper body only
    subtracted = np.zeros_like(learned_mask)
    subtracted[:3, 20:100, 61:84] = True  # the whole body, a pixel thinner (92 %)
    subtracted[3, 20:80, 61:84] = True  # the legs below the knees lost (69 %)
    subtracted[:, 40:44, 84:110] = True  # an arm
    subtracted[:, 104:110, 100:150] = True  # a shadow apart from the body
    subtracted[:2, 22, 20:60] = True  # a seam a pixel thick, touching the head
    fused = fuse_masks(learned_mask, subtracted, config)
    assert fused[2, 20:100, 61:84].all() and fused[:3, 40:44, 84:110].all()
    assert fused[:2, 22, 58:60].all() and not fused[:2, 22, :57].any()
    assert not fused[:, 104:110, 100:150].any()
    assert fused[3, 40:44, 84:87].all() and not fused[3, :, 88:].any()  # two pixels only


def test_what_the_network_takes_for_the_person_but_shows_the_empty_scene_is_taken_out():
    """A person sitting on a stool the network took for part of them: the stool shows
    the empty scene as it is (``plain_scene``) and the subtraction found nothing there,
    so it is taken out.  Kept: a piece the colour of the scene but next to what the
    subtraction found (within two pixels), a piece the subtraction's evidence does not
    call plain (camouflaged clothes), and a piece too small to count."""
    config = SilhouetteConfig()
    learned_mask = np.zeros((1, 120, 160), bool)
    learned_mask[0, 20:80, 60:85] = True  # the seated body
    learned_mask[0, 80:110, 55:90] = True  # the stool below it
    subtracted = np.zeros_like(learned_mask)
    subtracted[0, 20:80, 61:84] = True
    plain = np.zeros_like(learned_mask)
    plain[0, 80:110, 55:90] = True  # the stool: the empty scene as it is
    plain[0, 30:40, 84:85] = True  # a pixel column beside the body, within 2 px
    fused = fuse_masks(learned_mask, subtracted, config, plain)
    assert fused[0, 20:80, 60:85].all() and fused[0, 30:40, 84].all()
    assert not fused[0, 84:110].any()
    kept = fuse_masks(learned_mask, subtracted, config)  # without the evidence: as before
    assert kept[0, 80:110, 55:90].all()
    camouflaged = plain.copy()
    camouflaged[0, 80:110, 55:90] = False
    assert fuse_masks(learned_mask, subtracted, config, camouflaged)[0, 80:110, 55:90].all()
    small = np.zeros_like(plain)
    small[0, 100:104, 80:85] = True  # 20 px: under 2 % of the learned mask
    assert fuse_masks(learned_mask, subtracted, config, small)[0, 100:104, 80:85].all()
    with pytest.raises(InvalidParameterError, match="plain_scene"):
        fuse_masks(learned_mask, subtracted, config, plain[:, :60])


def test_fused_masks_follow_the_person_the_background_image_shows():
    """The kick sample with its background image: the fused masks keep what the learned
    ones find but the few pieces of wall and floor the networks took for the pink dress
    (under 5 % of the learned pixels), and overlap the subtraction's at least as well."""
    video = SAMPLES / "kick.mp4"
    background = SAMPLES / "kick_background.png"
    fused = load_clip_masks(video, background, QUERY_CONFIG, 15.0, segmenter="auto")
    assert fused.segmenter == "fused"
    cut, overlap = _cut_and_reference("kick")
    reference = load_clip_masks(video, background, QUERY_CONFIG, 15.0, segmenter="subtraction")
    lost = np.count_nonzero(cut.masks & ~fused.masks)
    assert lost <= 0.05 * np.count_nonzero(cut.masks)
    both = np.array([_iou(a, b) for a, b in zip(fused.masks, reference.masks, strict=True)])
    assert np.median(both) >= np.median(overlap)


def test_where_the_subtraction_finds_no_one_the_fused_masks_are_the_learned_ones(tmp_path):
    """An image of the scene taken with the person standing in it: nothing differs from
    it, so the subtraction finds no one; the networks still do, and their masks stand."""
    frames, fps = read_frames(SAMPLES / "walk_3s.mp4")
    still = np.repeat(frames[45:46], 12, axis=0)
    clip = write_video(still, tmp_path / "still.mp4", fps)
    scene = tmp_path / "scene.png"
    cv2.imwrite(str(scene), read_frames(clip)[0][0][..., ::-1])  # the person in it
    with pytest.raises(VideoError, match="no person found"):
        load_clip_masks(clip, scene, QUERY_CONFIG, 15.0, segmenter="subtraction")
    fused = load_clip_masks(clip, scene, QUERY_CONFIG, 15.0, segmenter="fused")
    networks = replace(QUERY_CONFIG, drop_seen_scene=False)
    learned_only = load_clip_masks(clip, None, networks, 15.0, segmenter="learned")
    assert fused.segmenter == "fused" and fused.masks.any(axis=(1, 2)).all()
    np.testing.assert_array_equal(fused.masks, learned_only.masks)


def _stool_clip() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A person walks up to a stool and sits on it: (16, 120, 160, 3) frames, the true
    person (16, 120, 160) and the learned masks, which take the stool for part of the
    person in the last four frames."""
    rng = np.random.default_rng(0)
    scene = rng.integers(60, 200, size=(120, 160, 3), dtype=np.uint8)
    scene[80:110, 95:125] = (200, 200, 210)  # the stool
    n = 16
    frames = np.repeat(scene[None], n, axis=0)
    person = np.zeros((n, 120, 160), bool)
    for i in range(n):  # walks in from the left for three frames, then sits
        x = (10, 40, 70)[i] if i < 3 else 82
        person[i, 30 : 80 if i >= 3 else 110, x : x + 22] = True
    frames[person] = (180, 40, 40)
    frames = np.clip(frames + rng.normal(0, 2, frames.shape), 0, 255).astype(np.uint8)
    learned_mask = person.copy()
    learned_mask[12:, 80:110, 95:125] = True  # the stool taken for the person
    return frames, person, learned_mask


def test_without_the_image_what_the_clip_shows_as_scene_is_taken_out():
    """Without an image of the empty scene, the scene is what the clip shows where the
    person is not.  A person walks up to a stool and sits on it for most of the clip;
    the networks take the stool for part of them in the last four frames.  The stool
    shows in the other frames, so it is taken out of those masks; the seated person,
    whose place the clip hardly ever shows empty, keeps every pixel, and so does someone
    who never moves at all."""
    config = SilhouetteConfig()
    frames, person, learned_mask = _stool_clip()
    n = len(frames)
    out = without_seen_scene(learned_mask, frames, config)
    assert not out[12:, 84:110, 100:125].any()
    assert (out & person).sum() == person.sum()  # every pixel of the person kept
    seen = seen_scene(frames, learned_mask, config)
    assert seen.seen[84:110, 100:125].all() and not seen.seen[30:80, 84:102].any()
    assert np.abs(seen.image[90:100, 105:115].astype(int) - (200, 200, 210)).max() <= 6
    still = np.repeat(frames[-1:], n, axis=0)
    np.testing.assert_array_equal(
        without_seen_scene(learned_mask[-1:].repeat(n, 0), still, config),
        learned_mask[-1:].repeat(n, 0),
    )
    with pytest.raises(InvalidParameterError, match="person must have shape"):
        seen_scene(frames, learned_mask[:, :60], config)


def _scene_pieces_over_the_whole_frame(mine, theirs, plain):
    """The rule of :func:`~eigmotion.segmentation.fused._scene_pieces`, worked over the
    whole frame."""
    near = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * SCENE_NEAR_PX + 1,) * 2)
    found = cv2.dilate(theirs.astype(np.uint8), near).astype(bool)
    scene = cv2.morphologyEx((mine & plain & ~found).astype(np.uint8), cv2.MORPH_OPEN,
                             np.ones((3, 3), np.uint8))  # fmt: skip
    _, pieces, stats, _ = cv2.connectedComponentsWithStats(scene, connectivity=8)
    big = stats[:, cv2.CC_STAT_AREA] >= SCENE_PIECE_SHARE * np.count_nonzero(mine)
    big[0] = False
    return big[pieces]


def test_the_seen_scene_rule_segments_only_frames_that_can_lose_a_piece():
    """Without the image, the subtraction against the scene the clip shows segments only
    the chunks of frames where the learned mask holds a piece of plain scene large
    enough to be taken out; the answer is the same to the pixel as segmenting every
    frame and looking at every frame's pieces over the whole frame."""
    frames, _, learned_mask = _stool_clip()
    config = replace(SilhouetteConfig(), upper_body_frac=0.0)
    scene = seen_scene(frames, learned_mask, config)
    every = subtract_scene(frame_chunks(frames), scene.image, config)
    assert every.wanted.all()
    later = subtract_scene(
        frame_chunks(frames), scene.image, config,
        frames_wanted=lambda plain: np.arange(len(plain)) >= 12,
    )  # fmt: skip
    chunk = CHUNK_FRAMES
    np.testing.assert_array_equal(later.wanted, np.arange(16) >= 12)
    np.testing.assert_array_equal(later.masks[chunk:], every.masks[chunk:])
    assert not later.masks[:chunk].any() and every.masks[:chunk].any()
    np.testing.assert_array_equal(later.plain_scene, every.plain_scene)

    expected = learned_mask.copy()
    for mine, theirs, plain, kept in zip(
        learned_mask, every.masks, every.plain_scene, expected, strict=True
    ):
        kept &= ~_scene_pieces_over_the_whole_frame(mine, theirs, plain & scene.seen)
    assert (expected != learned_mask).any()
    np.testing.assert_array_equal(without_seen_scene(learned_mask, frames, config), expected)
    rng = np.random.default_rng(1)
    for _ in range(200):  # at the frame's edges too
        seeds = (rng.random((40, 50)) < 0.01).astype(np.uint8)
        mine = cv2.dilate(seeds, None, iterations=4).astype(bool)
        mine[:, :3] |= rng.random((40, 1)) < 0.7
        theirs, plain = rng.random((40, 50)) < 0.004, rng.random((40, 50)) < 0.97
        np.testing.assert_array_equal(
            _scene_pieces(mine, theirs, plain),
            _scene_pieces_over_the_whole_frame(mine, theirs, plain),
        )
        # nothing subtracted: the same as an empty subtraction
        np.testing.assert_array_equal(
            _scene_pieces(mine, None, plain),
            _scene_pieces_over_the_whole_frame(mine, np.zeros_like(mine), plain),
        )


def test_without_the_image_the_learned_masks_lose_only_scene():
    """The walk sample without its background image: what the rule takes out of the
    learned masks is, by the empty-scene image the sample comes with, nearly all scene
    (the subtraction against that image finds at most a tenth of it), and the masks
    overlap the subtraction's masks at least as well as before."""
    video = SAMPLES / "walk_3s.mp4"
    background = SAMPLES / "walk_3s_background.png"
    networks = replace(QUERY_CONFIG, drop_seen_scene=False)
    before = load_clip_masks(video, None, networks, 15.0, segmenter="learned").masks
    after = load_clip_masks(video, None, QUERY_CONFIG, 15.0, segmenter="learned").masks
    reference = load_clip_masks(video, background, QUERY_CONFIG, 15.0, segmenter="subtraction")
    taken = before & ~after
    assert not (after & ~before).any()
    assert np.count_nonzero(taken & reference.masks) <= 0.1 * max(np.count_nonzero(taken), 1)
    iou = [np.median([_iou(a, b) for a, b in zip(m, reference.masks, strict=True)])
           for m in (before, after)]  # fmt: skip
    assert iou[1] >= iou[0]


@pytest.mark.parametrize("kind", ["25fps", "24fps", "folder", "gif"])
def test_fused_masks_of_clips_of_every_rate_and_kind(tmp_path, kind):
    """The fused front end cuts each frame twice (the networks, the subtraction) from one
    reading: videos at 24 and 25 frames/s whose last frame the 15 frames/s sample leaves
    out, a folder of images at 30 and a GIF each give one mask per sampled frame, the
    same as the learned masks' frames, and find the person in nearly all of them."""
    frames, fps = read_frames(SAMPLES / "walk_3s.mp4")
    background = SAMPLES / "walk_3s_background.png"
    if kind in ("25fps", "24fps"):  # 74 and 71 frames: the last is not in the sample
        rate, n = (25.0, 74) if kind == "25fps" else (24.0, 71)
        times = np.arange(n) / rate
        clip = write_video(frames[np.rint(times * fps).astype(int)], tmp_path / "c.mp4", rate)
    elif kind == "folder":
        clip = tmp_path / "frames"
        clip.mkdir()
        for i, frame in enumerate(frames[:40]):
            cv2.imwrite(str(clip / f"f{i}.png"), frame[..., ::-1])
    else:
        clip = write_video(frames[:40:2], tmp_path / "c.gif", fps / 2 + 5)  # 20 frames/s
    fused = load_clip_masks(clip, background, QUERY_CONFIG, 15.0, segmenter="fused")
    learned_only = load_clip_masks(clip, None, QUERY_CONFIG, 15.0, segmenter="learned")
    assert fused.segmenter == "fused"
    assert len(fused.masks) == len(fused.frame_indices) == len(learned_only.frame_indices) > 1
    np.testing.assert_array_equal(fused.frame_indices, learned_only.frame_indices)
    assert fused.masks.any(axis=(1, 2)).mean() >= 0.9  # (a GIF's palette loses a frame)
    # the fused masks add to the learned (a small piece of a learned mask may fall to
    # the rule on big pieces, once the subtraction has made the person larger)
    lost = np.count_nonzero(learned_only.masks & ~fused.masks)
    assert lost <= 0.01 * np.count_nonzero(learned_only.masks), lost


def test_a_dim_clip_is_brightened_for_the_networks_and_a_lit_one_is_not():
    """One gain for the whole clip brings the 99th percentile of its brightness to
    BRIGHT_LEVEL (at most MAX_GAIN); the filter after it takes out much of the noise
    the gain multiplied and keeps the person's edges; a clip lit well enough is the
    same array; the switch is validated."""
    rng = np.random.default_rng(0)

    def scene(person, noise=2.0):  # a dark room, a brighter figure in it
        frames = np.full((6, 60, 80, 3), 8.0)
        frames[:, 10:50, 30:45] = person
        noisy = np.rint(frames + rng.normal(0, noise, frames.shape))
        return np.clip(noisy, 0, 255).astype(np.uint8)

    lit = scene(150.0)
    assert learned.brightened(lit) is lit
    dim = scene(58.0)
    level = np.percentile(dim[:, ::4, ::4].mean(axis=-1), 99)
    assert level < learned.DIM_LEVEL
    gain = learned.BRIGHT_LEVEL / level
    bright = learned.brightened(dim)
    assert bright.dtype == np.uint8 and bright.shape == dim.shape
    inside, outside = bright[:, 12:48, 32:43].astype(float), bright[:, :, :25].astype(float)
    assert abs(np.median(inside) - gain * 58.0) < 6
    assert abs(np.median(outside) - gain * 8.0) < 6
    assert outside.std() < 0.6 * gain * 2.0  # the noise, smoothed
    edge = bright[:, 30, 28:32].mean(axis=(0, 2))  # two pixels each side of the edge
    assert edge[0] < 2 * gain * 8.0 and edge[-1] > 0.8 * gain * 58.0, edge
    night = scene(12.0, noise=1.0)  # the gain capped
    assert abs(np.median(learned.brightened(night)[:, 12:48, 32:43]) - 4 * 12) <= 4
    assert learned.brightened(lit[:0]).shape == (0, 60, 80, 3)
    with pytest.raises(InvalidParameterError, match="brighten_dim"):
        SilhouetteConfig(brighten_dim="yes")


def test_a_person_in_the_dark_is_found_brightened(tmp_path):
    """The kick sample at a fifth of its light with sensor noise, written as video:
    the networks find the person in half the frames or fewer as it is, in nearly all
    of them brightened, where the masks overlap the subtraction's of the lit clip
    (measured: 11 and 23 of 23 frames, median IoU 0.00 and 0.84)."""
    frames, fps = read_frames(SAMPLES / "kick.mp4")
    rng = np.random.default_rng(0)
    night = np.clip(np.rint(frames * 0.2 + rng.normal(0, 4, frames.shape)), 0, 255)
    video = write_video(night.astype(np.uint8), tmp_path / "night.mp4", fps)
    reference = load_clip_masks(
        SAMPLES / "kick.mp4", SAMPLES / "kick_background.png", QUERY_CONFIG, 15.0,
        segmenter="subtraction",
    ).masks  # fmt: skip
    found = {}
    for on in (False, True):
        config = replace(QUERY_CONFIG, brighten_dim=on)
        try:
            cut = load_clip_masks(video, None, config, 15.0, segmenter="learned").masks
        except VideoError:  # no person in any frame
            cut = np.zeros_like(reference)
        overlap = [_iou(a, b) for a, b in zip(cut, reference, strict=True)]
        found[on] = (int(cut.any(axis=(1, 2)).sum()), float(np.median(overlap)))
    assert found[False][0] <= len(reference) // 2, found
    assert found[True][0] >= len(reference) - 2 and found[True][1] >= 0.7, found


def test_a_crop_goes_back_where_it_was_cut():
    """:func:`crop_input` and :func:`crop_probabilities_back` are inverse maps: a
    bright square in a frame, cut out, taken as probabilities and put back on the
    working size, lands on the square shrunk to that size, and nothing outside the
    cut square is set."""
    frame = np.zeros((240, 320, 3), np.uint8)
    frame[100:160, 200:240] = 255
    view, matrix = crop_input(frame, (220.0, 130.0, 128.0))
    assert view.shape == (256, 256, 3) and view.dtype == np.uint8
    assert view[..., 0].mean() > 0.1 * 255  # zoomed twice: the square fills a good part
    back = crop_probabilities_back(
        view[..., 0].astype(np.float32) / 255.0, matrix, frame.shape[:2], (120, 160)
    )
    expected = np.zeros((120, 160), bool)
    expected[50:80, 100:120] = True
    assert _iou(back > 0.5, expected) > 0.9
    assert back[:, :75].max() == 0 and back[:, 146:].max() == 0  # outside the cut square


def test_probabilities_lie_in_0_1_and_a_blank_frame_has_no_person():
    blank = np.full((240, 320, 3), 128, np.uint8)
    frames = read_frame_sample(SAMPLES / "kick.mp4", 15.0).frames[-3:]
    inputs = np.stack([model_input(f) for f in [blank, *frames]])
    p = person_probabilities(inputs)
    assert p.shape == (4, 256, 256) and p.dtype == np.float32
    assert 0.0 <= p.min() and p.max() <= 1.0
    assert (p[0] > 0.5).mean() < 0.01
    assert all((q > 0.5).mean() > 0.05 for q in p[1:])
    with pytest.raises(InvalidParameterError, match="network inputs"):
        person_probabilities(frames)


@pytest.mark.skipif(
    importlib.util.find_spec("ai_edge_litert") is None,
    reason="the LiteRT runtime (pip install ai-edge-litert) is not installed",
)
def test_litert_and_opencv_runtimes_agree():
    """Both runtimes read the one shipped file: the same probabilities."""
    assert learned.runtime() == "litert"
    frames = read_frame_sample(SAMPLES / "kick.mp4", 5.0).frames[:4]
    x = np.stack([model_input(f) for f in frames]).astype(np.float32) / 255.0
    _, run_litert = learned.selfie_network()
    net = cv2.dnn.readNetFromTFLite(str(MODEL_PATH))
    for frame in x:
        net.setInput(np.ascontiguousarray(frame.transpose(2, 0, 1)[None]))
        np.testing.assert_allclose(run_litert(frame), net.forward()[0, 0], atol=2e-3)


def test_person_in_frame_keeps_the_person_and_counts_people_beside_it():
    config = SilhouetteConfig()
    mask = np.zeros((120, 160), bool)
    mask[30:100, 20:45] = True  # a person
    mask[15:27, 27:38] = True  # their head, cut off above
    person, people = person_in_frame(mask, config)
    np.testing.assert_array_equal(person, mask)
    assert people == 1
    mask[35:100, 100:122] = True  # someone beside them
    mask[2:5, 150:153] = True  # a speck
    person, people = person_in_frame(mask, config)
    assert people == 2
    assert not person[:, 90:].any() and person[30:100, 20:45].all()
    empty, nobody = person_in_frame(np.zeros((120, 160), bool), config)
    assert not empty.any() and nobody == 0


def test_people_in_view_needs_a_third_of_the_frames():
    assert people_in_view(np.array([1, 1, 1, 2, 1, 1])) == 1  # a stray blob
    assert people_in_view(np.array([1, 2, 2, 1, 2, 1])) == 2
    assert people_in_view(np.array([], np.int64)) == 0


def test_resolve_segmenter():
    assert resolve_segmenter("auto", False) == "learned"
    assert resolve_segmenter("auto", True) == "fused"
    assert resolve_segmenter("subtraction", False) == "subtraction"
    assert resolve_segmenter("subtraction", True) == "subtraction"
    assert resolve_segmenter("learned", False) == "learned"
    assert resolve_segmenter("fused", True) == "fused"
    with pytest.raises(InvalidParameterError, match="empty scene"):
        resolve_segmenter("learned", True)
    with pytest.raises(InvalidParameterError, match="needs an image of the empty scene"):
        resolve_segmenter("fused", False)
    with pytest.raises(InvalidParameterError, match="segmenter must be one of"):
        resolve_segmenter("grabcut", False)


def test_learned_masks_of_every_frame_match_the_sampled_ones(db_path):
    """The 3D answer's masks of every frame are cut as the answer's are: where the
    frames are the same, the masks overlap (the second pass's boxes and the outlier
    rule see the neighbouring frames, which differ)."""
    kick = SAMPLES / "kick.mp4"
    with MotionDatabase.open(db_path) as db:
        sampled, clip = db.query_clip(kick)
        every, whole = db.query_clip(kick, every_frame=True)
    assert clip.segmenter == whole.segmenter == "learned"
    pairs = zip(whole.masks[clip.frame_indices], clip.masks, strict=True)
    overlap = np.array([_iou(a, b) for a, b in pairs if a.any() and b.any()])
    assert len(overlap) >= 0.7 * len(clip.masks) and np.median(overlap) >= 0.9
    assert sampled.best.entry_id == every.best.entry_id and sampled.warnings == ()


def _side_by_side(tmp_path: Path) -> Path:
    """The kick sample's silhouettes (cut against its background image) beside their
    mirror image: two people in one ``.npz`` of masks."""
    kick = load_clip_masks(SAMPLES / "kick.mp4", SAMPLES / "kick_background.png")
    path = tmp_path / "two_people.npz"
    masks = np.concatenate([kick.masks, kick.masks[:, :, ::-1]], axis=2)
    np.savez_compressed(path, masks=masks, fps=np.float64(kick.fps))
    return path


def test_query_warns_when_two_people_are_in_view(db_path, tmp_path, capsys):
    clip = _side_by_side(tmp_path)
    assert main(["query", str(clip), "--db", str(db_path), "--json"]) == 0
    answer = json.loads(capsys.readouterr().out)
    assert len(answer["warnings"]) == 1 and "2 people in view" in answer["warnings"][0]
    assert main(["query", str(clip), "--db", str(db_path)]) == 0
    text = capsys.readouterr().out
    assert "  warning: 2 people in view" in text
    # One person: no warning.
    one = SAMPLES / "kick.mp4"
    assert main(["query", str(one), "--db", str(db_path), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["warnings"] == []


def test_lost_person_warning_names_the_frames():
    """Few empty frames: no warning; many: their count and the clip frames, in runs."""
    empty = np.zeros(20, bool)
    assert lost_person_warning(empty, np.arange(20)) is None
    empty[7] = True  # one of 20: under the share
    assert lost_person_warning(empty, np.arange(20)) is None
    empty[[3, 4, 5, 10, 15, 16, 18]] = True
    warning = lost_person_warning(empty, 2 * np.arange(20))
    assert warning.startswith(
        "no person found in 8 of 20 frames taken (clip frames 6-10, 14, 20 and"
    )
    assert "2 more)" in warning


def test_query_warns_when_the_person_is_lost_in_many_frames(db_path, tmp_path, capsys):
    """Frames 12-29 of the kick sample replaced by its empty scene: the answer says in
    which frames no person was found; the clip as it is gets no such warning."""
    kick, background = SAMPLES / "kick.mp4", SAMPLES / "kick_background.png"
    frames, fps = read_frames(kick)
    frames[12:30] = read_image_rgb(background)
    clip = write_video(frames, tmp_path / "gone.mp4", fps)
    argv = ["query", str(clip), "--db", str(db_path), "--background", str(background)]
    assert main([*argv, "--json"]) == 0
    warnings = json.loads(capsys.readouterr().out)["warnings"]
    lost = [w for w in warnings if w.startswith("no person found in")]
    assert len(lost) == 1, warnings
    # the empty frames' runs, in clip frames: from the first replaced frame to the last
    # (the network may take a piece of the empty scene for a person in one or two)
    runs = re.search(r"clip frames ([^)]*)\)", lost[0])[1].split(", ")
    assert 12 <= int(runs[0].split("-")[0]) <= 13 and 26 <= int(runs[-1].split("-")[-1]) <= 29
    assert main(argv) == 0
    assert "  warning: no person found in" in capsys.readouterr().out
    argv[1] = str(kick)
    assert main([*argv, "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["warnings"] == []


def test_query_segmenter_switch(db_path, capsys):
    clip, background = SAMPLES / "walk_3s.mp4", SAMPLES / "kick_background.png"
    for segmenter in ("learned", "subtraction"):
        argv = ["query", str(clip), "--db", str(db_path), "--segmenter", segmenter, "--json"]
        assert main(argv) == 0
        assert json.loads(capsys.readouterr().out)["label"]
    argv = ["query", str(clip), "--db", str(db_path), "--background", str(background)]
    assert main([*argv, "--segmenter", "learned"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "learned segmenter" in err[0]
    with pytest.raises(SystemExit):
        main(["query", str(clip), "--db", str(db_path), "--segmenter", "magic"])


def test_network_threads_must_be_positive():
    from eigmotion.segmentation import networks

    with pytest.raises(ValueError, match="at least 1"):
        networks.set_network_threads(0)
    before = networks._network_threads
    try:
        networks.set_network_threads(1)
        assert networks._threads() == 1
    finally:
        networks._network_threads = before


def test_a_long_clip_shows_the_networks_progress(monkeypatch):
    """With ``progress``, once the work has taken the bar's delay (here none), a bar
    counts the frames the person networks have looked at; without it, none shows."""
    import io

    from tqdm import tqdm

    shown = io.StringIO()

    def bar(total, desc, initial=0):
        return tqdm(total=total, initial=initial, desc=desc, file=shown)

    monkeypatch.setattr(learned, "FRAME_BAR_DELAY_S", 0.0)
    monkeypatch.setattr(learned, "progress_bar", bar)
    clip = load_clip_masks(SAMPLES / "kick.mp4", None, QUERY_CONFIG, 15.0, segmenter="learned")
    assert shown.getvalue() == ""
    again = load_clip_masks(
        SAMPLES / "kick.mp4", None, QUERY_CONFIG, 15.0, progress=True, segmenter="learned"
    )
    n = len(again.masks)
    assert "finding the person" in shown.getvalue() and f"{n}/{n}" in shown.getvalue()
    np.testing.assert_array_equal(clip.masks, again.masks)
