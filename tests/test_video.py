"""The video front end and the synthetic scene composer.

The done-when checks use the real avatar: a walk rendered by pyrender (the frames)
and by the CPU rasteriser (the true silhouettes), composed over a textured background
with a cast shadow, camouflaged clothing and sensor noise.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from eigmotion.body.retarget import animate_avatar
from eigmotion.errors import InvalidParameterError, VideoError
from eigmotion.retrieval.motion_image import motion_image
from eigmotion.segmentation import background as scene_estimate
from eigmotion.segmentation import evidence, subtraction, workers
from eigmotion.segmentation.background import (
    COLOUR_PER_NOISE,
    MIN_COLOUR_LEVELS,
    _commonest_colours,
    _pieces_reaching,
    estimate_background,
    find_still_body,
)
from eigmotion.segmentation.config import SilhouetteConfig
from eigmotion.segmentation.evidence import grid_step
from eigmotion.segmentation.video import (
    DEFAULT_NPZ_FPS,
    extract_silhouettes,
    load_clip_masks,
    read_background,
)
from eigmotion.synth.scene import (
    compose_scene,
    compose_scene_with_layout,
    procedural_background,
    stick_figure_masks,
)


def iou(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(F,) intersection over union of two (F, H, W) bool stacks."""
    return (a & b).sum(axis=(1, 2)) / np.maximum((a | b).sum(axis=(1, 2)), 1)


def cosine_distance(a: np.ndarray, b: np.ndarray) -> float:
    return float(1.0 - np.dot(a, b) / (np.linalg.norm(a) * np.linalg.norm(b)))


def write_png(path, rgb):
    cv2.imwrite(str(path), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
    return path


@pytest.fixture(scope="module")
def stick_scene():
    """A small synthetic clip: stick figure walking over a composed scene."""
    masks = stick_figure_masks(30, 120, 160, fps=30.0, body_height_px=90.0, walk_speed_px_s=60.0)
    frames, background, layout = compose_scene_with_layout(None, masks, np.random.default_rng(1))
    return masks, frames, background, layout


@pytest.fixture(scope="module")
def avatar_clip(cmu_dir):
    """1.5 s of the avatar walking (CMU 02_01) seen from its side at 160×120, 30 fps:
    shaded frames (pyrender, no floor) and true masks (CPU rasteriser)."""
    from eigmotion.body.avatar import DEFAULT_LOW_POLY_FACES, load_default_avatar
    from eigmotion.imaging.cameras import ring_rig
    from eigmotion.imaging.render import render_shaded
    from eigmotion.imaging.silhouettes import render_masks
    from eigmotion.mocap.amc import read_amc

    motion = read_amc(cmu_dir / "amc" / "02_01.amc", cmu_dir / "asf" / "02.asf")
    motion = motion.trim(0, 181).resample(30.0)
    body = load_default_avatar().decimated(DEFAULT_LOW_POLY_FACES)
    _, vertices = animate_avatar(body, motion)
    camera = ring_rig(4, 10.0, width=160, height=120).fitted(vertices[:, ::10])[1]
    masks = render_masks(vertices, body.faces, camera)
    rgb = render_shaded(vertices, body.faces, camera, floor=False)
    return rgb, masks


def _on_the_spot(motion_name: str):
    """A library motion performed on the spot by the avatar, seen from azimuth 30°,
    elevation 10°, at 160×120 and 15 fps, over a textured background with a cast
    shadow, camouflaged clothing and noise (scene seed 0): in view, and mostly in the
    same place, from the first frame to the last."""
    from eigmotion.body.avatar import load_default_avatar
    from eigmotion.mocap.library import find_motion
    from eigmotion.synth.clips import render_clip

    return render_clip(
        find_motion(motion_name),
        load_default_avatar(),
        30.0,
        10.0,
        np.random.default_rng(0),
        width=160,
        height=120,
        fps=15.0,
    )


@pytest.fixture(scope="module")
def lift_scene():
    """The avatar taking a heavy box up from the floor to its chest
    (pick_up_heavy_box_to_chest, 56 frames)."""
    return _on_the_spot("pick_up_heavy_box_to_chest")


@pytest.fixture(scope="module")
def wave_scene():
    """The avatar waving both hands above its head (wave_both_hands): the torso and the
    legs stand still between and below the arms for the whole clip."""
    return _on_the_spot("wave_both_hands")


@pytest.fixture(scope="module")
def avatar_scene(avatar_clip):
    rgb, masks = avatar_clip
    frames, background, layout = compose_scene_with_layout(
        rgb, masks, np.random.default_rng(0), shadow=True, camouflage=0.25, noise_sigma=3.0
    )
    assert layout.shadow_masks.any() and layout.camouflage_masks.any()
    return frames, background, masks


# -- the done-when checks --------------------------------------------------------------


@pytest.mark.parametrize("background_given", [True, False], ids=["background", "estimated"])
def test_recovers_the_avatar_from_a_textured_shadowed_noisy_video(avatar_scene, background_given):
    frames, background, truth = avatar_scene
    masks = extract_silhouettes(frames, background if background_given else None)
    overlap = iou(masks, truth)
    assert overlap.mean() >= 0.85, f"mean IoU {overlap.mean():.3f}"
    assert overlap.min() >= 0.7, f"worst frame IoU {overlap.min():.3f}"


@pytest.mark.parametrize("suffix", [".mp4", ".avi"])
def test_written_and_read_back_gives_the_same_motion_image(avatar_scene, tmp_path, suffix):
    from eigmotion.imaging.media import write_video

    frames, background, truth = avatar_scene
    direct = motion_image(extract_silhouettes(frames), clip_fps=30.0)
    path = write_video(frames, tmp_path / f"clip{suffix}", 30.0)
    clip = load_clip_masks(path)
    masks, fps = clip.masks, clip.fps
    assert masks.shape == truth.shape and fps == pytest.approx(30.0)
    assert cosine_distance(motion_image(masks, clip_fps=fps), direct) < 0.05
    assert cosine_distance(motion_image(truth, clip_fps=30.0), direct) < 0.05


def test_background_image_from_a_file(avatar_scene, tmp_path):
    from eigmotion.imaging.media import write_video

    frames, background, truth = avatar_scene
    path = write_video(frames, tmp_path / "clip.avi", 30.0)
    masks = load_clip_masks(path, write_png(tmp_path / "empty.png", background)).masks
    assert iou(masks, truth).mean() >= 0.8


def test_person_staying_in_place_without_a_background(lift_scene):
    truth = lift_scene.true_masks
    overlap = iou(extract_silhouettes(lift_scene.frames), truth)  # grabcut, the default
    assert overlap.mean() >= 0.75, f"mean IoU {overlap.mean():.3f}"
    assert overlap.min() >= 0.65, f"worst frame IoU {overlap.min():.3f}"
    # The temporal median keeps the body that stays in place (the test can fail).
    median = SilhouetteConfig(background="median")
    assert iou(extract_silhouettes(lift_scene.frames, None, median), truth).mean() < 0.6


def test_still_body_between_two_moving_arms_without_a_background(wave_scene):
    # The gap between the arms is open below: the still torso is found all the same.
    overlap = iou(extract_silhouettes(wave_scene.frames), wave_scene.true_masks)
    assert overlap.mean() >= 0.5, f"mean IoU {overlap.mean():.3f}"


@pytest.mark.parametrize("background_given", [True, False], ids=["background", "estimated"])
def test_masks_do_not_depend_on_the_chunks_frames_are_segmented_in(
    avatar_scene, monkeypatch, background_given
):
    frames, background, _ = avatar_scene
    given = background if background_given else None
    reference = extract_silhouettes(frames, given)
    for chunk in (1, 3, len(frames)):
        monkeypatch.setattr(subtraction, "CHUNK_FRAMES", chunk)
        np.testing.assert_array_equal(extract_silhouettes(frames, given), reference)


@pytest.mark.parametrize("background_given", [True, False], ids=["background", "estimated"])
def test_masks_cut_in_the_person_region_equal_those_of_the_whole_frames(
    avatar_scene, monkeypatch, background_given
):
    """The second pass segments only the region of a chunk that can hold the person;
    where a region proves too tight the chunk is segmented again over the whole
    frames.  Either way the masks are those of the whole frames."""
    frames, background, _ = avatar_scene
    given = background if background_given else None
    outcomes = []  # per second pass: (over a region, masks found)
    region_masks = subtraction._region_masks

    def recorded(evidence, scene, levels, config, shadow, region):
        masks = region_masks(evidence, scene, levels, config, shadow, region)
        outcomes.append((scene.shape != tuple(scene.frame), masks is not None))
        return masks

    monkeypatch.setattr(subtraction, "_region_masks", recorded)
    cut = extract_silhouettes(frames, given)
    assert (True, True) in outcomes
    outcomes.clear()
    with monkeypatch.context() as whole_frames:
        whole_frames.setattr(subtraction, "MAX_REGION_FRAC", 0.0)
        np.testing.assert_array_equal(extract_silhouettes(frames, given), cut)
    assert outcomes and all(not in_region for in_region, _ in outcomes)
    # Regions shrunk to the seeds' box: the components reach past their edges.
    person_region = subtraction._person_region

    def tight(evidence, scene, levels, shadow):
        region = person_region(evidence, scene, levels, shadow)
        if region is None:
            return None
        y0, y1, x0, x1 = region
        h, w = scene.shape
        cut_in = 2 * subtraction._guard_px(scene)
        return (y0 + cut_in * (y0 > 0), y1 - cut_in * (y1 < h),
                x0 + cut_in * (x0 > 0), x1 - cut_in * (x1 < w))  # fmt: skip

    outcomes.clear()
    monkeypatch.setattr(subtraction, "_person_region", tight)
    np.testing.assert_array_equal(extract_silhouettes(frames, given), cut)
    assert (True, False) in outcomes


def test_a_large_clip_without_a_background_is_shrunk_as_it_is_decoded(avatar_scene, tmp_path):
    """Frames four times the working size give the masks of the whole clip read at full
    size and cut out at once (the frames are shrunk per chunk instead of all together)."""
    from eigmotion.imaging.media import read_frames, write_video

    frames, _, _ = avatar_scene
    large = np.repeat(np.repeat(frames, 2, axis=1), 2, axis=2)  # 320 × 240
    path = write_video(large, tmp_path / "clip.mp4", 30.0)
    config = SilhouetteConfig(work_max_side_px=80)
    streamed = load_clip_masks(path, None, config)
    whole, _ = read_frames(path)
    assert streamed.masks.shape == (len(frames), 60, 80)
    np.testing.assert_array_equal(streamed.masks, extract_silhouettes(whole, None, config))


def test_the_replay_input_panel_is_the_clip_at_the_panel_height(avatar_scene, tmp_path):
    from eigmotion.imaging.media import read_frames, write_video
    from eigmotion.pose.replay import read_input_panel

    frames, _, _ = avatar_scene
    large = np.repeat(np.repeat(frames, 3, axis=1), 3, axis=2)  # 480 × 360
    path = write_video(large, tmp_path / "clip.mp4", 30.0)
    whole, _ = read_frames(path)
    panel = read_input_panel(path, height_px=90)
    expected = [cv2.resize(f, (120, 90), interpolation=cv2.INTER_AREA) for f in whole]
    np.testing.assert_array_equal(panel, np.stack(expected))
    np.testing.assert_array_equal(read_input_panel(path, height_px=360), whole)  # as read


def test_a_clip_segmented_while_it_is_decoded_equals_one_read_whole(avatar_scene, tmp_path):
    from eigmotion.imaging.media import read_frame_sample, write_video

    frames, background, _ = avatar_scene
    path = write_video(frames, tmp_path / "clip.mp4", 30.0)
    empty = write_png(tmp_path / "empty.png", background)
    streamed = load_clip_masks(path, empty, sample_fps=15.0)
    whole = read_frame_sample(path, 15.0)
    np.testing.assert_array_equal(streamed.frame_indices, whole.frame_indices)
    np.testing.assert_array_equal(
        streamed.masks, extract_silhouettes(whole.frames, read_background(empty))
    )


# -- what the front end copes with -------------------------------------------------------


def test_cast_shadow_is_not_the_person(stick_scene):
    masks, frames, background, layout = stick_scene
    found = extract_silhouettes(frames, background)
    shadow_px = layout.shadow_masks.sum()
    assert shadow_px > 0.2 * masks.sum()  # the shadow is there, and big
    assert (found & layout.shadow_masks).sum() < 0.05 * shadow_px
    naive = extract_silhouettes(frames, background, SilhouetteConfig(shadow_ratio=(0.01, 0.02)))
    assert (naive & layout.shadow_masks).sum() > 0.3 * shadow_px  # the test can fail


def test_camouflaged_clothing_stays_attached(stick_scene):
    masks, frames, background, layout = stick_scene
    found = extract_silhouettes(frames, background)
    camo = layout.camouflage_masks
    assert camo.sum() > 0.1 * masks.sum()
    assert (found & camo).sum() > 0.7 * camo.sum()
    assert iou(found, masks).mean() > 0.85


def test_clothing_dark_like_a_shadow_of_the_wall_stays_body(stick_scene):
    """A shirt darker than the wall behind it, with the wall's hue, passes the cast-shadow
    test; beside the upper body (the head above it) it is body, while the floor shadow
    stays excluded."""
    masks, frames, background, layout = stick_scene
    rows = np.arange(masks.shape[1])[None, :, None]
    tops = np.argmax(masks.any(axis=2), axis=1)[:, None, None]
    bottoms = masks.shape[1] - np.argmax(masks.any(axis=2)[:, ::-1], axis=1)[:, None, None]
    shirt = masks & (rows > tops + 0.2 * (bottoms - tops)) & (rows < tops + 0.5 * (bottoms - tops))
    dressed = frames.copy()
    dressed[shirt] = np.broadcast_to(0.75 * background.astype(np.float32), frames.shape)[shirt]
    found = extract_silhouettes(dressed, background)
    assert (found & shirt).sum() > 0.8 * shirt.sum()
    assert (found & layout.shadow_masks).sum() < 0.05 * layout.shadow_masks.sum()
    shadow_only = extract_silhouettes(dressed, background, SilhouetteConfig(upper_body_frac=0.0))
    assert (shadow_only & shirt).sum() < 0.5 * shirt.sum()  # the test can fail


@pytest.mark.parametrize("gain", [0.75, 1.1])
def test_exposure_change_against_a_given_background(stick_scene, gain):
    masks, frames, background, _ = stick_scene
    brighter = np.clip(frames.astype(np.float32) * gain, 0, 255).astype(np.uint8)
    assert iou(extract_silhouettes(brighter, background), masks).mean() > 0.85


def test_exposure_gains_are_the_median_ratios_to_the_background(rng):
    background = rng.integers(0, 256, size=(30, 40, 3), dtype=np.uint8)
    background[..., 2] = 5  # too dark: the channel is left at gain 1
    frames = np.clip(background * np.float32([0.9, 1.2, 1.0]), 0, 255).astype(np.uint8)
    frames = np.stack([frames, background, rng.integers(0, 256, (30, 40, 3), np.uint8)])
    scene = evidence.prepare_scene(background, SilhouetteConfig())
    found = evidence._exposure_gains(frames, scene)
    pixels = frames.reshape(3, -1, 3)
    for c, pick in enumerate(scene.gain_pixels[:2]):
        picked, bg = pick
        ratios = pixels[:, picked, c] / bg
        np.testing.assert_array_equal(found[:, c], np.clip(np.median(ratios, axis=1), 0.5, 2.0))
    assert scene.gain_pixels[2] is None and (found[:, 2] == 1.0).all()
    np.testing.assert_allclose(found[:2, :2], [[0.9, 1.2], [1.0, 1.0]], atol=0.01)


def test_opencv_runs_on_the_calling_threads_only_inside_the_scope():
    import threading

    before = cv2.getNumThreads()
    try:
        cv2.setNumThreads(2)
        entered = threading.Barrier(2)
        leave = threading.Event()
        inside = []

        def hold():
            with workers.opencv_in_calling_threads():
                entered.wait()
                leave.wait()

        other = threading.Thread(target=hold)
        other.start()
        with workers.opencv_in_calling_threads():
            entered.wait()
            with workers.opencv_in_calling_threads():  # nested
                inside.append(cv2.getNumThreads())
            leave.set()
            other.join()  # the other scope ends first: still inside this one
            inside.append(cv2.getNumThreads())
        assert inside == [1, 1]
        assert cv2.getNumThreads() == 2
    finally:
        cv2.setNumThreads(before)


@pytest.mark.parametrize("method, limit", [("median", 6.0), ("grabcut", 4.0), ("mog2", 12.0)])
def test_background_estimate(stick_scene, method, limit):
    """Mean absolute error of the estimated empty scene, 0–255 levels."""
    masks, frames, background, _ = stick_scene
    estimate = estimate_background(frames, SilhouetteConfig(background=method))
    assert estimate.shape == background.shape and estimate.dtype == np.uint8
    error = np.abs(estimate.astype(float) - background).mean()
    assert error < limit, f"{method}: {error:.2f}"


def test_refined_median_removes_the_ghost(stick_scene):
    masks, frames, background, _ = stick_scene
    median = SilhouetteConfig(background="median")
    plain = estimate_background(frames, median)
    refined = estimate_background(frames, median, exclude=extract_silhouettes(frames, None, median))
    err = lambda b: np.abs(b.astype(float) - background).max(axis=2)  # noqa: E731
    assert (err(refined) > 25).mean() <= (err(plain) > 25).mean()


def first_masks(frames: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each pixel's commonest colour over a clip and the person segmented against it."""
    commonest = np.rint(_commonest_colours(frames)).astype(np.uint8)
    return commonest, extract_silhouettes(frames, commonest)


def test_commonest_colour_is_the_scene_where_a_person_covers_it_more_often_than_not(rng):
    frames = (120 + rng.integers(-1, 2, size=(20, 8, 8, 3))).astype(np.uint8)
    # a person over the middle in 12 of the 20 frames, in ever other colours
    frames[:12, 2:6, 2:6] = rng.integers(150, 256, size=(12, 4, 4, 3))
    commonest = _commonest_colours(frames)
    assert commonest.shape == (8, 8, 3) and commonest.dtype == np.float32
    np.testing.assert_allclose(commonest, 120.0, atol=1.0)
    assert np.median(frames, axis=0)[2:6, 2:6].min() > 150  # the median takes the person


@pytest.mark.parametrize("q", [0.5, 0.8])
def test_masked_quantile_is_the_quantile_of_the_samples_left(rng, q):
    sample = rng.integers(0, 256, size=(9, 7, 5, 3), dtype=np.uint8)
    excluded = rng.random((9, 7, 5)) < 0.4
    excluded[:, 2, 3] = True  # a pixel no sample is left of
    found = scene_estimate._masked_quantile(sample, excluded, q)
    for y in range(7):
        for x in range(5):
            left = sample[~excluded[:, y, x], y, x].astype(np.float64)
            if len(left) == 0:
                assert np.isnan(found[y, x]).all()
            else:
                np.testing.assert_allclose(found[y, x], np.quantile(left, q, axis=0))


def test_commonest_colour_is_the_mean_of_the_largest_cluster_by_its_definition(rng):
    """The compiled kernel against every pair compared in numpy: the first sample (in
    frame order) with the most samples within the radius in every channel, and the
    mean of those, with ties, clusters of every size and a spread just over the radius."""
    frames = (100 + rng.integers(-1, 2, size=(23, 12, 13, 3))).astype(np.uint8)  # the scene
    frames[:, 7] = 100 + 3 * rng.integers(0, 3, size=(23, 13, 3))  # a spread just over the radius
    frames[:, 8:] = 60 + 5 * rng.integers(0, 6, size=(23, 4, 13, 3))  # colours the radius apart
    commonest = _commonest_colours(frames)
    f, h, w, _ = frames.shape
    values = frames.reshape(f, h * w, 3).astype(np.int64)
    grid = grid_step(h, w)
    noise = np.median(
        np.abs(np.diff(values.reshape(f, h, w, 3)[:, ::grid, ::grid], axis=0)).max(-1)
    )
    radius = max(MIN_COLOUR_LEVELS, int(COLOUR_PER_NOISE * noise))
    assert radius == 5  # a few levels: clusters of many sizes, and ties, among the colours
    near = np.abs(values[:, None] - values[None, :]).max(axis=-1) <= radius  # (F, F, P)
    best = near.sum(axis=1).argmax(axis=0)  # the first of the largest
    members = near[best, :, np.arange(h * w)]  # (P, F)
    expected = (members[..., None] * values.transpose(1, 0, 2)).sum(1) / members.sum(1)[:, None]
    np.testing.assert_array_equal(commonest.reshape(-1, 3), expected.astype(np.float32))


def test_still_body_is_found_in_the_commonest_colours(lift_scene):
    """Where the person is in just over half of the frames, in changing colours, the
    commonest colour is the scene's: the still body is where they are in more.
    (Measured IoU 0.638 against the pixels the person covers in 60 % of the frames,
    0.566 against 50 %; the median image gave 0.513 and 0.655.)"""
    commonest, first = first_masks(lift_scene.frames)
    body = find_still_body(commonest, lift_scene.frames, first)
    still = lift_scene.true_masks.mean(axis=0) >= 0.6
    assert iou(body.mask[None], still[None])[0] >= 0.6
    assert find_still_body(commonest, lift_scene.frames, np.zeros_like(first)) is None


def test_a_still_body_piece_near_the_moving_person_is_kept_whole():
    cut = np.zeros((40, 30), bool)
    cut[2:30, 10:20] = True  # head to hips: one piece
    cut[34:38, 2:6] = True  # a stray piece of the cut, far from the person
    near = np.zeros_like(cut)
    near[0:8, 5:25] = True  # only the shoulders lie near the waving arms
    kept = _pieces_reaching(cut, near)
    np.testing.assert_array_equal(kept[2:30, 10:20], True)
    assert not kept[34:38, 2:6].any()
    assert kept.sum() == 28 * 10


def test_a_person_crossing_the_picture_leaves_no_still_body(avatar_scene):
    frames, _, truth = avatar_scene
    commonest, first = first_masks(frames)
    body = find_still_body(commonest, frames, first)
    assert body.envelope.sum() > truth.sum(axis=(1, 2)).mean()  # they moved far
    assert body.mask.sum() < 0.05 * truth.sum(axis=(1, 2)).mean()


# -- errors ------------------------------------------------------------------------------


def test_frames_equal_to_the_background_hold_no_person():
    background = procedural_background(60, 80, 30, np.random.default_rng(1))
    frames = np.repeat(background[None], 5, axis=0)
    with pytest.raises(VideoError, match="no person found"):
        extract_silhouettes(frames, background)


def test_a_person_who_never_moves_without_a_background_image_is_told_what_is_needed(
    stick_scene,
):
    _, frames, background, _ = stick_scene
    still = np.repeat(frames[len(frames) // 2][None], 12, axis=0)
    with pytest.raises(VideoError, match="no person found.*a person shows only by moving"):
        extract_silhouettes(still, None)
    assert extract_silhouettes(still, background).all(axis=0).any()  # they are there


def test_a_background_image_of_another_scene_is_named_as_such(stick_scene):
    # The bundled kick clip against the walk clip's empty scene: the same size, but every
    # pixel differs, so the noise level is the scene's difference and no person shows.
    samples = Path(__file__).resolve().parents[1] / "database" / "samples"
    with pytest.raises(VideoError, match=r"differ from the empty scene over most of the picture"):
        load_clip_masks(samples / "kick.mp4", samples / "walk_3s_background.png")
    _, frames, background, _ = stick_scene
    other = procedural_background(*background.shape[:2], 30, np.random.default_rng(7))
    with pytest.raises(VideoError, match=r"median colour difference \d+ ΔE"):
        extract_silhouettes(frames, other)
    # its own empty scene is well under the limit
    assert extract_silhouettes(frames, background).any()


def test_background_of_another_size_names_both_sizes(stick_scene):
    _, frames, background, _ = stick_scene
    with pytest.raises(VideoError, match=r"background is 80×60 pixels but the frames are 160×120"):
        extract_silhouettes(frames, background[:60, :80])


@pytest.mark.parametrize(
    "frames, error, pattern",
    [
        (np.zeros((0, 32, 32, 3), np.uint8), VideoError, "zero frames"),
        (np.zeros((4, 32, 32), np.uint8), InvalidParameterError, r"frames must have shape"),
        (np.zeros((4, 32, 32, 3), np.float32), InvalidParameterError, "frames must be uint8"),
        (np.zeros((4, 4, 4, 3), np.uint8), InvalidParameterError, "at least 8×8"),
    ],
)
def test_bad_frames(frames, error, pattern):
    with pytest.raises(error, match=pattern):
        extract_silhouettes(frames)


def test_bad_background_type(stick_scene):
    _, frames, background, _ = stick_scene
    with pytest.raises(InvalidParameterError, match="background must be"):
        extract_silhouettes(frames, background.astype(np.float32))


@pytest.mark.parametrize(
    "name, value",
    [
        ("background", "gmm"),
        ("max_background_frames", 2),
        ("low_factor", 0.5),
        ("high_factor", 2.0),  # below the default low_factor
        ("min_delta_e", 0.0),
        ("shadow_ratio", (0.9, 0.5)),
        ("shadow_ratio", (0.5,)),
        ("shadow_chroma", 0.8),
        ("upper_body_frac", 1.5),
        ("smooth_sigma_px", -1.0),
        ("close_px", 40),
        ("min_person_frac", 0.0),
        ("keep_piece_frac", 2.0),
        ("small_hole_frac", -0.1),
    ],
)
def test_config_rejects_bad_values(name, value):
    with pytest.raises(InvalidParameterError, match=name):
        SilhouetteConfig(**{name: value})


def test_config_round_trip():
    config = SilhouetteConfig(background="mog2", shadow_ratio=(0.4, 0.9), close_px=3)
    assert SilhouetteConfig.from_dict(config.to_dict()) == config
    with pytest.raises(InvalidParameterError, match="unknown key"):
        SilhouetteConfig.from_dict({"threshold": 3})


# -- loading clips -----------------------------------------------------------------------


@pytest.mark.parametrize("fps", [None, 24.0])
def test_load_npz_masks(tmp_path, fps):
    masks = stick_figure_masks(6, 40, 50, body_height_px=30.0)
    path = tmp_path / "clip.npz"
    if fps is None:
        np.savez(path, masks=masks.astype(np.uint8))
    else:
        np.savez(path, masks=masks, fps=fps)
    clip = load_clip_masks(path)
    loaded, loaded_fps = clip.masks, clip.fps
    np.testing.assert_array_equal(loaded, masks)
    assert loaded.dtype == bool
    assert loaded_fps == (DEFAULT_NPZ_FPS if fps is None else fps)


@pytest.mark.parametrize(
    "arrays, error, pattern",
    [
        ({"silhouettes": np.ones((3, 8, 8), bool)}, InvalidParameterError, "no array 'masks'"),
        ({"masks": np.ones((8, 8), bool)}, InvalidParameterError, r"shape \(F, H, W\)"),
        ({"masks": np.zeros((0, 8, 8), bool)}, VideoError, "zero frames"),
        ({"masks": np.zeros((3, 8, 8), bool)}, VideoError, "no person"),
        ({"masks": np.ones((3, 8, 8), bool), "fps": -1.0}, InvalidParameterError, "fps"),
    ],
)
def test_bad_npz(tmp_path, arrays, error, pattern):
    path = tmp_path / "bad.npz"
    np.savez(path, **arrays)
    with pytest.raises(error, match=pattern):
        load_clip_masks(path)


def test_npz_with_a_background_is_refused(tmp_path):
    path = tmp_path / "clip.npz"
    np.savez(path, masks=np.ones((3, 8, 8), bool))
    with pytest.raises(InvalidParameterError, match="background_path"):
        load_clip_masks(path, tmp_path / "bg.png")


@pytest.mark.parametrize(
    "name, content, pattern",
    [
        ("missing.mp4", None, "no such file"),
        ("garbage.mp4", b"not a video at all", "cannot be opened|no frame"),
        ("garbage.npz", b"not a zip file", "not a readable .npz"),
        ("clip.txt", b"hello", "unknown clip type"),
    ],
)
def test_unreadable_files(tmp_path, name, content, pattern):
    path = tmp_path / name
    if content is not None:
        path.write_bytes(content)
    with pytest.raises(VideoError, match=pattern):
        load_clip_masks(path)


def test_folder_of_frames(stick_scene, tmp_path):
    masks, frames, background, _ = stick_scene
    for i, frame in enumerate(frames[:12]):
        write_png(tmp_path / f"f{i}.png", frame)
    clip = load_clip_masks(tmp_path, write_png(tmp_path.parent / "bg.png", background))
    loaded, fps = clip.masks, clip.fps
    assert loaded.shape == masks[:12].shape and fps > 0
    assert iou(loaded, masks[:12]).mean() > 0.85


def test_background_file_of_another_size(stick_scene, tmp_path):
    _, frames, background, _ = stick_scene
    for i, frame in enumerate(frames[:4]):
        write_png(tmp_path / f"f{i}.png", frame)
    small = write_png(tmp_path.parent / "small.png", background[:100, :150])
    with pytest.raises(VideoError, match="150×100 pixels but the frames are 160×120"):
        load_clip_masks(tmp_path, small)


@pytest.mark.parametrize("content", [None, b"nonsense"])
def test_a_bad_background_stops_the_decoding_of_its_video(tmp_path, content, rng):
    """The video starts decoding while the background is read; no decoding thread is
    left running when that cannot be read: a process that exits on the error while
    FFmpeg is inside one can abort."""
    import threading

    from eigmotion.imaging.media import write_video

    frames = rng.integers(0, 256, size=(240, 120, 160, 3)).astype(np.uint8)
    video = write_video(frames, tmp_path / "clip.mp4", 30.0)
    background = tmp_path / "bg.png"
    if content is not None:
        background.write_bytes(content)
    with pytest.raises(VideoError, match="background image not found|not a readable image"):
        load_clip_masks(video, background)
    assert not [t for t in threading.enumerate() if t.name == "eigmotion-decode"]


@pytest.mark.parametrize("content", [None, b"nonsense"])
def test_unreadable_background_file(tmp_path, content):
    path = tmp_path / "bg.png"
    if content is not None:
        path.write_bytes(content)
    with pytest.raises(VideoError, match="background image not found|not a readable image"):
        read_background(path)


# -- the scene composer ------------------------------------------------------------------


def test_scene_is_seeded(stick_scene):
    masks = stick_scene[0][:4]
    a = compose_scene(None, masks, np.random.default_rng(3))
    b = compose_scene(None, masks, np.random.default_rng(3))
    c = compose_scene(None, masks, np.random.default_rng(4))
    np.testing.assert_array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])
    assert not np.array_equal(a[1], c[1])


@pytest.mark.parametrize("noise_sigma", [0.0, 2.0, 6.0])
def test_scene_noise_level(stick_scene, noise_sigma):
    masks = stick_scene[0][:3]
    frames, background = compose_scene(
        None, masks, np.random.default_rng(2), shadow=False, noise_sigma=noise_sigma
    )
    # Far from the person, a frame and the empty scene differ by two noise draws.
    far = ~np.any(masks, axis=0)
    far[:, :100] = False
    diff = frames[0].astype(float)[far] - background.astype(float)[far]
    assert np.std(diff) == pytest.approx(np.sqrt(2) * noise_sigma, abs=0.6)


def test_shadow_darkens_the_floor_keeping_its_colour(stick_scene):
    masks = stick_scene[0][:5]
    kwargs = dict(noise_sigma=0.0, camouflage=0.0, shadow_strength=0.4)
    lit, _ = compose_scene(None, masks, np.random.default_rng(9), shadow=False, **kwargs)
    dark, _, layout = compose_scene_with_layout(
        None, masks, np.random.default_rng(9), shadow=True, **kwargs
    )
    core = layout.shadow_masks & (cv2.erode(layout.shadow_masks.astype(np.uint8)[0], None) > 0)
    assert core.any()
    assert np.all(np.flatnonzero(core.any(axis=(0, 2))) >= layout.horizon_row)
    ratio = dark[core].astype(float).sum(axis=1) / lit[core].astype(float).sum(axis=1)
    # Full shadow keeps 1 - 0.4 of the light; its soft edges keep more.
    assert np.percentile(ratio, 5) == pytest.approx(0.6, abs=0.03)
    assert np.median(ratio) < 0.8
    chroma = lambda x: x / x.sum(axis=1, keepdims=True)  # noqa: E731
    assert np.abs(chroma(dark[core].astype(float)) - chroma(lit[core].astype(float))).max() < 0.05


def test_scene_rejects_mismatched_inputs(stick_scene):
    masks = stick_scene[0][:3]
    with pytest.raises(InvalidParameterError, match="person_rgb must be uint8 of shape"):
        compose_scene(np.zeros((3, 10, 10, 3), np.uint8), masks, np.random.default_rng(0))
    with pytest.raises(InvalidParameterError, match="noise_sigma"):
        compose_scene(None, masks, np.random.default_rng(0), noise_sigma=-1.0)
    with pytest.raises(InvalidParameterError, match="rng must be a numpy.random.Generator"):
        compose_scene(None, masks, 0)


@pytest.mark.parametrize("fps, factor", [(48.0, 2), (120.0, 5)])
def test_stick_figure_is_a_function_of_time(fps, factor):
    """Frame k at 24 fps and the frame at the same time at a higher rate are the same pose."""
    a = stick_figure_masks(25, fps=24.0)
    b = stick_figure_masks(24 * factor + 1, fps=fps)
    np.testing.assert_array_equal(a[::6], b[:: 6 * factor])
    assert not np.array_equal(a[0], a[6])  # it does move
