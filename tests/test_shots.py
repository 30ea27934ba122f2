"""Edited clips and moving cameras: cuts between shots found, each shot's scene its own,
and a clip whose camera pans answered instead of refused."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest

from eigmotion.cli.main import main
from eigmotion.errors import InvalidParameterError, SceneMismatchError
from eigmotion.imaging.media import read_frames, write_video
from eigmotion.retrieval.database import MotionDatabase
from eigmotion.retrieval.motion_cues import floor_cues
from eigmotion.retrieval.query_windows import snapped_to_cuts
from eigmotion.retrieval.results import Segment, shots_warning
from eigmotion.segmentation.config import SilhouetteConfig
from eigmotion.segmentation.evidence import MAX_SCENE_DIFFERENCE
from eigmotion.segmentation.fused import without_seen_scene
from eigmotion.segmentation.shots import content_changes, shot_spans, shot_starts
from eigmotion.segmentation.subtraction import frame_chunks, subtract_scene
from eigmotion.segmentation.video import load_clip_masks

REPO = Path(__file__).resolve().parents[1]
SAMPLES = REPO / "database" / "samples"
QUERY_CONFIG = SilhouetteConfig(work_max_side_px=160)


def _sample(name: str, step: int = 2) -> tuple[np.ndarray, float]:
    """Every ``step``-th frame of a bundled sample, RGB, and the rate they are at."""
    frames, fps = read_frames(SAMPLES / name)
    return frames[::step], fps / step


def _panned(frames: np.ndarray, share: float = 0.6) -> np.ndarray:
    """The frames as a camera that pans to and fro and zooms in by 1 / ``share`` sees them."""
    n, h, w = frames.shape[:3]
    ch, cw = int(h * share), int(w * share)
    out = np.empty_like(frames)
    for i, frame in enumerate(frames):
        x = int((w - cw) * (0.5 + 0.5 * np.sin(2 * np.pi * i / n)))
        y = (h - ch) // 2
        out[i] = cv2.resize(frame[y : y + ch, x : x + cw], (w, h), interpolation=cv2.INTER_LINEAR)
    return out


def test_cuts_between_the_samples_are_found_and_nothing_else():
    """Three samples, each rendered in its own scene, joined as an editor joins clips:
    the two cuts are found where they are.  No sample alone, and no panning camera,
    has one: their frames change a little every frame, a cut a lot in one."""
    walk, _ = _sample("walk.mp4")
    kick, _ = _sample("kick.mp4")
    walk_3s, _ = _sample("walk_3s.mp4")
    joined = np.concatenate([walk, kick, walk_3s])
    np.testing.assert_array_equal(shot_starts(joined), [0, len(walk), len(walk) + len(kick)])
    for frames in (walk, kick, walk_3s, _panned(kick), _panned(walk_3s)):
        np.testing.assert_array_equal(shot_starts(frames), [0])
    changes = content_changes(joined)
    assert changes.shape == (len(joined) - 1,)
    assert changes[len(walk) - 1] > 5 * np.median(changes)
    # too few frames to compare a change with its neighbours': one shot
    np.testing.assert_array_equal(shot_starts(joined[len(walk) - 1 : len(walk) + 1]), [0])
    assert shot_spans(np.array([0, 4, 9]), 12) == [(0, 4), (4, 9), (9, 12)]
    assert shot_spans(None, 12) == [(0, 12)]
    with pytest.raises(InvalidParameterError, match="uint8"):
        shot_starts(joined.astype(np.float32))


def _scene_with_stool(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A person walking past a stool the networks take for part of them in the last
    four of 16 frames: (frames, the person's masks, the learned masks)."""
    rng = np.random.default_rng(seed)
    scene = rng.integers(60, 200, size=(120, 160, 3), dtype=np.uint8)
    scene[80:110, 95:125] = (200, 200, 210)  # the stool
    n = 16
    frames = np.repeat(scene[None], n, axis=0)
    person = np.zeros((n, 120, 160), bool)
    for i in range(n):
        x = 5 + 4 * i  # left of the stool
        person[i, 30:110, x : x + 22] = True
    frames[person] = (180, 40, 40)
    frames = np.clip(frames + rng.normal(0, 2, frames.shape), 0, 255).astype(np.uint8)
    learned = person.copy()
    learned[12:, 80:110, 95:125] = True
    return frames, person, learned


def test_each_shot_is_compared_with_its_own_scene():
    """Two shots of two scenes, each with a stool the networks take for the person: per
    shot, each stool is taken out; compared with one scene made of both, the frames
    differ from it over most of the picture and nothing is taken out."""
    config = SilhouetteConfig()
    first, person_a, learned_a = _scene_with_stool(0)
    second, person_b, learned_b = _scene_with_stool(1)
    frames = np.concatenate([first, second])
    person = np.concatenate([person_a, person_b])
    learned_masks = np.concatenate([learned_a, learned_b])
    starts = shot_starts(frames)
    np.testing.assert_array_equal(starts, [0, 16])
    out = without_seen_scene(learned_masks, frames, config, starts)
    for stop in (16, 32):
        assert not out[stop - 4 : stop, 84:110, 100:125].any()
    assert (out & person).sum() == person.sum()
    # one scene for both: the subtraction cannot tell the person from it
    with pytest.raises(SceneMismatchError, match="differ from the empty scene"):
        subtract_scene(frame_chunks(second), first[0], config)
    np.testing.assert_array_equal(without_seen_scene(learned_masks, frames, config), learned_masks)


def test_a_panning_camera_is_cut_out_by_the_networks(tmp_path):
    """The kick sample as a camera that pans and zooms sees it: without an image of the
    empty scene the clip shows no steady scene, and the networks' masks stand (the
    scene rule used to refuse the clip); with the classical subtraction, which must
    estimate one, it is refused in one line that names the learned segmenter."""
    frames, fps = read_frames(SAMPLES / "kick.mp4")
    clip = write_video(_panned(frames), tmp_path / "panned.mp4", fps)
    cut = load_clip_masks(clip, None, QUERY_CONFIG, 15.0, segmenter="learned")
    assert cut.masks.any(axis=(1, 2)).mean() >= 0.9
    np.testing.assert_array_equal(cut.shot_starts, [0])
    with pytest.raises(SceneMismatchError, match="no one steady scene.*learned segmenter") as e:
        load_clip_masks(clip, None, QUERY_CONFIG, 15.0, segmenter="subtraction")
    difference = e.value.difference
    assert difference > MAX_SCENE_DIFFERENCE and f"{difference:.0f} ΔE" in str(e.value)


def test_a_panning_camera_does_not_make_the_person_travel(four_motion_database, tmp_path):
    """The walk samples as a camera that pans to and fro, zoomed in by 1.25, sees them:
    the person's speed over the floor, read in the first frame's pixels (the camera's
    motion measured on the scene), is the one the still camera gives; read as the
    frames show it, it is not.  The walk away from the camera does not bend, unless
    the pan is taken for the person's travel.  (The sideways walk's bend is not
    compared: the narrower view cuts the figure in other frames.)"""
    for name in ("walk.mp4", "walk_3s.mp4"):
        frames, fps = read_frames(SAMPLES / name)
        clip = write_video(_panned(frames, 0.8), tmp_path / name, fps)
        still = load_clip_masks(SAMPLES / name, None, QUERY_CONFIG, 15.0, segmenter="learned")
        panned = load_clip_masks(clip, None, QUERY_CONFIG, 15.0, segmenter="learned")
        assert still.camera is None and panned.camera is not None
        unmeasured = replace(QUERY_CONFIG, measure_camera=False)
        same = load_clip_masks(clip, None, unmeasured, 15.0, segmenter="learned")
        assert same.camera is None and np.array_equal(same.masks, panned.masks)
        speed, turned = floor_cues(still.masks, still.fps)
        followed = floor_cues(panned.masks, panned.fps, panned.camera)
        as_seen = floor_cues(panned.masks, panned.fps)
        assert followed[0] == pytest.approx(speed, abs=0.03)
        assert abs(as_seen[0] - speed) > 0.04
    assert turned < 3.0 and followed[1] < 3.0 and as_seen[1] > 20.0
    with MotionDatabase.open(four_motion_database) as db:
        with pytest.raises(InvalidParameterError, match="camera must be finite, shape"):
            db.query_masks(panned.masks, panned.fps, camera=panned.camera[1:])
        # the answer reads the motion of the frames it samples; every frame's cut skips it
        result, every = db.query_clip(clip, every_frame=True)
        assert every.camera is None and len(every.masks) == every.n_frames
        assert result.travel_speed == pytest.approx(followed[0])


def test_the_query_of_an_edited_clip_names_its_cuts(four_motion_database, tmp_path, capsys):
    """The walk and kick samples joined: answered, with a warning naming the clip frame
    of the cut, by either front end; each shot's person is found in nine frames of ten
    or more (the outlier rule compares a frame with its own shot's person: the kick's
    performer, nearer the camera, covers four times the walker's area, and in one
    clip's median would be dropped as scene taken for the person)."""
    walk, fps = read_frames(SAMPLES / "walk.mp4")
    kick, _ = read_frames(SAMPLES / "kick.mp4")
    clip = write_video(np.concatenate([walk, kick]), tmp_path / "edited.mp4", fps)
    cut = load_clip_masks(clip, None, QUERY_CONFIG, 15.0, segmenter="learned")
    assert len(cut.shot_starts) == 2
    assert cut.frame_indices[cut.shot_starts[1]] in (len(walk), len(walk) + 1)
    found = cut.masks.any(axis=(1, 2))
    assert found[: cut.shot_starts[1]].mean() >= 0.9 and found[cut.shot_starts[1] :].mean() >= 0.9
    for segmenter in ("learned", "subtraction"):
        argv = ["query", str(clip), "--db", str(four_motion_database), "--segmenter", segmenter]
        assert main([*argv, "--json"]) == 0
        answer = json.loads(capsys.readouterr().out)
        cuts = [w for w in answer["warnings"] if w.startswith("the clip cuts to another view")]
        assert len(cuts) == 1 and "once (at clip frames " in cuts[0], answer["warnings"]
        cut = int(cuts[0].split("at clip frames ")[1].split(")")[0])
        assert cut in (len(walk), len(walk) + 1)
        # the walk, then the kick, parted at the cut
        parts = [(s["label"], s["start_frame"], s["end_frame"]) for s in answer["segments"]]
        assert parts == [("walk", 0, cut), ("kick", cut, len(walk) + len(kick))], parts
    assert main(argv) == 0
    assert "  warning: the clip cuts to another view once" in capsys.readouterr().out
    assert (
        main(["query", str(SAMPLES / "walk.mp4"), "--db", str(four_motion_database), "--json"]) == 0
    )
    assert json.loads(capsys.readouterr().out)["warnings"] == []


def test_shots_warning_counts_the_cuts():
    assert shots_warning(None, np.arange(10)) is None
    assert shots_warning(np.array([0]), np.arange(10)) is None
    warning = shots_warning(np.array([0, 3, 5, 7, 8]), 2 * np.arange(10))
    assert warning.startswith("the clip cuts to another view 4 times (at clip frames 6, 10, 14")
    assert "and 1 more)" in warning


def test_a_change_of_label_near_a_cut_moves_onto_it():
    walk, kick = Segment(0, 30, "walk", 0.1), Segment(30, 60, "kick", 0.2)
    wave = Segment(60, 90, "wave", 0.3)
    moved = snapped_to_cuts([walk, kick, wave], [38, 55], reach=10)
    assert [(s.start_frame, s.end_frame) for s in moved] == [(0, 38), (38, 55), (55, 90)]
    assert [s.label for s in moved] == ["walk", "kick", "wave"]
    # out of reach, or no cut: unchanged
    assert snapped_to_cuts([walk, kick, wave], [45], reach=10) == [walk, kick, wave]
    assert snapped_to_cuts([walk, kick], [], reach=10) == [walk, kick]
    # the same label on both sides: no boundary to move
    same = [walk, Segment(30, 60, "walk", 0.2)]
    assert snapped_to_cuts(same, [35], reach=10) == same
