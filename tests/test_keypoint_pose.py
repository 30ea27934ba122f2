"""The single-camera pose with the pose network's keypoints as a cue.

A library motion is performed by another body shape, rendered over a textured scene
(:func:`eigmotion.synth.clips.render_clip`) and written as a video; the tiny database
of ``tests/test_continuous_pose.py`` answers it.  The network runs on the frames for
real (LiteRT), the fit on its keypoints.
"""

from __future__ import annotations

import numpy as np
import pytest

import eigmotion.pose.keypoints as keypoints_module
from eigmotion.body.avatar import load_default_avatar
from eigmotion.body.retarget import pose_avatar, retarget
from eigmotion.cli.main import main
from eigmotion.errors import InvalidParameterError
from eigmotion.evaluation.joint_errors import (
    JOINT_ALIASES,
    LIMB_JOINTS,
    match_joints,
    pa_mpjpe_per_frame,
)
from eigmotion.imaging.cameras import virtual_rig
from eigmotion.imaging.figures import save_image
from eigmotion.imaging.media import write_video
from eigmotion.imaging.silhouettes import render_masks
from eigmotion.mocap.bvh import read_bvh
from eigmotion.mocap.kinematics import forward_kinematics
from eigmotion.mocap.library import load_library
from eigmotion.mocap.rotations import axis_rotation
from eigmotion.pose.continuous_pose import align_motion
from eigmotion.pose.keypoint_fit import (
    LIMB_PAIRS,
    KeypointFitConfig,
    camera_axes,
    fit_keypoints,
    sphere_directions,
)
from eigmotion.pose.keypoints import (
    ClipKeypoints,
    clip_keypoints,
    front_end_keypoints,
    keypoints_available,
    limb_world_joints,
    pose_keypoints,
    resolve_cue,
)
from eigmotion.retrieval.library_views import BuildConfig, hull_points
from eigmotion.segmentation.video import load_clip_masks
from eigmotion.synth.clips import render_clip

MOTIONS = ("kick_135_04", "wave_14_24")  # the database of tests/test_continuous_pose.py
CONFIG = BuildConfig(
    n_components=12, key_axes=3, key_sections=6, garments=((),), body_shapes=((None, 1.0),)
)
CLIP_FPS = 30.0
AVATAR = load_default_avatar()
#: The avatar's joint for each development-set limb joint.
AVATAR_LIMBS = {
    joint: next(a for a in JOINT_ALIASES[joint] if a in AVATAR.joint_names) for joint in LIMB_JOINTS
}

needs_litert = pytest.mark.skipif(not keypoints_available(), reason="LiteRT not installed")


@pytest.fixture(scope="module")
def db_path(ring6_database):
    return ring6_database(MOTIONS, CONFIG)


@pytest.fixture(scope="module")
def video(tmp_path_factory):
    """(video path, background path, true (F, 12, 3) limb joints in metres)."""
    motion = {m.name: m for m in load_library()}[MOTIONS[0]].motion
    body = AVATAR.with_shape(height_m=1.62, girth=1.15)
    clip = render_clip(motion, body, 30.0, 10.0, np.random.default_rng(7))
    folder = tmp_path_factory.mktemp("keypoint_clip")
    write_video(clip.frames, folder / "clip.mp4", clip.fps)
    save_image(clip.background, folder / "background.png")
    joints = retarget(motion.resample(clip.fps), body).joint_positions
    names = list(AVATAR.joint_names)
    truth = joints[:, [names.index(AVATAR_LIMBS[j]) for j in LIMB_JOINTS]]
    return folder / "clip.mp4", folder / "background.png", truth


def limb_error_mm(names, positions, truth) -> float:
    """Mean PA-MPJPE per frame over the 12 limb joints, mm."""
    est, true, _ = match_joints(names, positions, LIMB_JOINTS, truth, LIMB_JOINTS)
    return float(pa_mpjpe_per_frame(est, true).mean())


def heading_error_mm(names, positions, truth) -> float:
    """Mean distance over the 12 limb joints, mm, both centred between the hips per
    frame, the truth turned into the outputs' axes (the clip's camera, at azimuth 30°,
    turned to azimuth 0): the body's heading and its left and right count."""
    est, true, _ = match_joints(names, positions, LIMB_JOINTS, truth, LIMB_JOINTS)
    hips = [LIMB_JOINTS.index("l_hip"), LIMB_JOINTS.index("r_hip")]
    est = est - est[:, hips].mean(1, keepdims=True)
    true = (true - true[:, hips].mean(1, keepdims=True)) @ axis_rotation("Y", -30.0).T
    return float(1000 * np.linalg.norm(est - true, axis=-1).mean())


def query_pose(db_path, video, tmp_path, cue):
    clip, background, _ = video
    pose_path, bvh_path = tmp_path / f"{cue}.npz", tmp_path / f"{cue}.bvh"
    rc = main(
        ["query", str(clip), "--db", str(db_path), "--background", str(background),
         "--pose-out", str(pose_path), "--bvh-out", str(bvh_path), "--pose-cue", cue]
    )  # fmt: skip
    assert rc == 0
    with np.load(pose_path) as data:
        return tuple(str(s) for s in data["names"]), data["positions"], read_bvh(bvh_path)


@needs_litert
def test_keypoints_cue_keeps_the_output_and_follows_the_person(db_path, video, tmp_path):
    """Both cues write the same joint set, axes and frame count; the BVH is the npz's
    motion; the keypoints cue stays near the truth.  (On a clip of a library motion the
    silhouette cue is as close or closer: the reference is the very motion, and the
    network's keypoints of the rendered body are rougher than its outline.)"""
    _, _, truth = video
    names_s, silhouette, _ = query_pose(db_path, video, tmp_path, "silhouette")
    names_k, keypoints, bvh = query_pose(db_path, video, tmp_path, "keypoints")
    assert names_k == names_s == tuple(AVATAR.joint_names)
    assert keypoints.shape == silhouette.shape == (len(truth), len(names_k), 3)
    from_bvh = forward_kinematics(bvh, length_unit_m=1.0, ground=False).positions
    assert np.abs(from_bvh - keypoints).max() < 2e-3
    # the same root path on the floor, Y up, and the lowest joint as high: only the
    # posture and heading are refitted
    np.testing.assert_allclose(keypoints[:, 0, [0, 2]], silhouette[:, 0, [0, 2]], atol=1e-9)
    np.testing.assert_allclose(keypoints[..., 1].min(1), silhouette[..., 1].min(1), atol=1e-9)
    head = names_k.index("Head")
    assert np.all(keypoints[:, head, 1] > keypoints[:, 0, 1])
    ours = limb_error_mm(names_k, keypoints, truth)
    before = limb_error_mm(names_s, silhouette, truth)
    # near the truth; the silhouette cue, aligning the very motion, as near or nearer
    # (the same posture where the landmarks agree with it within ``agreement_m``: the
    # keypoints then tell nothing new and the fit keeps it)
    assert ours < 110.0 and before <= ours, (ours, before)
    # heading and sides counted (no rotation fitted): not turned or mirrored off the
    # silhouette cue, which here aligns the very motion
    assert (
        heading_error_mm(names_k, keypoints, truth)
        < heading_error_mm(names_s, silhouette, truth) + 10.0
    )


@needs_litert
def test_world_cue_keeps_the_silhouettes_heading_and_place(db_path, video, tmp_path):
    """The world cue writes the silhouette cue's joint set and frames; only the trunk
    and limbs turn: the root and both hip joints (hence the heading) stay where the
    silhouettes put them on the floor, raised or lowered together so that the lowest
    joint is as high (to 1e-9 m); the BVH is the npz's motion; the limbs stay near the
    truth."""
    _, _, truth = video
    names_s, silhouette, _ = query_pose(db_path, video, tmp_path, "silhouette")
    names_w, world, bvh = query_pose(db_path, video, tmp_path, "world")
    assert names_w == names_s and world.shape == silhouette.shape
    kept = [names_w.index(n) for n in ("Hips", "LeftUpLeg", "RightUpLeg")]
    rise = (world[:, 0, 1] - silhouette[:, 0, 1])[:, None, None] * [0.0, 1.0, 0.0]
    np.testing.assert_allclose(world[:, kept], silhouette[:, kept] + rise, rtol=0, atol=1e-9)
    np.testing.assert_allclose(world[..., 1].min(1), silhouette[..., 1].min(1), atol=1e-9)
    assert np.abs(world - silhouette).max() > 0.01  # the limbs did move
    from_bvh = forward_kinematics(bvh, length_unit_m=1.0, ground=False).positions
    assert np.abs(from_bvh - world).max() < 2e-3
    ours = limb_error_mm(names_w, world, truth)
    assert ours < 130.0, ours


@needs_litert
def test_network_keypoints_lie_on_the_rendered_person(video):
    """The network finds the person in most frames; its limb landmarks project inside
    the true silhouette's box; its world landmarks are a body of about the right size."""
    clip, background, truth = video
    cut = load_clip_masks(clip, background, segmenter="subtraction")
    keypoints = clip_keypoints(clip, cut.masks, cut.frame_indices)
    assert keypoints.image_px.shape == (len(cut.masks), 33, 2)
    assert keypoints.found.mean() > 0.8
    assert keypoints.seconds_per_frame > 0
    h, w = cut.masks.shape[1:]
    for i in np.flatnonzero(keypoints.found):
        rows, cols = np.flatnonzero(cut.masks[i].any(1)), np.flatnonzero(cut.masks[i].any(0))
        xy = keypoints.image_px[i, [11, 12, 23, 24]]  # shoulders and hips
        assert np.all((xy[:, 0] > cols[0] - 3) & (xy[:, 0] < cols[-1] + 4)), i
        assert np.all((xy[:, 1] > rows[0] - 3) & (xy[:, 1] < rows[-1] + 4)), i
    names, world = limb_world_joints(keypoints)
    assert names == LIMB_JOINTS and world.shape == truth.shape
    assert limb_error_mm(names, world, truth) < 120.0


@needs_litert
def test_the_3d_answer_reuses_the_front_ends_network_answer(video, monkeypatch):
    """The learned front end keeps the pose network's answer it had while it cut the
    silhouettes, and the 3D answer takes it; the network runs again only on the frames
    where the front end found no one (on this faceless render, the first ones).  The
    kept answer lies where a run on squares around the finished silhouettes puts it.
    Background subtraction keeps none: there the network runs on every frame."""
    clip, background, truth = video
    cut = load_clip_masks(clip, background, segmenter="fused")
    kept = front_end_keypoints(cut)
    again = clip_keypoints(clip, cut.masks, cut.frame_indices)
    assert kept.image_px.shape == again.image_px.shape and kept.seconds_per_frame == 0
    assert np.all((kept.visibility >= 0) & (kept.visibility <= 1))
    assert np.isnan(kept.world_m[~kept.found]).all() and (kept.visibility[~kept.found] == 0).all()
    both = kept.found & again.found
    assert both.sum() >= 10
    apart = np.linalg.norm(kept.image_px[both] - again.image_px[both], axis=-1)
    assert np.median(apart) < 2.0, np.median(apart)  # pixels of the masks
    assert np.median(pa_mpjpe_per_frame(kept.world_m[both], again.world_m[both])) < 40.0

    runs = []
    network = keypoints_module.pose_network()  # the real network, its runs counted
    monkeypatch.setattr(
        keypoints_module, "pose_network", lambda: lambda x: runs.append(1) or network(x)
    )
    answer = pose_keypoints(cut, clip)
    assert len(runs) == (~kept.found).sum() > 0
    np.testing.assert_array_equal(answer.world_m[kept.found], kept.world_m[kept.found])
    filled = ~kept.found & again.found
    np.testing.assert_array_equal(answer.world_m[filled], again.world_m[filled])
    np.testing.assert_array_equal(answer.found, kept.found | again.found)
    names, world = limb_world_joints(answer)
    assert limb_error_mm(names, world, truth) < 120.0

    runs.clear()
    subtracted = load_clip_masks(clip, background, segmenter="subtraction")
    assert front_end_keypoints(subtracted) is None
    assert pose_keypoints(subtracted, clip).found.mean() > 0.8
    assert len(runs) == len(subtracted.masks)


@needs_litert
def test_the_network_pass_shows_progress_once_it_takes_a_while(video, monkeypatch, capsys):
    """With ``progress``, a bar on stderr once the network has run for
    ``NETWORK_BAR_DELAY_S`` (here at once); none without, and the same keypoints."""
    clip, background, _ = video
    cut = load_clip_masks(clip, background, segmenter="subtraction")
    quiet = clip_keypoints(clip, cut.masks[:6], cut.frame_indices[:6])
    assert "pose network" not in capsys.readouterr().err
    monkeypatch.setattr(keypoints_module, "NETWORK_BAR_DELAY_S", 0.0)
    shown = clip_keypoints(clip, cut.masks[:6], cut.frame_indices[:6], progress=True)
    assert "pose network" in capsys.readouterr().err
    np.testing.assert_array_equal(shown.image_px, quiet.image_px)


def _turned_truth(pose, truth_pose, with_world: bool):
    """Synthetic keypoints: ``truth_pose``'s limb joints seen by the pose's camera
    (weak perspective, 40 pixels per metre), and as world landmarks in the camera's
    axes (x right, y down, z away) if ``with_world``."""
    joints = [pose.names.index(n) for n, _ in LIMB_PAIRS]
    marks = [m for _, m in LIMB_PAIRS]
    axes = camera_axes(pose.elevation_deg)
    image = np.full((pose.n_frames, 33, 2), np.nan)
    image[:, marks] = 40.0 * truth_pose[:, joints] @ axes.T + [80.0, 60.0]
    visibility = np.where(np.isfinite(image[..., 0]), 1.0, 0.0)
    world = np.full((pose.n_frames, 33, 3), np.nan)
    if with_world:
        camera = np.stack([axes[0], axes[1], np.cross(axes[0], axes[1])])  # rows in the scene
        world[:, marks] = (truth_pose[:, joints] - truth_pose[:, :1]) @ camera.T
    return ClipKeypoints(image, visibility, world, np.ones(pose.n_frames, bool), 0.0)


def test_fit_lays_the_joints_on_the_keypoints():
    """A pose fitted to the projection of another posture of the same body moves its
    joints toward that posture (3D, after alignment) and onto its projection (2D)."""
    motion = {m.name: m for m in load_library()}[MOTIONS[0]].motion
    body = AVATAR.decimated(4000)
    anim = retarget(motion.resample(CLIP_FPS), body)
    vertices = pose_avatar(body, anim)
    camera = virtual_rig([0.0], [10.0], 160, 120).fitted(hull_points(vertices))[0]
    masks = render_masks(vertices, body.faces, camera)
    pose = align_motion(motion, (0, motion.n_frames), 0.0, 10.0, masks, CLIP_FPS)
    # the target: the aligned pose played 8 frames later (another posture, same body)
    shifted = np.concatenate([pose.positions[8:], pose.positions[-1:].repeat(8, 0)])
    target = shifted - shifted[:, :1] + pose.positions[:, :1]
    config = KeypointFitConfig(prior=0.01, agreement_m=0.0)  # fitted even where close
    fitted = fit_keypoints(pose, _turned_truth(pose, target, False), config)
    with_world = fit_keypoints(pose, _turned_truth(pose, target, True), config)
    limbs = [pose.names.index(n) for n, _ in LIMB_PAIRS]

    def error(positions):
        return float(pa_mpjpe_per_frame(positions[:, limbs], target[:, limbs]).mean())

    # 2D alone leaves each bone's depth to the prior; the world landmarks tell it
    assert error(fitted.positions) < 0.6 * error(pose.positions)
    assert error(with_world.positions) < 0.6 * error(fitted.positions)
    assert fitted.positions.shape == pose.positions.shape
    assert fitted.names == pose.names and fitted.motion.n_frames == pose.n_frames
    assert "keypoints_fit" in fitted.timings_s


def test_fit_goes_the_set_share_of_the_way_to_the_network_posture():
    """World landmarks of another posture of the same body, the image landmarks of the
    pose itself: the whole way there (``network_share`` 1, unsmoothed) the limbs take
    that posture up to the pelvis's and the shoulders' own turn, which the bones'
    directions do not set (the network's posture is brought onto the fit first, so its
    place, heading and size do not matter); half way lands between; frames where the
    network found no one keep the fit's posture to the bit."""
    motion = {m.name: m for m in load_library()}[MOTIONS[0]].motion
    body = AVATAR.decimated(4000)
    anim = retarget(motion.resample(CLIP_FPS), body)
    vertices = pose_avatar(body, anim)
    camera = virtual_rig([0.0], [10.0], 160, 120).fitted(hull_points(vertices))[0]
    pose = align_motion(
        motion, (0, motion.n_frames), 0.0, 10.0, render_masks(vertices, body.faces, camera),
        CLIP_FPS,
    )  # fmt: skip
    shifted = np.concatenate([pose.positions[8:], pose.positions[-1:].repeat(8, 0)])
    other = shifted - shifted[:, :1] + pose.positions[:, :1]
    image = _turned_truth(pose, pose.positions, False)
    world = _turned_truth(pose, 1.3 * other @ axis_rotation("Y", 40.0).T, True).world_m
    lost = np.arange(3, pose.n_frames, 10)
    found = np.ones(pose.n_frames, bool)
    found[lost] = False
    world[lost] = np.nan
    keypoints = ClipKeypoints(image.image_px, image.visibility, world, found, 0.0)
    limbs = [pose.names.index(n) for n, _ in LIMB_PAIRS]
    seen = np.flatnonzero(found)

    def fitted(share):
        config = KeypointFitConfig(agreement_m=0.0, network_share=share, network_smooth_s=0.0)
        return fit_keypoints(pose, keypoints, config).positions

    def error_mm(positions):
        return float(pa_mpjpe_per_frame(positions[seen][:, limbs], other[seen][:, limbs]).mean())

    alone, half, whole = fitted(0.0), fitted(0.5), fitted(1.0)
    # (85, 51 and 15 mm when written)
    assert error_mm(whole) < error_mm(half) < error_mm(alone)
    assert error_mm(whole) < 0.25 * error_mm(alone), (error_mm(whole), error_mm(alone))
    assert error_mm(half) < 0.7 * error_mm(alone), (error_mm(half), error_mm(alone))
    np.testing.assert_array_equal(half[lost], alone[lost])
    np.testing.assert_array_equal(whole[lost], alone[lost])


@pytest.fixture(scope="module")
def aligned_kick():
    """A kick aligned to its own rendered silhouettes from 30° (the continuous pose)."""
    motion = {m.name: m for m in load_library()}[MOTIONS[0]].motion
    body = AVATAR.decimated(4000)
    anim = retarget(motion.resample(CLIP_FPS), body)
    vertices = pose_avatar(body, anim)
    camera = virtual_rig([30.0], [10.0], 160, 120).fitted(hull_points(vertices))[0]
    masks = render_masks(vertices, body.faces, camera)
    return align_motion(motion, (0, motion.n_frames), 30.0, 10.0, masks, CLIP_FPS)


def _facing_deg(positions, names):
    """(F,) the body's heading about the vertical, degrees: the direction of its hips'
    left-to-right line."""
    hips = positions[:, names.index("LeftUpLeg")] - positions[:, names.index("RightUpLeg")]
    return np.degrees(np.arctan2(hips[:, 2], hips[:, 0]))


def test_fit_keeps_a_pose_the_landmarks_agree_with(aligned_kick):
    """Landmarks on the pose's own joints, 3 cm of noise on each: nothing to correct,
    the pose comes back as it was (with ``agreement_m`` 0 it is moved)."""
    pose = aligned_kick
    keypoints = _turned_truth(pose, pose.positions, True)
    noise = np.random.default_rng(3).normal(0.0, 0.03 * 40.0 / np.sqrt(2), keypoints.image_px.shape)
    noisy = ClipKeypoints(
        keypoints.image_px + noise, keypoints.visibility, keypoints.world_m, keypoints.found, 0.0
    )
    kept = fit_keypoints(pose, noisy)
    np.testing.assert_array_equal(kept.positions, pose.positions)
    assert "keypoints_fit" in kept.timings_s
    moved = fit_keypoints(pose, noisy, KeypointFitConfig(agreement_m=0.0))
    assert np.abs(moved.positions - pose.positions).max() > 0.01


def test_frames_where_the_network_lost_the_person_do_not_turn_the_body(aligned_kick):
    """Another posture's landmarks, but in a few frames the network lost the person and
    answered with landmarks bunched into a few pixels (a weak-perspective scale near 0,
    whose residual over s² would otherwise outweigh the whole clip): the body keeps its
    heading within 30° in every frame; counting those frames (``scale_band`` 1e6)
    turns it 60° or more in some."""
    pose = aligned_kick
    shifted = np.concatenate([pose.positions[8:], pose.positions[-1:].repeat(8, 0)])
    target = shifted - shifted[:, :1] + pose.positions[:, :1]
    keypoints = _turned_truth(pose, target, False)
    image = keypoints.image_px.copy()
    lost = np.arange(5, pose.n_frames, 12)
    marks = [m for _, m in LIMB_PAIRS]
    rng = np.random.default_rng(5)
    image[lost[:, None], marks] = [80.0, 60.0] + rng.normal(0.0, 0.3, (len(lost), len(marks), 2))
    bunched = ClipKeypoints(image, keypoints.visibility, keypoints.world_m, keypoints.found, 0.0)
    before = _facing_deg(pose.positions, pose.names)

    def turned_deg(config):
        fitted = fit_keypoints(pose, bunched, config)
        after = _facing_deg(fitted.positions, fitted.names)
        return np.abs((after - before + 180.0) % 360.0 - 180.0)

    kept, counted = (
        turned_deg(KeypointFitConfig(agreement_m=0.0, scale_band=band)) for band in (0.5, 1e6)
    )
    assert kept.max() <= 30.0 and counted.max() >= 60.0, (kept.max(), counted.max())


def test_sphere_directions_are_unit_and_spread():
    d = sphere_directions(500)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0)
    assert np.abs(d.mean(0)).max() < 0.01
    # every direction has a neighbour within 12°
    nearest = np.sort(d @ d.T, axis=1)[:, -2]
    assert np.degrees(np.arccos(nearest.min())) < 12.0


@pytest.mark.parametrize(
    "change",
    [{"prior": -1.0}, {"directions": 10}, {"rounds": 0}, {"min_visibility": 2.0},
     {"heading_step_deg": 0.0}, {"scale_band": 0.0}, {"agreement_m": -0.1},
     {"network_share": 1.5}, {"network_share": -0.1}, {"network_smooth_s": -1.0}],
)  # fmt: skip
def test_fit_config_rejects_out_of_range_values(change):
    with pytest.raises(InvalidParameterError):
        KeypointFitConfig(**change)


def test_resolve_cue(tmp_path):
    assert resolve_cue("silhouette", tmp_path / "clip.mp4") == "silhouette"
    assert resolve_cue("auto", tmp_path / "clip.npz") == "silhouette"
    expected = "world" if keypoints_available() else "silhouette"
    assert resolve_cue("auto", tmp_path / "clip.mp4") == expected
    if keypoints_available():
        assert resolve_cue("world", tmp_path / "clip.mp4") == "world"
    for cue in ("keypoints", "world"):
        with pytest.raises(InvalidParameterError, match=f"the {cue} cue needs the clip's frames"):
            resolve_cue(cue, tmp_path / "clip.npz")
    with pytest.raises(InvalidParameterError, match="one of"):
        resolve_cue("depth", tmp_path / "clip.mp4")


@pytest.mark.parametrize("cue", ["keypoints", "world"])
def test_query_network_cue_on_stored_masks_is_one_line(db_path, tmp_path, capsys, cue):
    clip_path = tmp_path / "clip.npz"
    np.savez_compressed(clip_path, masks=np.ones((5, 40, 30), bool), fps=CLIP_FPS)
    out = tmp_path / "pose.npz"
    rc = main(["query", str(clip_path), "--db", str(db_path), "--pose-out", str(out),
               "--pose-cue", cue])  # fmt: skip
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1 and "frames" in err
    assert not out.exists()
