"""``eigmotion eval tracking`` and ``eval pose``: the joint errors and the commands.

The measures are checked on small arrays made up here; the commands end to end on a
tiny folder laid out like the development set, written by the test (a library walk
rendered on another body, seen by two calibrated cameras and by one), against what
``eigmotion track --joints-out`` and ``eigmotion query --pose-out`` write.
"""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from eigmotion.body.avatar import load_default_avatar
from eigmotion.body.retarget import animate_avatar
from eigmotion.cli.main import main
from eigmotion.errors import InvalidParameterError
from eigmotion.evaluation.joint_errors import (
    JOINT_ALIASES,
    LIMB_JOINTS,
    ROOT_JOINT,
    TRACKING_JOINTS,
    heading_deg,
    heading_error_deg,
    match_joints,
    mirror_index,
    pa_mpjpe_per_clip,
    pa_mpjpe_per_frame,
    swapped_frames,
    tracking_errors,
)
from eigmotion.imaging.cameras import intrinsics, look_at
from eigmotion.imaging.media import write_video
from eigmotion.imaging.render import render_shaded
from eigmotion.imaging.silhouettes import render_masks
from eigmotion.mocap.library import load_library
from eigmotion.mocap.rotations import similarity_align
from eigmotion.pose.keypoints import keypoints_available
from eigmotion.retrieval.database import QUERY_SILHOUETTE_CONFIG
from eigmotion.segmentation import learned
from eigmotion.segmentation.video import load_clip_masks
from eigmotion.synth.clips import clip_camera
from eigmotion.synth.scene import compose_scene
from eigmotion.tracking.calibration import save_calibration
from eigmotion.tracking.postures import yaw_rotation

#: A standing body facing +Z (+X its left), in the development set's joint names.
BODY = {
    "pelvis": (0.0, 1.0, 0.0), "l_hip": (0.1, 0.95, 0.0), "r_hip": (-0.1, 0.95, 0.0),
    "l_knee": (0.1, 0.5, 0.05), "r_knee": (-0.1, 0.5, 0.0),
    "l_ankle": (0.1, 0.08, 0.0), "r_ankle": (-0.1, 0.08, -0.05),
    "l_shoulder": (0.2, 1.45, 0.0), "r_shoulder": (-0.2, 1.45, 0.0),
    "l_elbow": (0.25, 1.2, 0.1), "r_elbow": (-0.25, 1.2, 0.0),
    "l_wrist": (0.3, 0.95, 0.2), "r_wrist": (-0.3, 0.95, 0.0), "head": (0.0, 1.65, 0.02),
}  # fmt: skip


def _body(n_frames=4, seed=0):
    """(n_frames, 14, 3) metres: BODY walking forward with a little jitter, and names."""
    rng = np.random.default_rng(seed)
    names = list(BODY)
    base = np.array([BODY[n] for n in names])
    frames = base + rng.normal(0, 0.02, (n_frames, *base.shape))
    frames[..., 2] += np.arange(n_frames)[:, None] * 0.3
    return names, frames


def _turned(points, deg):
    return points @ yaw_rotation(deg).T


def test_similarity_alignment_removes_rotation_scale_and_shift():
    names, truth = _body()
    moved = 1.3 * _turned(truth[0], 70.0) + [2.0, -1.0, 0.5]
    assert np.allclose(similarity_align(moved, truth[0]), truth[0])
    est = 0.8 * _turned(truth, 35.0) + [0.3, 0.0, -4.0]
    assert np.allclose(pa_mpjpe_per_frame(est, truth), 0.0, atol=1e-9)
    assert pa_mpjpe_per_clip(est, truth) == pytest.approx(0.0, abs=1e-9)
    # each frame turned its own way: aligned per frame, not by one clip-wide similarity
    twisted = np.stack([_turned(f, 40.0 * i) for i, f in enumerate(truth)])
    assert np.allclose(pa_mpjpe_per_frame(twisted, truth), 0.0, atol=1e-9)
    assert pa_mpjpe_per_clip(twisted, truth) > 50.0
    # one joint 10 cm off in every frame: the alignment can spread the error but never
    # raise its root mean square (100 mm / sqrt(joints)), which bounds the mean
    off = truth.copy()
    off[:, 0, 0] += 0.1
    per_frame = pa_mpjpe_per_frame(off, truth)
    assert np.all((per_frame > 1.0) & (per_frame < 100.0 / np.sqrt(len(names))))


def test_left_right_swaps_and_heading_flips_are_told_apart():
    names, truth = _body(6)
    joints = [n for n in names if n != ROOT_JOINT]
    truth = truth[:, [names.index(j) for j in joints]]
    mirror = mirror_index(joints)
    assert [joints[i] for i in mirror[:2]] == ["r_hip", "l_hip"]
    assert joints[mirror[joints.index("head")]] == "head"
    assert np.allclose(heading_deg(truth, joints), 0.0, atol=10.0)  # 2 cm of jitter
    assert np.allclose(heading_deg(_turned(truth, 90.0), joints), heading_deg(truth, joints) + 90)
    # as it is: no swap, no flip
    assert not swapped_frames(truth, truth, joints).any()
    assert np.allclose(heading_error_deg(truth, truth, joints), 0.0)
    # the estimate's left and right exchanged in frames 1 and 4
    est = truth.copy()
    est[[1, 4]] = est[[1, 4]][:, mirror]
    assert swapped_frames(est, truth, joints).tolist() == [0, 1, 0, 0, 1, 0]
    # the body turned 180° about its own centre in frames 2 and 3, or 60° in frame 5
    centre = truth.mean(1, keepdims=True)
    est = truth.copy()
    est[2:4] = _turned(truth[2:4] - centre[2:4], 180.0) + centre[2:4]
    est[5] = _turned(truth[5] - centre[5], 60.0) + centre[5]
    error = heading_error_deg(est, truth, joints)
    assert error[2:4] == pytest.approx([180.0, 180.0], abs=3.0)
    assert error[5] == pytest.approx(60.0, abs=3.0)
    assert ((error > 90.0) == [0, 0, 1, 1, 0, 0]).all()


def test_tracking_errors_match_joints_by_their_aliases():
    names, truth = _body(5)
    # an estimate in a BVH skeleton's names, 5 cm to the right, one frame longer
    aliases = {"pelvis": "Hips", **{j: JOINT_ALIASES[j][0] for j in TRACKING_JOINTS}}
    est_names = ["Spine", *(aliases[n] for n in names)]
    est = np.concatenate([np.zeros((5, 1, 3)), truth], 1) + [-0.05, 0.0, 0.0]
    est = np.concatenate([est, est[-1:]])
    errors = tracking_errors(est_names, est, names, truth)
    assert errors.joints == TRACKING_JOINTS and errors.frames == 5
    assert errors.mpjpe_mm == pytest.approx(50.0)
    assert errors.per_joint_mm == pytest.approx(np.full(13, 50.0))
    assert errors.root_mm == pytest.approx(50.0)
    assert (errors.swaps, errors.heading_flips) == (0, 0)
    assert json.loads(json.dumps(errors.to_json()))["per_joint_mm"]["head"] == 50.0
    e, t, matched = match_joints(est_names, est, names, truth, LIMB_JOINTS)
    assert e.shape == t.shape == (5, 12, 3) and matched == LIMB_JOINTS
    with pytest.raises(InvalidParameterError, match="match none"):
        match_joints(["a", "b"], est[:, :2], names, truth, LIMB_JOINTS)


# -- end to end ----------------------------------------------------------------------


def _truth_of(anim) -> tuple[list[str], np.ndarray]:
    """The development set's joints (names, (F, 14, 3)) of an avatar animation."""
    wanted = {ROOT_JOINT: "Hips", **{j: JOINT_ALIASES[j][0] for j in TRACKING_JOINTS}}
    index = [anim.joint_names.index(a) for a in wanted.values()]
    return list(wanted), anim.joint_positions[:, index].astype(np.float32)


def _write_truth(folder: Path, names, positions) -> None:
    np.save(folder / "joints.npy", positions)
    (folder / "joints.json").write_text(json.dumps({"names": names}))


@pytest.fixture(scope="module")
def dev_set(tmp_path_factory):
    """One two-camera set and one retrieval clip of a library walk on another body."""
    by_name = {m.name: m for m in load_library()}
    body = load_default_avatar().with_shape(height_m=1.62, girth=1.15).decimated(4000)
    rng = np.random.default_rng(5)
    dev = tmp_path_factory.mktemp("devset_pose") / "dev"
    walk = by_name["walk_02_01"].motion.resample(30.0)
    anim, vertices = animate_avatar(body, walk)
    anim_frames = slice(0, 24)
    names, truth = _truth_of(anim)
    # two cameras, 1.5 m high, at ±60° from the walk, as the development set has them
    folder = dev / "tracking" / "track_t"
    folder.mkdir(parents=True)
    K = intrinsics(320, 240, 45.0)
    middle = truth[anim_frames, 0].mean(0)
    forward = truth[anim_frames][-1, 0] - truth[anim_frames][0, 0]
    heading = np.rad2deg(np.arctan2(forward[0], forward[2]))
    cams = []
    for i, side in enumerate((60.0, -60.0)):
        direction = yaw_rotation(heading + side) @ [0.0, 0.0, 1.0]
        eye = middle + 3.2 * direction
        eye[1] = 1.5
        cams.append(look_at(eye, [middle[0], 0.9, middle[2]], K, 320, 240, name=f"cam{i}"))
    save_calibration(cams, folder / "cams.json")
    for i, cam in enumerate(cams):
        masks = render_masks(vertices[anim_frames], body.faces, cam)
        # a shaded body, as the person networks of the default front end need
        shaded = render_shaded(vertices[anim_frames], body.faces, cam, floor=False)
        frames, background = compose_scene(shaded, masks, rng)
        write_video(frames, folder / f"cam{i}.mp4", 30.0)
        cv2.imwrite(str(folder / f"background{i}.png"), background[..., ::-1])
        np.savez_compressed(folder / f"masks{i}.npz", masks=masks)
    _write_truth(folder, names, truth[anim_frames])
    (folder / "meta.json").write_text(json.dumps({"label": "walk"}))
    # one camera: a retrieval clip
    folder = dev / "retrieval" / "walk_t_v0"
    folder.mkdir(parents=True)
    clip = vertices[: int(2.5 * 30)]
    masks = render_masks(clip, body.faces, clip_camera(clip, 40, 8.0, 320, 240))
    frames, background = compose_scene(None, masks, rng)
    write_video(frames, folder / "video.mp4", 30.0)
    cv2.imwrite(str(folder / "background.png"), background[..., ::-1])
    _write_truth(folder, names, truth[: len(clip)])
    (folder / "meta.json").write_text(json.dumps({"label": "walk", "fps": 30.0}))
    return dev


def test_eval_tracking_scores_what_track_writes(dev_set, tmp_path, capsys):
    """Background subtraction: the person networks of the default front end take little
    of this plain rendered body (IoU 0.6-0.7, below)."""
    out = tmp_path / "tracking.json"
    subtraction = ["--segmenter", "subtraction"]
    args = ["eval", "tracking", "--dev", str(dev_set), "--json-out", str(out), *subtraction]
    assert main(args) == 0
    printed = capsys.readouterr().out
    assert "## tracking" in printed and "track_t" in printed and "l_wrist" in printed
    report = json.loads(out.read_text())
    (scored,) = report["sets"]
    assert scored["error"] is None and scored["frames"] == 24
    assert scored["estimates"] == 24 and scored["estimates_per_cpu_s"] > 0
    assert report["summary"]["mpjpe_mm"] == pytest.approx(scored["mpjpe_mm"], abs=0.01)
    # the same figures from the command's own output
    folder = dev_set / "tracking" / "track_t"
    joints = tmp_path / "j.npz"
    args = ["track", "--calib", folder / "cams.json", folder / "cam0.mp4", folder / "cam1.mp4",
            "--background", folder / "background0.png", folder / "background1.png",
            "--joints-out", joints, *subtraction]  # fmt: skip
    assert main([str(a) for a in args]) == 0
    written = np.load(joints)
    truth_names = json.loads((folder / "joints.json").read_text())["names"]
    errors = tracking_errors(
        [str(n) for n in written["names"]], written["positions"], truth_names,
        np.load(folder / "joints.npy"),
    )  # fmt: skip
    assert scored["mpjpe_mm"] == pytest.approx(errors.mpjpe_mm, abs=0.01)
    assert scored["root_mm"] == pytest.approx(errors.root_mm, abs=0.01)
    assert (scored["swaps"], scored["heading_flips"]) == (errors.swaps, errors.heading_flips)
    # a library walk the dictionary holds, on a body near the model: tracked closely
    assert scored["mpjpe_mm"] < 60 and scored["root_mm"] < 60
    # other tracker settings: as `track --no-travel-prior --scale-from-top` gives
    settings = ["travel_tolerance_deg=null", "scale_from_top=true"]
    other = tmp_path / "other.json"
    args_eval = ["eval", "tracking", "--dev", str(dev_set), "--json-out", str(other),
                 *subtraction, "--tracker-config", *settings]  # fmt: skip
    assert main(args_eval) == 0
    report = json.loads(other.read_text())
    assert report["tracker_config"]["travel_tolerance_deg"] is None
    assert report["tracker_config"]["scale_from_top"] is True
    assert main([str(a) for a in [*args, "--no-travel-prior", "--scale-from-top"]]) == 0
    written = np.load(joints)
    errors = tracking_errors(
        [str(n) for n in written["names"]], written["positions"], truth_names,
        np.load(folder / "joints.npy"),
    )  # fmt: skip
    assert report["sets"][0]["mpjpe_mm"] == pytest.approx(errors.mpjpe_mm, abs=0.01)


@pytest.mark.parametrize("segmenter", ["auto", "learned"])
def test_eval_tracking_segmenters_and_their_iou(dev_set, tmp_path, capsys, segmenter):
    """Each front end's silhouettes are scored against the set's true masks, and
    tracked as `track --segmenter` tracks them."""
    default = tmp_path / "subtraction.json"
    args = ["eval", "tracking", "--dev", str(dev_set), "--json-out", str(default),
            "--segmenter", "subtraction"]  # fmt: skip
    assert main(args) == 0
    out = tmp_path / f"{segmenter}.json"
    args = ["eval", "tracking", "--dev", str(dev_set), "--segmenter", segmenter,
            "--json-out", str(out)]  # fmt: skip
    assert main(args) == 0
    assert "silhouette IoU" in capsys.readouterr().out
    base, other = json.loads(default.read_text()), json.loads(out.read_text())
    assert base["segmenter"] == "subtraction" and other["segmenter"] == segmenter
    (subtracted,), (scored,) = base["sets"], other["sets"]
    assert scored["error"] is None and scored["frames"] == 24
    assert 0.8 < subtracted["silhouette_iou"] <= 1.0
    assert 0.5 < scored["silhouette_iou"] <= 1.0
    if segmenter == "learned":  # the networks alone round off the rendered avatar's limbs
        assert scored["silhouette_iou"] < subtracted["silhouette_iou"]
    assert other["summary"]["silhouette_iou"] == pytest.approx(scored["silhouette_iou"], abs=1e-4)
    # the keypoints stage runs on the networks' landmarks, not on subtraction's masks
    assert subtracted["keypoints_trusted"] is None
    assert 0.0 <= scored["keypoints_trusted"] <= 1.0
    folder = dev_set / "tracking" / "track_t"
    joints = tmp_path / "j.npz"
    backgrounds = [] if segmenter == "learned" else [
        "--background", folder / "background0.png", folder / "background1.png"]  # fmt: skip
    track = ["track", "--calib", folder / "cams.json", folder / "cam0.mp4", folder / "cam1.mp4",
             *backgrounds, "--segmenter", segmenter, "--joints-out", joints]  # fmt: skip
    assert main([str(a) for a in track]) == 0
    written = np.load(joints)
    errors = tracking_errors(
        [str(n) for n in written["names"]], written["positions"],
        json.loads((folder / "joints.json").read_text())["names"], np.load(folder / "joints.npy"),
    )  # fmt: skip
    assert scored["mpjpe_mm"] == pytest.approx(errors.mpjpe_mm, abs=0.01)


def test_a_floor_the_first_look_takes_for_a_person_is_left_out(dev_set, monkeypatch):
    """The retrieval clip's person is a flat-coloured figure the networks on the square
    often miss; in those frames the first look, at the whole frame, is sure that the
    textured floor (half the frame) is a person.  The clip's typical person comes from
    the frames the second look found, so those floors are left out: the masks are
    those of a first look never kept."""
    clip = dev_set / "retrieval" / "walk_t_v0" / "video.mp4"
    config = QUERY_SILHOUETTE_CONFIG
    cut = load_clip_masks(clip, config=config, sample_fps=15.0, segmenter="learned")
    monkeypatch.setattr(learned, "SURE_PROBABILITY", np.inf)  # the first look never stands
    never = load_clip_masks(clip, config=config, sample_fps=15.0, segmenter="learned")
    np.testing.assert_array_equal(cut.masks, never.masks)
    assert (cut.masks.sum(axis=(1, 2)) > 0).sum() >= 10


def test_eval_pose_scores_what_query_writes(dev_set, four_motion_database, tmp_path, capsys):
    db = four_motion_database
    out = tmp_path / "pose.json"
    args = ["eval", "pose", "--dev", str(dev_set), "--db", str(db), "--json-out", str(out)]
    assert main(args) == 0
    printed = capsys.readouterr().out
    assert "## pose" in printed
    report = json.loads(out.read_text())
    (scored,) = report["clips"]
    assert scored["error"] is None and scored["frames"] == 75
    if keypoints_available():  # every variant in the same run, the default among them
        assert "pose landmark network alone, world landmarks" in printed
        assert set(scored["variants"]) == {"silhouette", "world", "keypoints", "network"}
        assert "ours, world cue (query --pose-cue world)" in printed
        default = scored["variants"]["world"]  # the query's default cue for a video
        assert default["pa_mpjpe_frame_mm"] == scored["pa_mpjpe_frame_mm"]
        assert 0 < scored["variants"]["network"]["pa_mpjpe_frame_mm"] < 300
        assert scored["network_ms_per_frame"] > 0 and scored["fit_ms_per_frame"] > 0
    folder = dev_set / "retrieval" / "walk_t_v0"
    pose = tmp_path / "p.npz"
    query = ["query", folder / "video.mp4", "--db", db, "--background",
             folder / "background.png", "--pose-out", pose]  # fmt: skip
    assert main([str(a) for a in query]) == 0
    written = np.load(pose)
    est, true, _ = match_joints(
        [str(n) for n in written["names"]], written["positions"],
        json.loads((folder / "joints.json").read_text())["names"],
        np.load(folder / "joints.npy"), LIMB_JOINTS,
    )  # fmt: skip
    assert scored["pa_mpjpe_frame_mm"] == pytest.approx(
        pa_mpjpe_per_frame(est, true).mean(), abs=0.01
    )
    assert scored["pa_mpjpe_clip_mm"] == pytest.approx(pa_mpjpe_per_clip(est, true), abs=0.01)
    # the library's own walk, seen from a view the database holds: a close pose
    assert 0 < scored["pa_mpjpe_frame_mm"] < 200


def test_eval_tracking_and_pose_bad_input_is_one_line(dev_set, tmp_path, capsys):
    empty = tmp_path / "dev"
    (empty / "retrieval").mkdir(parents=True)
    assert main(["eval", "tracking", "--dev", str(empty)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "no tracking sets" in err
    assert main(["eval", "pose", "--dev", str(empty)]) == 2
    assert "no retrieval clips" in capsys.readouterr().err
    for setting, message in [
        ("nonsense=1", "'nonsense' is no tracker setting"),
        ("travel_weight", "expected NAME=VALUE"),
        ("travel_weight=abc", "the value is not JSON"),
        ("travel_weight=-1", "travel_weight must be"),
    ]:
        args = ["eval", "tracking", "--dev", str(dev_set), "--tracker-config", setting]
        assert main(args) == 2
        err = capsys.readouterr().err.strip()
        assert err.count("\n") == 0 and message in err, err
    assert main(["eval", "pose", "--dev", str(dev_set), "--db", str(tmp_path / "x.fs")]) == 2
    assert "no such database file" in capsys.readouterr().err
