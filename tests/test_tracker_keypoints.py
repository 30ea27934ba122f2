"""The two-camera keypoints stage: triangulation of the pose landmarks, left/right
exchanges, the skeleton's fit, the joints' paths smoothed, and the switches that leave
the tracker alone."""

from __future__ import annotations

import importlib.util

import cv2
import numpy as np
import pytest

from eigmotion.body.avatar import load_default_avatar
from eigmotion.body.retarget import retarget
from eigmotion.errors import InvalidParameterError
from eigmotion.imaging.cameras import intrinsics, look_at
from eigmotion.imaging.media import read_frames, write_video
from eigmotion.imaging.silhouettes import render_masks
from eigmotion.mocap.amc import read_amc
from eigmotion.resources import samples_dir
from eigmotion.segmentation.learned import STORE_MAX_SIDE_PX
from eigmotion.segmentation.video import load_clip_masks
from eigmotion.tracking.body import avatar_bodies
from eigmotion.tracking.dictionary import build_dictionary
from eigmotion.tracking.keypoint_fit import (
    KeypointFitter,
    gaussian_over_time,
    rotation_between,
    smooth_targets,
)
from eigmotion.tracking.overlay import SKELETON_RGB, draw_skeleton
from eigmotion.tracking.pipeline import track_clip
from eigmotion.tracking.postures import mean_heading_deg, yaw_rotation
from eigmotion.tracking.tracker import SilhouetteTracker, TrackerConfig
from eigmotion.tracking.triangulation import (
    KEYPOINT_JOINTS,
    KEYPOINT_LANDMARKS,
    SIDE_GROUPS,
    TriangulationConfig,
    projection_matrix,
    triangulate_clip,
    triangulate_points,
)

N_FRAMES = 12


def walkway_cameras(width=320, height=240):
    K = intrinsics(width, height, 45.0)
    return [
        look_at([-2.5, 1.6, -3.5], [0.5, 0.9, 0.0], K, width, height, name="left"),
        look_at([-2.5, 1.6, 3.5], [0.5, 0.9, 0.0], K, width, height, name="right"),
    ]


@pytest.fixture(scope="module")
def walk(cmu_dir):
    """A dictionary of one walk (02_01) and a rendered walk of another body (02_02):
    (dictionary, bodies, cameras, masks, joint names, true joints (F, J, 3))."""

    def read(trial):
        return read_amc(cmu_dir / "amc" / f"{trial}.amc", cmu_dir / "asf" / f"{trial[:2]}.asf")

    dictionary = build_dictionary(
        [read("02_01")], threshold_deg=5.0, headings_deg=(60.0, 90.0, 120.0), face_forward=True
    )
    subject = load_default_avatar().with_shape(height_m=1.7, girth=1.1)
    anim = retarget(read("02_02").trim(0, 60).resample(25), subject)
    turn = yaw_rotation(90.0 - mean_heading_deg(anim.joint_rotations[:, 0]))
    rot = (turn @ anim.joint_rotations)[:N_FRAMES]
    pos = (anim.joint_positions @ turn.T)[:N_FRAMES]
    pos[..., [0, 2]] -= pos[0, 0, [0, 2]]
    cams = walkway_cameras()
    vertices = subject.skin(rot, pos)
    masks = [render_masks(vertices, subject.faces, cam) for cam in cams]
    return dictionary, avatar_bodies(dictionary), cams, masks, subject.joint_names, pos


def keypoints_of(names, joints):
    """(F, K, 3): :data:`KEYPOINT_JOINTS` of joints (F, J, 3) named ``names``."""
    return joints[:, [list(names).index(n) for n in KEYPOINT_JOINTS]]


def landmarks_seen(cameras, points, visibility=0.9):
    """Per camera, (F, 33, 4) landmarks where the points (F, K, 3) project (continuous
    pixels: the centre of the first pixel at 0.5); the ears both at the head."""
    views = []
    for cam in cameras:
        marks = np.full((len(points), 33, 4), np.nan)
        uv, _ = cam.project(points)
        for k, ids in enumerate(KEYPOINT_LANDMARKS.values()):
            for i in ids:
                marks[:, i, :2] = uv[:, k] + 0.5
                marks[:, i, 2:] = visibility
        views.append(marks)
    return views


def test_triangulation_recovers_known_points():
    cams = walkway_cameras()
    rng = np.random.default_rng(0)
    points = rng.uniform([-0.5, 0.1, -0.5], [1.0, 1.8, 0.5], (200, 3))
    projections = np.stack([projection_matrix(c) for c in cams])
    pixels = np.stack([c.project(points)[0] for c in cams], axis=1)
    exact = triangulate_points(projections, pixels, np.ones((200, 2)))
    np.testing.assert_allclose(exact, points, atol=1e-6)
    noisy = triangulate_points(projections, pixels + rng.normal(0, 0.5, pixels.shape), 1.0)
    error = np.linalg.norm(noisy - points, axis=1)
    assert np.median(error) < 0.015 and error.max() < 0.06  # half a pixel: 7 mm at 4 m
    one_view = triangulate_points(projections, pixels, np.array([[1.0, 0.0]] * 200))
    assert np.isnan(one_view).all()


def test_clip_triangulation_trusts_only_what_two_views_see(walk):
    *_, cams, _, names, truth = walk
    points = keypoints_of(names, truth)
    views = landmarks_seen(cams, points)
    views[1][:, 15, 2] = 0.1  # left wrist hardly visible in the second camera
    views[0][3, 25, :2] += 40.0  # left knee 40 px off in one frame of the first
    joints = triangulate_clip(cams, views, points)
    wrist, knee = KEYPOINT_JOINTS.index("LeftHand"), KEYPOINT_JOINTS.index("LeftLeg")
    assert not joints.trusted[:, wrist].any()
    assert not joints.trusted[3, knee] and joints.trusted[2, knee]
    good = joints.trusted
    assert good.sum() == good.size - N_FRAMES - 1
    np.testing.assert_allclose(joints.positions_m[good], points[good], atol=1e-3)
    assert not joints.exchanged.any()


def test_with_three_cameras_a_view_far_off_is_left_out(walk):
    *_, cams, _, names, truth = walk
    K = intrinsics(320, 240, 45.0)
    cams = [*cams, look_at([3.5, 1.8, 0.2], [0.5, 0.9, 0.0], K, 320, 240, name="front")]
    points = keypoints_of(names, truth)
    views = landmarks_seen(cams, points)
    views[2][5, 27, :2] += 30.0  # the third camera puts the left ankle 30 px off
    joints = triangulate_clip(cams, views, points)
    assert joints.trusted.all()
    np.testing.assert_allclose(joints.positions_m, points, atol=1e-3)
    two = triangulate_clip([cams[0], cams[2]], [views[0], views[2]], points)
    assert not two.trusted[5, KEYPOINT_JOINTS.index("LeftFoot")]  # two views: not trusted
    empty = triangulate_clip(cams, [v[:0] for v in views], points[:0])
    assert empty.positions_m.shape == (0, len(KEYPOINT_JOINTS), 3)


def test_a_view_with_left_and_right_exchanged_is_put_right(walk):
    *_, cams, _, names, truth = walk
    points = keypoints_of(names, truth)
    views = landmarks_seen(cams, points)
    legs = [(23, 24), (25, 26), (27, 28)]
    arms = [(11, 12), (13, 14), (15, 16)]
    for left, right in legs:  # the second camera mixes up the legs in frames 4-7
        views[1][4:8, [left, right]] = views[1][4:8, [right, left]]
    for left, right in arms:  # both cameras mix up the arms in frames 2-3
        for view in views:
            view[2:4, [left, right]] = view[2:4, [right, left]]
    joints = triangulate_clip(cams, views, points)
    np.testing.assert_allclose(joints.positions_m, points, atol=1e-3)
    assert joints.exchanged[4:8, 1, 0].all() and not joints.exchanged[:, 0, 0].any()
    assert joints.exchanged[2:4, :, 1].all() and joints.exchanged[:, :, 1].sum() == 4
    assert len(SIDE_GROUPS) == 2


def test_untrusted_joints_keep_the_trackers_posture_and_bones_keep_their_length(walk):
    dictionary, *_ = walk
    fitter = KeypointFitter(dictionary)
    names = list(dictionary.joint_names)
    start, other = 0, len(dictionary) // 2
    own = dictionary.joints_at(np.array([start]), np.zeros(3))
    wanted = dictionary.joints_at(np.array([other]), np.zeros(3)) + [0.1, 0.0, 0.05]
    targets = keypoints_of(names, wanted)
    targets[0, KEYPOINT_JOINTS.index("RightHand")] = np.nan  # not trusted
    fitted = fitter.fit(np.array([start]), own, targets, weight=1.0)
    parents = dictionary.parents
    bones = np.linalg.norm(own[0, 1:] - own[0, parents[1:]], axis=-1)
    bones_after = np.linalg.norm(fitted.joints_m[0, 1:] - fitted.joints_m[0, parents[1:]], axis=-1)
    np.testing.assert_allclose(bones_after, bones, atol=1e-9)
    # the trusted limb joints land on their targets' directions: elbows and knees on them
    for name in ("LeftLeg", "RightLeg", "LeftForeArm", "LeftHand"):
        j, k = names.index(name), KEYPOINT_JOINTS.index(name)
        parent = fitted.joints_m[0, parents[j]]
        bone = fitted.joints_m[0, j] - parent
        aim = targets[0, k] - parent
        assert np.dot(bone, aim) / np.linalg.norm(bone) / np.linalg.norm(aim) > 0.999, name
    # the untrusted right hand keeps the tracker's elbow bend (its local rotation)
    elbow = names.index("RightForeArm")
    np.testing.assert_allclose(
        fitted.local_rotations[0, elbow], dictionary.local_rotations[start, elbow], atol=1e-9
    )
    left = names.index("LeftForeArm")
    assert not np.allclose(fitted.local_rotations[0, left], dictionary.local_rotations[start, left])
    # nothing trusted: the tracker's posture as it was
    none = fitter.fit(np.array([start]), own, np.full_like(targets, np.nan))
    np.testing.assert_allclose(none.joints_m, own, atol=1e-12)
    np.testing.assert_allclose(
        none.local_rotations[0], dictionary.local_rotations[start], atol=1e-9
    )


def test_rotation_between_and_smoothing():
    rng = np.random.default_rng(1)
    for a, b in rng.normal(size=(20, 2, 3)):
        turn = rotation_between(a, b)
        np.testing.assert_allclose(turn @ turn.T, np.eye(3), atol=1e-9)
        np.testing.assert_allclose(turn @ a / np.linalg.norm(a), b / np.linalg.norm(b), atol=1e-9)
    half = rotation_between(np.array([1.0, 0, 0]), np.array([-1.0, 0, 0]))
    np.testing.assert_allclose(half @ [1.0, 0, 0], [-1.0, 0, 0], atol=1e-9)
    track = np.zeros((5, 1, 3))
    track[:, 0, 0] = [0.0, 1.0, 2.0, 3.0, 4.0]
    track[2] = np.nan
    smooth = smooth_targets(track)
    assert np.isnan(smooth[2]).all()
    np.testing.assert_allclose(smooth[[0, 1, 3, 4], 0, 0], [1 / 3, 2 / 3, 10 / 3, 11 / 3])


def test_gaussian_smoothing_over_time():
    """A path through time: a joint moving at a steady speed keeps its path, to the
    ends; a single jolt is spread over its neighbours; a frame with a joint not finite
    is left as it is and bridged for the others."""
    line = np.zeros((9, 2, 3))
    line[:, :, 0] = np.arange(9.0)[:, None]
    np.testing.assert_allclose(gaussian_over_time(line, 1.0), line, atol=1e-9)
    np.testing.assert_allclose(gaussian_over_time(line, 20.0), line, atol=1e-9)
    jolt = np.zeros((9, 1, 3))
    jolt[4, 0, 1] = 1.0
    spread = gaussian_over_time(jolt, 1.0)
    assert 0.3 < spread[4, 0, 1] < 0.5 and spread[3, 0, 1] > 0.2 and spread[0, 0, 1] < 0.01
    np.testing.assert_allclose(spread[..., 1].sum(), 1.0, atol=0.02)
    holed = jolt.copy()
    holed[4, 0, 0] = np.nan
    kept = gaussian_over_time(holed, 1.0)
    assert np.isnan(kept[4, 0, 0]) and np.abs(kept[[3, 5], 0, 1]).max() < 1e-12
    np.testing.assert_array_equal(gaussian_over_time(line, 0.0), line)


def test_the_fit_follows_the_smoothed_paths_and_keeps_the_bones(walk):
    """Targets that jitter from estimate to estimate: fitted once more to their own
    paths smoothed over time, the joints move less from estimate to estimate, and every
    bone keeps its length."""
    dictionary, *_ = walk
    fitter = KeypointFitter(dictionary)
    names = list(dictionary.joint_names)
    entries = np.arange(8) * (len(dictionary) // 16)
    own = dictionary.joints_at(entries, np.zeros(3))
    rng = np.random.default_rng(4)
    targets = keypoints_of(names, own) + rng.normal(0.0, 0.04, (8, len(KEYPOINT_JOINTS), 3))
    plain = fitter.fit(entries, own, targets, weight=1.0)
    smooth = fitter.fit(entries, own, targets, weight=1.0, smooth_estimates=1.5)

    def jitter(joints):
        return np.linalg.norm(np.diff(joints, 2, axis=0), axis=-1).mean()

    assert jitter(smooth.joints_m) < 0.8 * jitter(plain.joints_m)
    parents = dictionary.parents
    for fitted in (plain, smooth):
        bones = np.linalg.norm(fitted.joints_m[:, 1:] - fitted.joints_m[:, parents[1:]], axis=-1)
        np.testing.assert_allclose(bones, np.linalg.norm(own[:, 1:] - own[:, parents[1:]], axis=-1),
                                   atol=1e-9)  # fmt: skip
    with pytest.raises(InvalidParameterError, match="joint_smooth_s"):
        TrackerConfig(joint_smooth_s=-1.0)


def test_the_stage_fits_the_tracker_and_switches_off(walk):
    dictionary, bodies, cams, masks, names, truth = walk
    points = keypoints_of(names, truth)
    rng = np.random.default_rng(2)
    views = landmarks_seen(cams, points)
    for view in views:  # the network's error, about 1.5 px
        view[..., :2] += rng.normal(0, 1.5, view[..., :2].shape)

    def run(config, landmarks):
        tracker = SilhouetteTracker(dictionary, cams, bodies, config)
        return track_clip(tracker, masks, 25.0, 25.0, landmarks)

    alone = run(TrackerConfig(keypoints=False, joint_smooth_s=0.0), views)
    assert alone.fitted is None
    np.testing.assert_array_equal(alone.joints_m, alone.result.joint_positions_m)
    # without landmarks, or switched off, the keypoints stage does not run: the paths
    # are smoothed alone, the same for all three
    smoothed = run(TrackerConfig(keypoints=False), views)
    without = run(TrackerConfig(), None)
    subtraction = run(TrackerConfig(), [views[0], None])  # a camera without landmarks
    for same in (smoothed, without, subtraction):
        assert same.fitted is not None and same.fitted.trusted is None
        np.testing.assert_array_equal(same.joints_m, smoothed.joints_m)
        np.testing.assert_array_equal(same.entries, alone.entries)
    fitted = run(TrackerConfig(), views)
    assert fitted.fitted.trusted is not None and fitted.fitted.trusted.mean() > 0.9
    np.testing.assert_array_equal(fitted.entries, alone.entries)

    def error_mm(tracked):
        own = keypoints_of(dictionary.joint_names, tracked.joints_m)
        return 1000 * np.linalg.norm(own - points, axis=-1).mean()

    def jitter_mm(tracked):
        own = keypoints_of(dictionary.joint_names, tracked.joints_m)
        return 1000 * np.linalg.norm(np.diff(own, 2, axis=0), axis=-1).mean()

    assert error_mm(fitted) < error_mm(alone) - 10, (error_mm(fitted), error_mm(alone))
    assert jitter_mm(smoothed) < 0.8 * jitter_mm(alone), (jitter_mm(smoothed), jitter_mm(alone))
    assert error_mm(smoothed) < error_mm(alone) - 3, (error_mm(smoothed), error_mm(alone))
    with pytest.raises(InvalidParameterError, match="keypoint_weight"):
        TrackerConfig(keypoint_weight=1.5)
    with pytest.raises(InvalidParameterError, match="min_confidence"):
        TriangulationConfig(min_confidence=2.0)


@pytest.mark.skipif(
    importlib.util.find_spec("ai_edge_litert") is None,
    reason="the pose network runs through LiteRT (pip install ai-edge-litert)",
)
def test_the_front_end_hands_over_its_landmarks_in_frame_pixels(tmp_path):
    """The fused front end's landmarks (the stage's input) lie on the person in the
    clip's own pixels, also when the networks saw the frames shrunk (a clip larger
    than :data:`~eigmotion.segmentation.learned.STORE_MAX_SIDE_PX`); background
    subtraction gives none."""
    small, _ = read_frames(samples_dir() / "walk_3s.mp4")
    background = cv2.imread(str(samples_dir() / "walk_3s_background.png"))
    clip_path = write_video(
        np.stack([cv2.resize(f, (800, 600)) for f in small[30::2]]), tmp_path / "big.mp4", 12.5
    )
    cv2.imwrite(str(tmp_path / "big.png"), cv2.resize(background, (800, 600)))
    fused = load_clip_masks(clip_path, tmp_path / "big.png", segmenter="auto")
    height, width = 600, 800
    assert max(height, width) > STORE_MAX_SIDE_PX
    assert fused.landmarks.shape == (len(fused.masks), 33, 4)
    assert fused.masks.shape[1:] == (height, width)
    hips = fused.landmarks[:, 23:25]
    seen = np.isfinite(hips[..., 0]) & (hips[..., 2] > 0.5)
    assert seen.mean() > 0.6
    cols = np.clip(hips[..., 0][seen].astype(int), 0, width - 1)
    rows = np.clip(hips[..., 1][seen].astype(int), 0, height - 1)
    frame_of = np.nonzero(seen)[0]
    near = [fused.masks[f, max(r - 6, 0) : r + 7, max(c - 6, 0) : c + 7].any()
            for f, r, c in zip(frame_of, rows, cols, strict=True)]  # fmt: skip
    assert np.mean(near) > 0.9
    # the person's middle: the hips' midpoint within the mask's extent, frame by frame
    middle = hips[..., 0].mean(axis=1)
    for f in np.flatnonzero(seen.all(axis=1)):
        columns = np.flatnonzero(fused.masks[f].any(axis=0))
        assert columns[0] <= middle[f] <= columns[-1] + 1
    background_only = load_clip_masks(clip_path, tmp_path / "big.png", segmenter="subtraction")
    assert background_only.landmarks is None


def test_the_fitted_skeleton_is_drawn_where_the_camera_sees_it():
    cam = walkway_cameras()[0]
    joints = np.array([[0.5, 0.9, 0.0], [0.5, 1.5, 0.0], [0.5, 0.9, -9.0]])  # last: behind
    image = np.zeros((cam.height, cam.width, 3), np.uint8)
    drawn = draw_skeleton(image, cam, joints, np.array([-1, 0, 0]))
    cyan = (drawn == SKELETON_RGB).all(axis=-1)
    (u0, v0), (u1, v1) = cam.project(joints[:2])[0]
    assert cyan.sum() >= 0.8 * abs(v1 - v0)
    rows, cols = np.nonzero(cyan)
    assert min(v0, v1) - 2 <= rows.min() and rows.max() <= max(v0, v1) + 2
    assert abs(cols.mean() - (u0 + u1) / 2) < 3
    assert not image.any()  # a copy is drawn on
