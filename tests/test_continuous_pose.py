"""Continuous pose behind ``eigmotion query``: the retrieved motion aligned to the clip.

A tiny real database (two library motions × the six horizontal cameras of
``virtual_cameras/ring6.toml``) is built once into a temporary ZODB file; the query
clip is a library motion performed by another body shape, filmed between two rig
cameras, and time-warped (played slower, then faster) so that a linear stretch of the
matched window is out of step with it.
"""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from eigmotion.body.avatar import load_default_avatar
from eigmotion.body.retarget import pose_avatar, retarget
from eigmotion.cli.main import main
from eigmotion.errors import InvalidParameterError, VideoError
from eigmotion.imaging.cameras import virtual_rig
from eigmotion.mocap.bvh import read_bvh
from eigmotion.mocap.kinematics import forward_kinematics
from eigmotion.mocap.library import load_library
from eigmotion.mocap.rotations import axis_rotation
from eigmotion.pose.continuous_pose import ContinuousPoseConfig, align_motion, continuous_pose
from eigmotion.pose.playback import monotone_path, speed_costs
from eigmotion.pose.replay import replay
from eigmotion.retrieval.database import MotionDatabase
from eigmotion.retrieval.library_views import BuildConfig, hull_points
from eigmotion.synth.clips import time_warped

REPO = Path(__file__).resolve().parents[1]
MOTIONS = ("kick_135_04", "wave_14_24")
CONFIG = BuildConfig(
    n_components=12, key_axes=3, key_sections=6, garments=((),), body_shapes=((None, 1.0),)
)
CLIP_FPS = 30.0
#: The clip plays the first half of the motion at 0.7× and the second at 1.3× speed.
SPEEDS = (0.7, 1.3)
AVATAR = load_default_avatar()
BODY_JOINTS = [i for i, n in enumerate(AVATAR.joint_names) if not n.endswith(("1", "Thumb"))]


def root_relative(positions, azimuth_deg):
    """Joints minus the root, turned so that a camera at ``azimuth_deg`` is at 0."""
    rel = positions - positions[:, :1]
    return rel @ axis_rotation("Y", -azimuth_deg).T


def mpjpe_mm(a, b):
    return float(1000 * np.linalg.norm(a - b, axis=-1)[:, BODY_JOINTS].mean())


@pytest.fixture(scope="module")
def library():
    by_name = {m.name: m for m in load_library()}
    return [by_name[n] for n in MOTIONS]


@pytest.fixture(scope="module")
def db_path(ring6_database):
    return ring6_database(MOTIONS, CONFIG)


@pytest.fixture(scope="module")
def clip(library):
    """(masks (F, 120, 160) bool, true root-relative joints (F, 31, 3), azimuth)."""
    from eigmotion.imaging.silhouettes import render_masks

    azimuth_deg, elevation_deg = 30.0, 10.0  # halfway between two ring6 cameras
    body = AVATAR.with_shape(height_m=1.62, girth=1.15).decimated(4000)
    warped = time_warped(library[0].motion, SPEEDS, CLIP_FPS)
    anim = retarget(warped, body)
    vertices = pose_avatar(body, anim)
    camera = virtual_rig([azimuth_deg], [elevation_deg], 160, 120).fitted(
        hull_points(vertices), margin=0.08
    )[0]
    masks = render_masks(vertices, body.faces, camera)
    return masks, root_relative(anim.joint_positions, azimuth_deg)


@pytest.fixture(scope="module")
def aligned(db_path, clip):
    """The query's result, its continuous pose, and the linear stretch of the matched
    window replayed under the continuous pose's (refined) view."""
    masks, _ = clip
    with MotionDatabase.open(db_path) as db:
        result = db.query_masks(masks, CLIP_FPS)
        pose = continuous_pose(db, result, masks, CLIP_FPS)
        best = result.best
        linear = replay(
            db.motion(best.motion_id),
            best.window,
            pose.azimuth_deg,
            pose.elevation_deg,
            len(masks),
            CLIP_FPS,
        )
    return result, pose, linear


def test_one_pose_per_clip_frame(aligned, clip, library):
    masks, _ = clip
    result, pose, _ = aligned
    n = len(masks)
    assert result.best.motion == MOTIONS[0]
    assert pose.n_frames == n and pose.motion.n_frames == n
    assert pose.motion.frame_time_s == pytest.approx(1.0 / CLIP_FPS)
    assert pose.positions.shape == (n, len(AVATAR.joint_names), 3)
    assert pose.names == tuple(AVATAR.joint_names)
    assert np.all(np.isfinite(pose.positions))
    # the playback never goes back and never jumps more than its window
    steps = np.diff(pose.reference_frames)
    assert steps.min() >= 0 and steps.max() <= pose.max_step_frames
    assert 0 <= pose.reference_frames[0] and pose.reference_frames[-1] < library[0].motion.n_frames
    # it moves through the motion, not holding one posture
    assert pose.reference_frames[-1] - pose.reference_frames[0] > 0.5 * library[0].motion.n_frames
    # a body of the avatar's height standing on the floor
    head = AVATAR.joint_names.index("Head")
    assert 1.3 < pose.positions[0, head, 1] < 1.9
    assert np.all(pose.positions[:, :, 1].min(axis=1) < 0.25)
    assert np.nanmean(pose.scores) > 0.7


def test_time_warped_clip_beats_the_linear_stretch(aligned, clip):
    """Root-aligned joints in the clip camera's frame (camera at azimuth 0), both
    under the same view: the frame-by-frame alignment follows the warp, the linear
    stretch cannot."""
    _, truth = clip
    _, pose, linear = aligned
    ours = mpjpe_mm(root_relative(pose.positions, 0.0), truth)
    baseline_positions = forward_kinematics(linear.motion, length_unit_m=1.0, ground=False)
    baseline = mpjpe_mm(root_relative(baseline_positions.positions, 0.0), truth)
    assert ours < 50.0, (ours, baseline)
    assert ours < 0.6 * baseline, (ours, baseline)
    # the view was refined towards the clip's (between two rig cameras)
    assert abs(pose.azimuth_deg - 30.0) <= abs(pose.matched_azimuth_deg - 30.0)


def test_query_says_how_its_3d_answer_was_made(db_path, clip, tmp_path, capsys):
    """``--linear-replay`` stretches the matched window for the BVH; the joints of
    ``--pose-out`` are still aligned frame by frame, which the command announces before
    it starts; the closing line says which."""
    masks, _ = clip
    clip_path = tmp_path / "clip.npz"
    np.savez_compressed(clip_path, masks=masks, fps=CLIP_FPS)
    bvh, joints = tmp_path / "clip.bvh", tmp_path / "pose.npz"
    base = ["query", str(clip_path), "--db", str(db_path), "--bvh-out", str(bvh), "--linear-replay"]
    assert main(base) == 0
    said = capsys.readouterr().err.strip()
    assert said.endswith(f"wrote {bvh} (stretched linearly)") and "aligning" not in said
    assert main([*base, "--pose-out", str(joints)]) == 0
    *before, said = capsys.readouterr().err.strip().splitlines()
    assert any(
        line.startswith("aligning ") and "frame by frame (--pose-cue silhouette)" in line
        for line in before
    )
    assert said == (
        f"wrote {bvh}, {joints} (the BVH and replay stretched linearly, the joints aligned "
        "frame by frame, --pose-cue silhouette)"
    )


def test_query_writes_pose_and_bvh(db_path, clip, tmp_path, capsys):
    masks, _ = clip
    clip_path = tmp_path / "clip.npz"
    np.savez_compressed(clip_path, masks=masks, fps=CLIP_FPS)
    pose_path, bvh_path = tmp_path / "pose.npz", tmp_path / "clip.bvh"
    rc = main(
        [
            "query",
            str(clip_path),
            "--db",
            str(db_path),
            "--pose-out",
            str(pose_path),
            "--bvh-out",
            str(bvh_path),
        ]
    )
    assert rc == 0
    # stored masks: no frames for the pose network, so the silhouette cue, and it says so
    assert "aligned frame by frame, --pose-cue silhouette)" in capsys.readouterr().err
    with np.load(pose_path) as data:
        assert set(data.files) == {"names", "positions", "reference_frames", "fps"}
        names = tuple(str(s) for s in data["names"])
        positions = data["positions"]
        assert names == tuple(AVATAR.joint_names)
        assert positions.shape == (len(masks), len(names), 3)
        assert float(data["fps"]) == CLIP_FPS
        assert data["reference_frames"].shape == (len(masks),)
        assert np.all(np.diff(data["reference_frames"]) >= 0)
    # the BVH is the same motion, frame by frame, at the clip's rate
    motion = read_bvh(bvh_path)
    assert motion.n_frames == len(masks)
    assert motion.frame_time_s == pytest.approx(1.0 / CLIP_FPS, rel=1e-4)
    from_bvh = forward_kinematics(motion, length_unit_m=1.0, ground=False).positions
    assert np.abs(from_bvh - positions).max() < 2e-3


def test_query_pose_out_needs_an_existing_folder(db_path, clip, tmp_path, capsys):
    masks, _ = clip
    clip_path = tmp_path / "clip.npz"
    np.savez_compressed(clip_path, masks=masks[:10], fps=CLIP_FPS)
    missing = tmp_path / "nowhere" / "pose.npz"
    rc = main(["query", str(clip_path), "--db", str(db_path), "--pose-out", str(missing)])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1 and "nowhere" in err


# -- the playback path, on its own ----------------------------------------------------


def brute_force_best(scores, max_step, costs):
    n_f, n_r = scores.shape
    best = -np.inf
    for path in itertools.product(range(n_r), repeat=n_f):
        steps = np.diff(path)
        if np.any(steps < 0) or np.any(steps > max_step):
            continue
        total = scores[np.arange(n_f), path].sum() - costs[steps].sum()
        best = max(best, total)
    return best


@settings(max_examples=60, deadline=None)
@given(
    st.integers(1, 4),
    st.integers(1, 5),
    st.integers(1, 3),
    st.floats(0.0, 0.5),
    st.integers(0, 2**31 - 1),
)
def test_monotone_path_is_the_best_allowed_path(n_f, n_r, max_step, weight, seed):
    rng = np.random.default_rng(seed)
    scores = rng.uniform(-1, 1, (n_f, n_r))
    costs = speed_costs(max_step, 1.5, weight)
    path = monotone_path(scores, max_step, costs)
    steps = np.diff(path)
    assert path.shape == (n_f,) and np.all(steps >= 0) and np.all(steps <= max_step)
    total = scores[np.arange(n_f), path].sum() - costs[steps].sum()
    assert total == pytest.approx(brute_force_best(scores, max_step, costs))


def test_monotone_path_follows_a_changing_speed():
    # the best reference frame moves 1, then 3 frames per clip frame
    truth = np.concatenate([np.arange(0, 10), np.arange(12, 40, 3)])
    scores = np.full((len(truth), 41), -1.0)
    scores[np.arange(len(truth)), truth] = 1.0
    assert np.array_equal(monotone_path(scores, 3), truth)
    # a window of 2 cannot keep up: the path lags but never goes back
    lagging = monotone_path(scores, 2)
    assert np.all(np.diff(lagging) >= 0) and np.all(np.diff(lagging) <= 2)
    # -inf cells are never used
    scores[:, 20:] = -np.inf
    assert monotone_path(scores, 3).max() < 20


def test_speed_prior_carries_the_playback_through_frames_without_evidence():
    # clip frames 10-19 show nobody (zero scores); the reference moves 2 frames per
    # clip frame before and after
    truth = 2 * np.arange(30)
    scores = np.full((30, 61), -1.0)
    scores[np.arange(30), truth] = 1.0
    scores[10:20] = 0.0
    with_prior = monotone_path(scores, 5, speed_costs(5, 2.0, 0.03))
    assert np.array_equal(with_prior, truth)
    # without it, any path through the gap scores the same: it holds, then jumps
    without = monotone_path(scores, 5)
    assert np.array_equal(without[:10], truth[:10]) and np.diff(without[9:21]).max() > 2


@pytest.mark.parametrize(
    ("scores", "max_step", "costs"),
    [
        (np.zeros((0, 3)), 1, None),
        (np.zeros(3), 1, None),
        (np.zeros((2, 3)), 0, None),
        (np.zeros((2, 3)), 2, np.zeros(2)),
        (np.full((2, 3), -np.inf), 1, None),
    ],
)
def test_monotone_path_rejects_bad_input(scores, max_step, costs):
    with pytest.raises(InvalidParameterError):
        monotone_path(scores, max_step, costs)


@pytest.mark.parametrize(
    "change",
    [
        {"max_speed": 0},
        {"margin_s": -1},
        {"reference_fps": 0},
        {"scales": ()},
        {"scales": (0.1,)},
        {"shift_radius_px": -1},
        {"smoothing_frames": 0},
        {"azimuth_step_deg": 0},
        {"speed_weight": float("nan")},
    ],
)
def test_config_rejects_out_of_range_values(change):
    with pytest.raises(InvalidParameterError, match=next(iter(change))):
        ContinuousPoseConfig(**change)


@pytest.mark.parametrize(
    ("window", "masks", "error"),
    [
        ((0, 10_000), np.ones((4, 60, 80), bool), InvalidParameterError),
        ((5, 5), np.ones((4, 60, 80), bool), InvalidParameterError),
        ((0, 50), np.ones((60, 80), bool), InvalidParameterError),
        ((0, 50), np.zeros((4, 60, 80), bool), VideoError),
    ],
)
def test_align_motion_rejects_bad_input(library, window, masks, error):
    with pytest.raises(error):
        align_motion(library[0].motion, window, 0.0, 0.0, masks, CLIP_FPS)
