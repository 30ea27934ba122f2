"""The tracker end to end on rendered views of real mocap it has not seen."""

from __future__ import annotations

import numpy as np
import pytest

from eigmotion.body.avatar import load_default_avatar
from eigmotion.body.retarget import pose_avatar, retarget
from eigmotion.errors import InvalidParameterError
from eigmotion.imaging.cameras import intrinsics, look_at
from eigmotion.imaging.silhouettes import render_masks
from eigmotion.mocap.amc import read_amc
from eigmotion.tracking.body import avatar_bodies
from eigmotion.tracking.calibration import CameraPair
from eigmotion.tracking.dictionary import build_dictionary, dictionary_from_motion
from eigmotion.tracking.postures import mean_heading_deg, yaw_rotation
from eigmotion.tracking.tracker import SilhouetteTracker, TrackerConfig

BODY_JOINTS = [
    i for i, n in enumerate(load_default_avatar().joint_names) if not n.endswith(("1", "Thumb"))
]


def walkway_cameras(width=320, height=240):
    """Two cameras on both sides of a walkway along +X."""
    K = intrinsics(width, height, 45.0)
    return [
        look_at([-2.5, 1.6, -3.5], [0.5, 0.9, 0.0], K, width, height, name="left"),
        look_at([-2.5, 1.6, 3.5], [0.5, 0.9, 0.0], K, width, height, name="right"),
    ]


def stage_clip(motion, avatar, heading_deg, start_m):
    """A motion retargeted onto ``avatar``, turned to ``heading_deg`` and moved so that
    its root starts at ``start_m`` (x, z).  Returns (world rotations, joint positions)."""
    anim = retarget(motion, avatar)
    turn = yaw_rotation(heading_deg - mean_heading_deg(anim.joint_rotations[:, 0]))
    rot = turn @ anim.joint_rotations
    pos = anim.joint_positions @ turn.T
    pos[..., [0, 2]] += np.asarray(start_m) - pos[0, 0, [0, 2]]
    return rot, pos


@pytest.fixture(scope="module")
def cmu(cmu_dir):
    def read(trial):
        return read_amc(cmu_dir / "amc" / f"{trial}.amc", cmu_dir / "asf" / f"{trial[:2]}.asf")

    return read


@pytest.fixture(scope="module")
def walk_setup(cmu):
    """Dictionary from one walk (02_01); views of ANOTHER walk (02_02) by another body."""
    dictionary = build_dictionary(
        [cmu("02_01")], threshold_deg=5.0, headings_deg=(60.0, 75.0, 90.0, 105.0, 120.0),
        face_forward=True,
    )  # fmt: skip
    bodies = avatar_bodies(dictionary)
    subject = load_default_avatar().with_shape(height_m=1.55, girth=1.15)
    rot, pos = stage_clip(cmu("02_02").trim(0, 120).resample(25), subject, 90.0, (-0.6, 0.0))
    cams = walkway_cameras()
    vertices = subject.skin(rot, pos)
    masks = [render_masks(vertices, subject.faces, cam) for cam in cams]
    return dictionary, bodies, cams, masks, pos, subject.height_m / load_default_avatar().height_m


def mpjpe_mm(result, truth):
    err = np.linalg.norm(result.joint_positions_m - truth, axis=-1)[:, BODY_JOINTS]
    return 1000 * float(err.mean())


def test_tracks_an_unseen_walk(walk_setup):
    dictionary, bodies, cams, masks, truth, scale = walk_setup
    tree = SilhouetteTracker(dictionary, cams, bodies).track(masks, frame_time_s=1 / 25)
    full = SilhouetteTracker(dictionary, cams, bodies, TrackerConfig(exhaustive=True)).track(
        masks, frame_time_s=1 / 25
    )
    assert tree.n_estimates == len(truth) and np.all(tree.found)
    # the person is smaller than the body model: the measured body scale says by how much
    assert abs(tree.estimates[-1].body_scale - scale) < 0.02, (tree.estimates[-1].body_scale, scale)
    err_tree, err_full = mpjpe_mm(tree, truth), mpjpe_mm(full, truth)
    assert err_tree < 80.0, err_tree
    assert err_tree < 1.15 * err_full + 5.0
    # the tree scores about half of the T_n = 40 candidates, the exhaustive search all
    assert tree.n_evaluations[1:].mean() < 0.7 * full.n_evaluations[1:].mean()
    assert full.n_evaluations[1:].max() <= 40
    # positions: the body centre within a few centimetres on the floor plane
    horizontal = np.linalg.norm((tree.positions_m - truth[:, 0])[:, [0, 2]], axis=1)
    assert np.median(horizontal) < 0.06
    motion = dictionary.to_motion(tree.entries, tree.positions_m, tree.frame_time_s)
    assert motion.n_frames == tree.n_estimates


def test_trackers_of_one_dictionary_share_its_cluster_tree(walk_setup):
    dictionary, bodies, cams, *_ = walk_setup
    first = SilhouetteTracker(dictionary, cams, bodies).cluster_tree()
    assert SilhouetteTracker(dictionary, cams, bodies).cluster_tree() is first
    other = SilhouetteTracker(dictionary, cams, bodies, TrackerConfig(init_branching=8))
    tree = other.cluster_tree()
    assert tree is not first and len(tree) == 8

    # every posture is in each tree once: the shared tree is the whole dictionary's
    def items(nodes):
        return [n.item for n in nodes] + [i for n in nodes for i in items(n.children)]

    assert sorted(items(first)) == sorted(items(tree)) == list(range(len(dictionary)))


def test_single_camera_aligns_a_known_motion(cmu):
    """The single-camera use: the dictionary is one motion's frames, one camera, and
    the candidate silhouettes are also scaled in 2D (another body size)."""
    motion = cmu("16_15").trim(0, 240).resample(25)
    dictionary = dictionary_from_motion(motion)
    subject = load_default_avatar().with_shape(height_m=1.62)
    anim = retarget(motion, subject)
    # A camera beside the path, as a virtual camera would see the motion as recorded.
    path = anim.joint_positions[:, 0]
    travel = path[-1] - path[0]
    side = np.cross([0.0, 1.0, 0.0], travel / np.linalg.norm(travel))
    middle = path.mean(axis=0)
    cam = look_at(middle + 4.5 * side + [0, 0.7, 0], middle, intrinsics(160, 120, 50), 160, 120)
    masks = render_masks(pose_avatar(subject, anim), subject.faces, cam)
    config = TrackerConfig(scales=(0.92, 1.0, 1.08), downsample=1, body_scale=1.0)
    result = SilhouetteTracker(dictionary, [cam], config=config).track([masks])
    # The walk repeats itself: a frame one gait cycle away is the same posture, so
    # compare postures (joints relative to the root), not frame numbers.
    truth = dictionary.joint_positions[np.arange(len(masks))]
    got = dictionary.joint_positions[result.entries]
    err_mm = 1000 * np.linalg.norm(got - truth, axis=-1)[:, BODY_JOINTS].mean(axis=1)
    assert np.median(err_mm) < 20 and np.mean(err_mm < 50) > 0.9, err_mm.round()
    lag = np.abs(result.entries - np.arange(len(masks)))
    assert np.mean(lag <= 1) > 0.5
    # one camera cannot tell distance from size: the 2D scale search takes it up
    chosen = {float(e.scales[0]) for e in result.estimates}
    assert chosen <= {0.92, 1.0, 1.08} and chosen != {1.0}


def test_camera_pairs_and_missing_views(walk_setup):
    dictionary, bodies, cams, masks, _, _ = walk_setup
    far = [
        look_at([cam.center[0] + 20, cam.center[1], cam.center[2]], [20.5, 0.9, 0], cam.K, 320, 240)
        for cam in cams
    ]
    four = cams + far
    pairs = [CameraPair((0, 1), (-5, -3, 5, 3)), CameraPair((2, 3), (15, -3, 25, 3))]
    empty = np.zeros_like(masks[0])
    tracker = SilhouetteTracker(dictionary, four, bodies, pairs=pairs)
    result = tracker.track([masks[0], masks[1], empty, empty], frame_time_s=1 / 25)
    assert all(e.cameras == (0, 1) for e in result.estimates)
    # frames with no person: -1 before the first sighting, then the last estimate held
    blank = [np.concatenate([np.zeros_like(m[:2]), m[:3], np.zeros_like(m[:1])]) for m in masks]
    result = SilhouetteTracker(dictionary, cams, bodies).track(blank)
    assert result.entries[:2].tolist() == [-1, -1] and not result.found[:2].any()
    assert np.isnan(result.joint_positions_m[:2]).all()
    assert result.found[2:5].all() and not result.found[5]
    assert result.entries[5] == result.entries[4]


def test_errors(walk_setup):
    dictionary, bodies, cams, masks, _, _ = walk_setup
    tracker = SilhouetteTracker(dictionary, cams, bodies)
    with pytest.raises(InvalidParameterError, match="2 cameras"):
        tracker.step([masks[0][0]])
    with pytest.raises(InvalidParameterError, match="expected"):
        tracker.step([masks[0][0], masks[1][0][:10]])
    with pytest.raises(InvalidParameterError, match="frame counts"):
        tracker.track([masks[0], masks[1][:-1]])
    with pytest.raises(InvalidParameterError, match="at least one camera"):
        SilhouetteTracker(dictionary, [], bodies)
    for bad in (
        {"layer_step": 0},
        {"top_k": 0},
        {"max_candidates": 0},
        {"max_d1_deg": 0.0},
        {"shift_radius_px": -1},
        {"scales": ()},
        {"downsample": 1.5},
    ):
        with pytest.raises(InvalidParameterError, match=next(iter(bad))):
            TrackerConfig(**bad)
