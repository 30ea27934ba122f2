"""``eigmotion track``: errors as one line and exit 2, and an end-to-end run."""

from __future__ import annotations

import contextlib
import io
import subprocess
import sys

import cv2
import numpy as np
import pytest
from blender_helpers import assert_blender_reads_as_eigmotion, blender_python, read_in_blender

from eigmotion.body.avatar import load_default_avatar
from eigmotion.body.retarget import retarget
from eigmotion.cli.main import main
from eigmotion.imaging.cameras import intrinsics, look_at
from eigmotion.imaging.media import read_frames, write_video
from eigmotion.imaging.silhouettes import render_masks
from eigmotion.mocap.amc import read_amc
from eigmotion.mocap.bvh import read_bvh
from eigmotion.mocap.kinematics import forward_kinematics
from eigmotion.tracking.calibration import save_calibration
from eigmotion.tracking.postures import mean_heading_deg, yaw_rotation

N_FRAMES = 10


@pytest.fixture(scope="module")
def scene(tmp_path_factory, cmu_dir):
    """Two calibrated views of a walk (02_02, 25 fps) stored as .npz masks."""
    root = tmp_path_factory.mktemp("track")
    K = intrinsics(320, 240, 45.0)
    cams = [
        look_at([-2.5, 1.6, -3.5], [0.5, 0.9, 0.0], K, 320, 240, name="left"),
        look_at([-2.5, 1.6, 3.5], [0.5, 0.9, 0.0], K, 320, 240, name="right"),
    ]
    save_calibration(cams, root / "cams.json")
    motion = read_amc(cmu_dir / "amc" / "02_02.amc", cmu_dir / "asf" / "02.asf")
    subject = load_default_avatar().with_shape(height_m=1.7, girth=1.1)
    anim = retarget(motion.trim(0, 50).resample(100), subject)
    turn = yaw_rotation(90.0 - mean_heading_deg(anim.joint_rotations[:, 0]))
    rot = (turn @ anim.joint_rotations)[::4][:N_FRAMES]
    pos = (anim.joint_positions @ turn.T)[::4][:N_FRAMES]
    pos[..., [0, 2]] -= pos[0, 0, [0, 2]]
    vertices = subject.skin(rot, pos)
    paths = []
    for i, cam in enumerate(cams):
        masks = render_masks(vertices, subject.faces, cam)
        np.savez_compressed(root / f"cam{i}.npz", masks=masks, fps=25.0)
        paths.append(root / f"cam{i}.npz")
    return root, paths, pos, vertices, subject, cams


def run_cli(args, capsys):
    code = main(["track", *map(str, args)])
    captured = capsys.readouterr()
    return code, captured.out, captured.err.strip().splitlines()


def test_missing_calibration(scene, capsys, tmp_path):
    root, paths, *_ = scene
    code, _, err = run_cli(["--calib", tmp_path / "none.json", *paths], capsys)
    assert code == 2 and len(err) == 1 and "none.json" in err[0]


def test_videos_must_match_cameras(scene, capsys):
    root, paths, *_ = scene
    code, _, err = run_cli(["--calib", root / "cams.json", paths[0]], capsys)
    assert code == 2 and len(err) == 1 and "1 videos given for the 2 cameras" in err[0]


def test_backgrounds_must_match_videos(scene, capsys):
    root, paths, *_ = scene
    bg = root / "bg.png"
    cv2.imwrite(str(bg), np.zeros((240, 320, 3), np.uint8))
    code, _, err = run_cli(["--calib", root / "cams.json", *paths, "--background", bg], capsys)
    assert code == 2 and len(err) == 1 and "1 backgrounds given for 2 videos" in err[0]


def test_segmenter_needs_what_it_uses(scene, capsys, tmp_path):
    """The learned segmenter takes no background image, the fused one needs one."""
    root, *_ = scene
    video, image = tmp_path / "v.avi", tmp_path / "bg.png"
    write_video(np.zeros((3, 240, 320, 3), np.uint8), video, 25.0)
    cv2.imwrite(str(image), np.zeros((240, 320, 3), np.uint8))
    common = ["--calib", root / "cams.json", video, video]
    learned = [*common, "--background", image, image, "--segmenter", "learned"]
    code, _, err = run_cli(learned, capsys)
    assert code == 2 and len(err) == 1 and "learned segmenter does not use" in err[0]
    code, _, err = run_cli([*common, "--segmenter", "fused"], capsys)
    assert code == 2 and len(err) == 1 and "fused segmenter needs" in err[0]


def test_wrong_frame_size(scene, capsys, tmp_path):
    root, paths, *_ = scene
    small = tmp_path / "small.npz"
    masks = np.zeros((N_FRAMES, 120, 160), bool)
    masks[:, 40:100, 70:90] = True
    np.savez(small, masks=masks)
    code, _, err = run_cli(["--calib", root / "cams.json", paths[0], small], capsys)
    assert code == 2 and len(err) == 1 and "calibrated at 320×240" in err[0]


def test_errors_in_a_subprocess_have_no_traceback(scene, tmp_path):
    root, paths, *_ = scene
    proc = subprocess.run(
        [sys.executable, "-m", "eigmotion", "track", "--calib", str(tmp_path / "x.json")]
        + [str(p) for p in paths],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in proc.stderr


@pytest.fixture(scope="module")
def tracked(scene, tmp_path_factory):
    """One run of ``eigmotion track`` on the scene: (folder of its outputs, stdout, stderr)."""
    root, paths, *_ = scene
    work = tmp_path_factory.mktemp("tracked")
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(
            [
                "track", "--calib", str(root / "cams.json"), *map(str, paths),
                "--dictionary", "walk_02_01", "--heading-step-deg", "30",
                "--bvh-out", str(work / "out.bvh"), "--joints-out", str(work / "out.npz"),
                "--overlay-out", str(work / "out.gif"), "--dictionary-out", str(work / "dict.npz"),
            ]
        )  # fmt: skip
    assert code == 0, err.getvalue()
    return work, out.getvalue(), err.getvalue()


def test_track_bvh_stands_on_the_floor_in_blender(scene, tracked, tmp_path):
    """Blender places the tracked BVH as eigmotion does; its lowest joint (a toe joint:
    the avatar's skeleton has no end sites at the soles) is as high as the truth's."""
    python = blender_python()
    if python is None:
        pytest.skip("Blender's bpy module is not importable (.ci/run installs it)")
    truth = scene[2]
    readings = read_in_blender(python, [tracked[0] / "out.bvh"], tmp_path)
    assert_blender_reads_as_eigmotion(readings, lowest_m=float(truth[..., 1].min()))


def test_track_end_to_end(scene, tracked, capsys, tmp_path):
    root, paths, truth, *_ = scene
    work, out, _ = tracked
    bvh, joints, overlay = work / "out.bvh", work / "out.npz", work / "out.gif"
    assert "tracked 10 frames" in out
    data = np.load(joints)
    assert data["positions"].shape == (N_FRAMES, 31, 3)
    assert list(data["names"])[0] == "Hips"
    err_mm = 1000 * np.linalg.norm(data["positions"] - truth, axis=-1).mean()
    assert err_mm < 120, err_mm
    motion = read_bvh(bvh)
    assert motion.n_frames == N_FRAMES and motion.frame_time_s == pytest.approx(0.04)
    frames, _ = read_frames(overlay)
    assert frames.shape[1:3] == (240, 640)
    yellow = (frames[..., 0] > 200) & (frames[..., 1] > 180) & (frames[..., 2] < 80)
    assert yellow.sum(axis=(1, 2)).min() > 50  # the outline is drawn in every frame
    # the saved dictionary is reused, and a reference motion is replayed; the
    # direction-of-travel prior off, the body's height measured from the top
    code, out, err = run_cli(
        [
            "--calib", root / "cams.json", *paths, "--dictionary", work / "dict.npz",
            "--reference", "walk_02_01", "--bvh-out", tmp_path / "ref.bvh",
            "--joints-out", tmp_path / "ref.npz", "--no-travel-prior", "--scale-from-top",
        ],
        capsys,
    )  # fmt: skip
    assert code == 0, err
    replay = np.load(tmp_path / "ref.npz")["positions"]
    assert replay.shape == (N_FRAMES, 31, 3)
    assert 1000 * np.linalg.norm(replay - truth, axis=-1).mean() < 200


def test_no_keypoints_and_no_smoothing(scene, tracked, capsys, tmp_path):
    """Stored masks come without landmarks: the keypoints stage does not run, and
    ``--no-keypoints`` gives the same joints and motion.  The joints' paths are
    smoothed (the BVH's joints are ``--joints-out``'s); ``--joint-smooth-s 0`` gives
    the tracker's postures as they are, which move more from estimate to estimate."""
    root, paths, *_ = scene
    work, *_ = tracked
    common = ["--calib", root / "cams.json", *paths, "--dictionary", work / "dict.npz"]
    code, _, err = run_cli(
        [
            *common, "--no-keypoints", "--joints-out", tmp_path / "alone.npz",
            "--bvh-out", tmp_path / "alone.bvh",
        ],
        capsys,
    )  # fmt: skip
    assert code == 0, err
    smoothed = np.load(tmp_path / "alone.npz")["positions"]
    np.testing.assert_array_equal(smoothed, np.load(work / "out.npz")["positions"])
    assert (tmp_path / "alone.bvh").read_text() == (work / "out.bvh").read_text()
    replayed = forward_kinematics(read_bvh(work / "out.bvh"), ground=False).positions
    code, _, err = run_cli(
        [*common, "--joint-smooth-s", "0", "--joints-out", tmp_path / "raw.npz"], capsys
    )
    assert code == 0, err
    raw = np.load(tmp_path / "raw.npz")["positions"]

    def jitter(joints):
        return np.linalg.norm(np.diff(joints[1:], 2, axis=0), axis=-1).mean()

    assert jitter(smoothed) < 0.8 * jitter(raw), (jitter(smoothed), jitter(raw))
    # the BVH holds the smoothed postures: its joints are the smoothed ones but for the
    # first estimates, tracked before the body scale settled (the BVH is drawn at the
    # settled scale: a few millimetres off there)
    assert np.abs(replayed - smoothed).max() < 0.01 < np.abs(raw - smoothed).max()
    code, _, err = run_cli([*common, "--joint-smooth-s", "-1"], capsys)
    assert code == 2 and len(err) == 1 and "joint_smooth_s" in err[0], err


def test_track_from_video_with_background(scene, capsys, tmp_path):
    """RGB videos with a textured background, a shadow and noise, cut out against
    background images by subtraction (the person networks of the default front end do
    not take a flat-coloured body for a person)."""
    from eigmotion.synth.scene import compose_scene

    root, _, truth, vertices, subject, cams = scene
    rng = np.random.default_rng(0)
    videos, backgrounds = [], []
    for i, cam in enumerate(cams):
        masks = render_masks(vertices, subject.faces, cam)
        frames, background = compose_scene(None, masks, rng)
        videos.append(write_video(frames, tmp_path / f"cam{i}.avi", 25.0))
        backgrounds.append(tmp_path / f"bg{i}.png")
        cv2.imwrite(str(backgrounds[-1]), cv2.cvtColor(background, cv2.COLOR_RGB2BGR))
    code, out, err = run_cli(
        [
            "--calib", root / "cams.json", *videos, "--background", *backgrounds,
            "--segmenter", "subtraction", "--dictionary", "walk_02_01", "--heading-step-deg", "30",
            "--joints-out", tmp_path / "j.npz",
        ],
        capsys,
    )  # fmt: skip
    assert code == 0, err
    positions = np.load(tmp_path / "j.npz")["positions"]
    assert 1000 * np.linalg.norm(positions - truth, axis=-1).mean() < 150
