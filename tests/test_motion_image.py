"""The motion image: unit vectors, invariances, time direction, frame rates, errors."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from mask_helpers import edge_flicker

from eigmotion.body.retarget import animate_avatar
from eigmotion.errors import InvalidParameterError, VideoError
from eigmotion.retrieval.motion_image import (
    FILTERS,
    FRAMES,
    STILL_CHANGE_SHARE,
    WEIGHTINGS,
    ClipMotionImages,
    MotionImageConfig,
    align_frames,
    motion_image,
    motion_image_picture,
    sample_indices,
)
from eigmotion.synth.scene import stick_figure_masks


def cosine_distance(a: np.ndarray, b: np.ndarray) -> float:
    return float(1.0 - np.dot(a, b) / (np.linalg.norm(a) * np.linalg.norm(b)))


def walk(n_frames=45, fps=30.0, **kwargs) -> np.ndarray:
    """A stick figure walking right and swinging its arms, (F, 120, 160) bool."""
    return stick_figure_masks(n_frames, 120, 160, fps=fps, body_height_px=80.0, **kwargs)


def shift_and_scale(masks, scale, offset_rc, shape_hw):
    """Every mask resized by ``scale`` and pasted at ``offset_rc`` into a bigger frame."""
    h, w = masks.shape[1:]
    size = (int(round(w * scale)), int(round(h * scale)))
    out = np.zeros((len(masks), *shape_hw), bool)
    r, c = offset_rc
    for i, m in enumerate(masks):
        small = cv2.resize(m.astype(np.float32), size, interpolation=cv2.INTER_AREA) >= 0.5
        out[i, r : r + size[1], c : c + size[0]] = small
    return out


ALL_OPTIONS = [
    MotionImageConfig(frame=f, weighting=w, filter=k)
    for f in FRAMES
    for w in WEIGHTINGS
    for k in FILTERS
]


# -- the vector --------------------------------------------------------------------------


@pytest.mark.parametrize("config", ALL_OPTIONS, ids=lambda c: f"{c.frame}-{c.weighting}-{c.filter}")
def test_unit_norm_and_length(config):
    vector = motion_image(walk(), config, clip_fps=30.0)
    assert vector.dtype == np.float32
    assert vector.shape == (config.n_dims,) == (config.phases * config.size**2,)
    assert np.all(np.isfinite(vector))
    assert abs(float(np.linalg.norm(vector)) - 1.0) < 1e-5


@pytest.mark.parametrize("size", [8, 24, 64])
@pytest.mark.parametrize("step", [1, 2, 3])
def test_sizes_and_steps(size, step):
    config = MotionImageConfig(size=size, step=step)
    vector = motion_image(walk(), config, clip_fps=30.0)
    assert vector.shape == (config.phases * size * size,)
    assert abs(float(np.linalg.norm(vector)) - 1.0) < 1e-5


@pytest.mark.parametrize("dtype", ["bool", "uint8-01", "uint8-255", "float32", "float64"])
def test_mask_dtypes_agree(dtype):
    masks = walk()
    as_type = {
        "bool": masks,
        "uint8-01": masks.astype(np.uint8),
        "uint8-255": masks.astype(np.uint8) * 255,
        "float32": masks.astype(np.float32),
        "float64": masks.astype(np.float64),
    }[dtype]
    reference = motion_image(masks, clip_fps=30.0)
    np.testing.assert_allclose(motion_image(as_type, clip_fps=30.0), reference, atol=1e-6)
    if dtype != "uint8-255":  # 0/1 masks count as they sum: the same image to the bit
        np.testing.assert_array_equal(motion_image(as_type, clip_fps=30.0), reference)


def test_the_image_holds_the_motion_not_the_background():
    """Where nothing ever moved the image is zero (differences only, no silhouette)."""
    masks = walk(walk_speed_px_s=0.0)
    config = MotionImageConfig(frame="image", filter="none", silhouette_weight=0.0, phases=1)
    picture = motion_image_picture(motion_image(masks, config, 30.0), config)
    aligned = align_frames(masks[sample_indices(len(masks), 30.0, 15.0)], config)
    never = aligned.max(axis=0) == 0.0
    assert picture[never].max() == 0
    assert picture.max() == 255


# -- invariance --------------------------------------------------------------------------


@pytest.mark.parametrize(
    "frame, weighting, limit",
    [("person", "recency", 0.1), ("person", "uniform", 0.1), ("image", "recency", 0.1)],
)
def test_shift_and_scale_invariance(frame, weighting, limit):
    """The person 30 px away and at 0.6 of the size inside a larger frame."""
    masks = walk()
    moved = shift_and_scale(masks, 0.6, (30, 90), (200, 260))
    config = MotionImageConfig(frame=frame, weighting=weighting)
    distance = cosine_distance(motion_image(masks, config, 30.0), motion_image(moved, config, 30.0))
    assert distance < limit, f"{frame}/{weighting}: cosine distance {distance:.4f}"


def test_person_frame_removes_travel_image_frame_keeps_it():
    """Walking across the picture vs. walking on the spot: the same motion in the
    person frame, a different image in the image frame."""
    on_spot = walk(start_x_px=80.0, walk_speed_px_s=0.0)
    across = walk(start_x_px=30.0, walk_speed_px_s=60.0)
    person = MotionImageConfig(frame="person")
    image = MotionImageConfig(frame="image")
    d_person = cosine_distance(
        motion_image(on_spot, person, 30.0), motion_image(across, person, 30.0)
    )
    d_image = cosine_distance(motion_image(on_spot, image, 30.0), motion_image(across, image, 30.0))
    assert d_person < 0.1
    assert d_image > 2 * d_person


# -- time direction ------------------------------------------------------------------------


@pytest.mark.parametrize("frame", FRAMES)
def test_recency_tells_a_motion_from_its_reverse(frame):
    """Arms lifting sideways vs. lowering: same set of differences, other order."""
    kwargs = dict(walk_speed_px_s=0.0, arm_swing_deg=0.0, leg_swing_deg=0.0, raise_arms_deg=80.0)
    forward = walk(**kwargs)
    backward = walk(reverse=True, **kwargs)
    np.testing.assert_array_equal(forward[::-1], backward)
    uniform = MotionImageConfig(frame=frame, weighting="uniform", phases=1)
    recency = MotionImageConfig(frame=frame, weighting="recency", phases=1)
    d_uniform = cosine_distance(
        motion_image(forward, uniform, 30.0), motion_image(backward, uniform, 30.0)
    )
    d_recency = cosine_distance(
        motion_image(forward, recency, 30.0), motion_image(backward, recency, 30.0)
    )
    assert d_uniform < 1e-6
    assert d_recency > 0.05


@pytest.mark.parametrize("phases", [2, 3])
def test_phases_keep_the_order_of_the_motion(phases):
    """Arms lifting vs. lowering again, with uniform weights: one image cannot tell them
    apart, consecutive phases can."""
    kwargs = dict(walk_speed_px_s=0.0, arm_swing_deg=0.0, leg_swing_deg=0.0, raise_arms_deg=80.0)
    forward, backward = walk(**kwargs), walk(reverse=True, **kwargs)
    config = MotionImageConfig(weighting="uniform", phases=phases)
    vector = motion_image(forward, config, 30.0)
    assert vector.shape == (config.n_dims,) == (phases * 32 * 32,)
    assert np.linalg.norm(vector) == pytest.approx(1.0, abs=1e-5)
    assert cosine_distance(vector, motion_image(backward, config, 30.0)) > 0.05
    assert motion_image_picture(vector, config).shape == (32, phases * 32)


@pytest.mark.parametrize("phases", [2, 3])
def test_phases_cut_by_motion_ignore_a_pause(phases):
    """Arms lifting then lowering, once straight through and once with a pose held
    halfway: with phases cut by motion the images are the same, by time they differ.
    (Uniform weights and no silhouette term: the held frames add no difference.)"""
    kwargs = dict(walk_speed_px_s=0.0, arm_swing_deg=0.0, leg_swing_deg=0.0, raise_arms_deg=80.0)
    up, down = walk(**kwargs), walk(reverse=True, **kwargs)
    straight = np.concatenate([up, down[1:]])
    paused = np.concatenate([up[:15], np.repeat(up[15:16], 30, axis=0), up[16:], down[1:]])
    for cuts, same in (("motion", True), ("time", False)):
        config = MotionImageConfig(
            weighting="uniform", silhouette_weight=0.0, filter="none", phases=phases,
            phase_cuts=cuts,
        )  # fmt: skip
        d = cosine_distance(motion_image(straight, config), motion_image(paused, config))
        assert (d < 1e-6) == same, (cuts, d)
        if not same:
            assert d > 0.02


# -- frame rates -----------------------------------------------------------------------------


@pytest.mark.parametrize("clip_fps", [30.0, 60.0, 120.0])
def test_frame_rates_of_one_motion_agree(clip_fps):
    """1.5 s of the same motion drawn at 30, 60 and 120 fps, compared with 24 fps."""
    n = int(round(1.5 * clip_fps)) + 1
    reference = motion_image(walk(37, fps=24.0), clip_fps=24.0)
    vector = motion_image(walk(n, fps=clip_fps), clip_fps=clip_fps)
    assert cosine_distance(vector, reference) < 0.05


@pytest.mark.parametrize("config", ALL_OPTIONS, ids=lambda c: f"{c.frame}-{c.weighting}-{c.filter}")
def test_the_same_masks_give_the_same_image_to_the_last_bit(config):
    """A clip answered twice gives the same distances, and a database built twice the
    same points: nothing in the image may depend on where its arrays lie in memory."""
    for n_frames in (30, 45, 60, 75):
        masks = walk(n_frames)
        first = motion_image(masks, config, clip_fps=30.0)
        for _ in range(7):
            np.testing.assert_array_equal(motion_image(masks.copy(), config, clip_fps=30.0), first)


@pytest.mark.parametrize("frame", FRAMES)
@pytest.mark.parametrize("clip_fps", [None, 30.0])
def test_windows_of_a_clip_equal_motion_images_of_their_masks(frame, clip_fps):
    masks = walk(60)
    masks[40:44] = False  # frames without the person
    config = MotionImageConfig(frame=frame)
    images = ClipMotionImages(masks, config, clip_fps)
    for start, stop in [(0, 60), (0, 23), (7, 30), (15, 38), (37, 60)]:
        np.testing.assert_array_equal(
            images.window(start, stop), motion_image(masks[start:stop], config, clip_fps)
        )
    with pytest.raises(VideoError, match="no person"):
        images.window(40, 44)


def test_sampling_matters():
    """Without clip_fps every frame is used: the 120 fps clip then differs more."""
    slow = motion_image(walk(181, fps=120.0))
    sampled = motion_image(walk(181, fps=120.0), clip_fps=120.0)
    reference = motion_image(walk(46, fps=30.0), clip_fps=30.0)
    assert cosine_distance(sampled, reference) < cosine_distance(slow, reference)


@pytest.mark.parametrize(
    "n_frames, clip_fps, sample_fps, expected",
    [
        (90, 120.0, 15.0, list(range(0, 90, 8))),
        (31, 30.0, 15.0, list(range(0, 31, 2))),
        (10, 10.0, 15.0, list(range(10))),
        (5, 50.0, 50.0, list(range(5))),
    ],
)
def test_sample_indices(n_frames, clip_fps, sample_fps, expected):
    assert sample_indices(n_frames, clip_fps, sample_fps).tolist() == expected


@settings(max_examples=60, deadline=None)
@given(
    n_frames=st.integers(1, 400),
    clip_fps=st.floats(1.0, 240.0),
    sample_fps=st.floats(1.0, 50.0),
)
def test_sample_indices_properties(n_frames, clip_fps, sample_fps):
    idx = sample_indices(n_frames, clip_fps, sample_fps)
    assert idx[0] == 0
    assert np.all(np.diff(idx) >= 0) and idx[-1] <= n_frames - 1
    if clip_fps > sample_fps:
        times = idx / clip_fps
        wanted = np.arange(len(idx)) / sample_fps
        assert np.all(np.abs(times - wanted) <= 0.5 / clip_fps + 1e-9)


# -- errors --------------------------------------------------------------------------------


def test_static_masks_have_no_motion():
    still = np.repeat(walk()[:1], 20, axis=0)
    with pytest.raises(VideoError, match="no motion"):
        motion_image(still)


def _waving_person(n_frames: int, wave_deg: float) -> np.ndarray:
    """(F, 120, 160) bool at 15 fps: a body 85 px tall, its forearm raised beside the
    head swinging ``wave_deg`` either way once a second."""
    out = np.zeros((n_frames, 120, 160), np.uint8)
    for i, frame in enumerate(out):
        cv2.ellipse(frame, (80, 70), (14, 35), 0, 0, 360, 1, -1)
        cv2.circle(frame, (80, 28), 8, 1, -1)
        angle = 2.6 + np.radians(wave_deg) * np.sin(2.0 * np.pi * i / 15.0)
        hand = (round(92 + 28 * np.sin(angle)), round(50 + 28 * np.cos(angle)))
        cv2.line(frame, (92, 50), hand, 1, 4)
    return out.astype(bool)


def test_a_person_standing_still_is_no_motion_however_their_edges_flicker():
    """Edge flicker passes the aligned image's own test (the person frame re-centres on
    every flicker); ``min_change`` on the silhouettes as given tells it from a wave."""
    still = edge_flicker(_waving_person(45, 0.0), 0.01)
    waving = edge_flicker(_waving_person(45, 30.0), 0.01)
    assert motion_image(still, clip_fps=15.0).shape == (MotionImageConfig().n_dims,)
    with pytest.raises(VideoError, match="the person stands still"):
        ClipMotionImages(still, clip_fps=15.0, min_change=STILL_CHANGE_SHARE).window(0, 45)
    held = ClipMotionImages(waving, clip_fps=15.0, min_change=STILL_CHANGE_SHARE)
    np.testing.assert_array_equal(held.window(0, 45), motion_image(waving, clip_fps=15.0))
    assert ClipMotionImages(still, clip_fps=15.0).change(0, 45) < 0.01 < 0.04 < held.change(0, 45)


@pytest.mark.parametrize("frame", FRAMES)
def test_empty_masks_have_no_person(frame):
    with pytest.raises(VideoError, match="no person"):
        motion_image(np.zeros((10, 32, 32), bool), MotionImageConfig(frame=frame))


def test_too_few_frames():
    with pytest.raises(VideoError, match=r"in 2 of the 2 .* \(step=2\) needs at least 3"):
        motion_image(walk()[:2], MotionImageConfig(step=2))
    one_person = np.zeros((6, 120, 160), bool)
    one_person[2] = walk()[0]
    with pytest.raises(VideoError, match=r"the person is in 1 of the 6 frame"):
        motion_image(one_person, MotionImageConfig(frame="person"))


@pytest.mark.parametrize(
    "masks, pattern",
    [
        (np.zeros((32, 32), bool), r"masks must have shape \(F, H, W\)"),
        (np.zeros((4, 32, 32, 3), bool), r"masks must have shape \(F, H, W\)"),
        (np.zeros((0, 32, 32), bool), r"masks must have shape \(F, H, W\)"),
        (np.full((4, 8, 8), np.nan), "masks hold NaN"),
        (np.full((4, 8, 8), 2.0), r"masks must hold values in \[0, 1\]"),
        (np.zeros((4, 8, 8), np.complex64), "masks must be bool, uint8 or float"),
    ],
)
def test_bad_masks_name_the_parameter(masks, pattern):
    with pytest.raises(InvalidParameterError, match=pattern):
        motion_image(masks)


@pytest.mark.parametrize("clip_fps", [0.0, -30.0, float("nan"), float("inf")])
def test_bad_clip_fps(clip_fps):
    with pytest.raises(InvalidParameterError, match="clip_fps"):
        motion_image(walk(), clip_fps=clip_fps)


# -- the configuration ---------------------------------------------------------------------


@pytest.mark.parametrize(
    "name, value",
    [
        ("size", 4),
        ("size", 1000),
        ("size", 32.5),
        ("step", 0),
        ("step", 4),
        ("sample_fps", 0.5),
        ("sample_fps", 60.0),
        ("sample_fps", float("nan")),
        ("frame", "world"),
        ("weighting", "linear"),
        ("filter", "canny"),
        ("log_sigma_px", 0.0),
        ("silhouette_weight", 1.5),
        ("residual_floor", 0.5),
        ("margin_frac", -0.1),
        ("person_height_frac", 0.0),
        ("min_motion_frac", 1.0),
        ("phases", 0),
        ("phases", 5),
        ("phase_cuts", "energy"),
    ],
)
def test_config_rejects_bad_values(name, value):
    with pytest.raises(InvalidParameterError, match=name) as info:
        MotionImageConfig(**{name: value})
    assert repr(value) in str(info.value) or str(value) in str(info.value)


@pytest.mark.parametrize(
    "config",
    ALL_OPTIONS[:4] + [MotionImageConfig(size=48, step=3, phases=3, phase_cuts="time")],
)
def test_config_round_trip(config):
    data = config.to_dict()
    assert all(isinstance(v, int | float | str) for v in data.values())
    assert MotionImageConfig.from_dict(data) == config


def test_a_config_stored_before_phases_existed_made_one_image():
    data = MotionImageConfig().to_dict()
    del data["phases"], data["phase_cuts"]
    assert MotionImageConfig.from_dict(data).phases == 1
    assert MotionImageConfig.from_dict(data).phase_cuts == "time"


def test_config_from_dict_rejects_unknown_keys():
    with pytest.raises(InvalidParameterError, match="unknown key"):
        MotionImageConfig.from_dict({"size": 32, "colour": "red"})


# -- the picture ---------------------------------------------------------------------------


@pytest.mark.parametrize("filter_", FILTERS)
def test_picture(filter_):
    config = MotionImageConfig(filter=filter_)
    picture = motion_image_picture(motion_image(walk(), config, 30.0), config)
    assert picture.shape == (config.size, config.phases * config.size)
    assert picture.dtype == np.uint8
    if filter_ == "log":  # signed: 0 maps to mid-grey
        assert picture.min() == 0 or picture.max() == 255
        assert np.median(picture) in (127, 128)
    else:
        assert picture.max() == 255 and np.median(picture) == 0


def test_picture_rejects_a_vector_of_another_size():
    with pytest.raises(InvalidParameterError, match=r"vector must have shape \(2048,\)"):
        motion_image_picture(np.zeros(64 * 64, np.float32), MotionImageConfig(size=32))


# -- the real avatar ------------------------------------------------------------------------


@pytest.fixture(scope="module")
def avatar_walk(cmu_dir):
    """Vertices (F, V, 3) of the avatar walking (CMU 02_01, 1.5 s) at 120 and at
    30 fps, and the faces."""
    from eigmotion.body.avatar import DEFAULT_LOW_POLY_FACES, load_default_avatar
    from eigmotion.mocap.amc import read_amc

    motion = read_amc(cmu_dir / "amc" / "02_01.amc", cmu_dir / "asf" / "02.asf")
    motion = motion.trim(0, 181)
    body = load_default_avatar().decimated(DEFAULT_LOW_POLY_FACES)
    _, vertices_120 = animate_avatar(body, motion)
    _, vertices_30 = animate_avatar(body, motion.resample(30.0))
    return vertices_120, vertices_30, body.faces


def _side_camera(vertices, width, height, distance_factor=1.0, aim_offset_m=(0.0, 0.0, 0.0)):
    from eigmotion.imaging.cameras import fit_distance, intrinsics, look_at, view_direction

    points = vertices[:, ::7].reshape(-1, 3)
    centre = 0.5 * (points.min(axis=0) + points.max(axis=0))
    K = intrinsics(width, height, 40.0)
    d = distance_factor * fit_distance(points, centre, 90.0, 5.0, K, width, height)
    eye = centre + d * view_direction(90.0, 5.0)
    return look_at(eye, centre + np.asarray(aim_offset_m), K, width, height)


def test_avatar_person_frame_ignores_camera_distance_and_aim(avatar_walk):
    """The same walk filmed by a camera fitted to it and by one 1.7x further away,
    aimed 0.4 m off, at another image size: the person frame sees the same motion."""
    from eigmotion.imaging.silhouettes import render_masks

    _, vertices, faces = avatar_walk
    near = render_masks(vertices, faces, _side_camera(vertices, 128, 128))
    far = render_masks(vertices, faces, _side_camera(vertices, 160, 120, 1.7, (0.4, 0.2, 0.0)))
    assert far.sum() < 0.6 * near.sum()  # the person really is smaller
    config = MotionImageConfig()
    distance = cosine_distance(motion_image(near, config, 30.0), motion_image(far, config, 30.0))
    assert distance < 0.1


def test_avatar_rendered_at_120_and_30_fps_agree(avatar_walk):
    from eigmotion.imaging.silhouettes import render_masks

    vertices_120, vertices_30, faces = avatar_walk
    camera = _side_camera(vertices_120, 128, 128)
    at_120 = motion_image(render_masks(vertices_120, faces, camera), clip_fps=120.0)
    at_30 = motion_image(render_masks(vertices_30, faces, camera), clip_fps=30.0)
    assert cosine_distance(at_120, at_30) < 0.05


@pytest.mark.parametrize("frame", ["person", "image"])
def test_aligned_at_another_size_is_align_frames_of_the_sampled_frames(frame):
    config = MotionImageConfig(frame=frame)
    masks = stick_figure_masks(60, 120, 160, fps=30.0)
    images = ClipMotionImages(masks, config, clip_fps=30.0)
    small = MotionImageConfig(frame=frame, size=16)
    expected = align_frames(masks[sample_indices(60, 30.0, config.sample_fps)], small)
    np.testing.assert_array_equal(images.aligned(16), expected)
    assert images.aligned(16).shape[1:] == (16, 16)
