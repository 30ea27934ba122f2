"""``eigmotion eval recognition``: the development set's loader, scores and command.

The scores are checked on answers made up here; the loader and the command end to end
on a tiny folder laid out like the development set, written by the test (clips rendered
from library motions on another body), against a small real database.
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
from eigmotion.evaluation.devset import (
    ERROR_LABEL,
    ClipAnswer,
    find_dev_set,
    load_dev_clips,
    silhouette_iou,
    true_masks_at,
)
from eigmotion.evaluation.devset_report import (
    format_mode,
    format_overview,
    summarise,
    top_confusions,
)
from eigmotion.imaging.media import write_video
from eigmotion.imaging.silhouettes import render_masks
from eigmotion.mocap.library import load_library
from eigmotion.synth.clips import clip_camera
from eigmotion.synth.scene import compose_scene


def _answer(clip_id, truth, labels, accepted=True, p_known=0.5, query_s=0.1, **kw):
    return ClipAnswer(
        clip_id, "bg", truth, labels[0], tuple(labels), accepted, p_known, 0.2, query_s, **kw
    )


def _error(clip_id, truth, message="no person found"):
    return ClipAnswer(
        clip_id, "bg", truth, ERROR_LABEL, (ERROR_LABEL,), True, None, None, 0.3, error=message
    )


def test_scores_count_top1_top3_errors_unknown_and_iou():
    answers = [
        _answer("walk_a", "walk", ["walk", "run"], iou=0.8, iou_frames=10),
        _answer("walk_b", "walk", ["run", "turn", "walk"], iou=0.6, iou_frames=10),
        _answer("walk_c", "walk", ["run", "turn", "jump", "walk"], iou=0.7, iou_frames=8),
        _answer("wave_a", "wave", ["punch", "wave"], query_s=0.5, iou=0.9, iou_frames=9),
        _error("wave_b", "wave"),
        _answer("jack_a", "unknown", ["jump"], accepted=False, p_known=0.01),
        _answer("jack_b", "unknown", ["wave"], accepted=True, p_known=0.2),
        _error("jack_c", "unknown"),
    ]
    summary = summarise("bg", answers)
    s = summary.score
    assert (s.n, s.top1, s.topk) == (5, 1, 3)  # in-library clips only; top-3 of distinct labels
    per = {p.label: p for p in s.per_label}
    assert (per["walk"].n, per["walk"].top1, per["walk"].topk) == (3, 1, 2)
    assert (per["wave"].n, per["wave"].top1, per["wave"].topk) == (2, 0, 1)
    assert not per["unknown"].in_library
    # an error is wrong, not a rejection, and listed with its message
    assert summary.errors == (("wave_b", "no person found"), ("jack_c", "no person found"))
    assert summary.unknown_rejected == 1 and len(summary.unknown) == 3
    assert s.confusion.count("wave", ERROR_LABEL) == 1
    assert s.confusion.count("walk", "run") == 2
    assert top_confusions(summary)[0] == ("walk", "run", 2)
    assert ("unknown", "jump", 1) not in top_confusions(summary)
    assert summary.median_s == pytest.approx(0.1)
    assert summary.p90_s == pytest.approx(np.percentile([0.1] * 5 + [0.5, 0.3, 0.3], 90))
    assert summary.iou_per_label["walk"] == (pytest.approx(0.7), 3)
    assert summary.iou_per_label["wave"] == (pytest.approx(0.9), 1)
    assert summary.iou == pytest.approx(np.mean([0.8, 0.6, 0.7, 0.9]))
    text = format_mode(summary)
    assert "top-1 1/5 (20.0%" in text and "top-3 3/5 (60.0%" in text
    assert "1/3 answered accepted: false" in text and "jack_a 0.010 (rejected)" in text
    assert "- wave_b: no person found" in text
    assert "walk → run 2" in text
    assert "| all   | 4     | 0.750 |" in text
    overview = format_overview([summary])
    assert "| bg   | 1/5 (20.0%) | 3/5 (60.0%) | 0.750 |" in overview
    data = json.loads(json.dumps(summary.to_json()))
    assert data["top1"] == 1 and data["unknown"]["rejected"] == 1
    assert data["errors"][0] == {"id": "wave_b", "error": "no person found"}
    assert data["iou_per_label"]["wave"]["n"] == 1
    # where the true label stands (the unknown clips left out; an error: not ranked)
    assert summary.ranks == {"1": 1, "2": 1, "3": 1, "lower": 1, "not ranked": 1}
    assert data["truth_ranks"] == summary.ranks
    assert "true label ranked (of the in-library clips): 1 1, 2 1, 3 1, lower 1, " in text
    assert [a.truth_rank for a in answers[:5]] == [1, 3, 4, 2, None]
    assert answers[2].to_json()["truth_rank"] == 4
    with pytest.raises(InvalidParameterError):
        summarise("bg", [])


def test_true_masks_are_compared_at_the_silhouettes_size_and_frames():
    truth = np.zeros((5, 240, 320), bool)
    truth[:, 40:200, 100:140] = True
    truth[:, 201, 0] = True  # a quarter of a block: out at half the size
    picked = true_masks_at(truth, np.array([0, 2, 4]), (120, 160))
    assert picked.shape == (3, 120, 160)
    assert picked[:, 20:100, 50:70].all() and picked.sum() == 3 * 80 * 20
    score, n = silhouette_iou(picked, np.array([0, 2, 4]), truth)
    assert (score, n) == (1.0, 3)
    half = picked.copy()
    half[:, :, 60:] = False
    assert silhouette_iou(half, np.array([0, 2, 4]), truth)[0] == pytest.approx(0.5)
    # a size that is no whole factor: area resize
    assert true_masks_at(truth, np.array([1]), (100, 133)).shape == (1, 100, 133)


def test_finding_the_dev_set(tmp_path, monkeypatch):
    with pytest.raises(InvalidParameterError, match="pass --dev"):
        find_dev_set(tmp_path / "nope")
    with pytest.raises(InvalidParameterError, match="not a development set"):
        find_dev_set(tmp_path)
    monkeypatch.chdir(tmp_path)
    with pytest.raises(InvalidParameterError, match="pass --dev"):
        find_dev_set(None)
    dev = tmp_path.parent / "shared" / "eval" / "dev"
    (dev / "real").mkdir(parents=True)
    assert find_dev_set(None).resolve() == dev.resolve()


# -- end to end ----------------------------------------------------------------------


def _write_clip(folder: Path, label: str, motion, body, azimuth_deg, rng, size, fps=30.0):
    """A clip in the development set's layout: video, empty scene, masks, meta."""
    folder.mkdir(parents=True)
    _, vertices = animate_avatar(body, motion.resample(fps))
    vertices = vertices[: int(2.5 * fps)]
    camera = clip_camera(vertices, azimuth_deg, 8.0, *size)
    masks = render_masks(vertices, body.faces, camera)
    frames, background = compose_scene(None, masks, rng)
    write_video(frames, folder / "video.mp4", fps)
    cv2.imwrite(str(folder / "background.png"), cv2.cvtColor(background, cv2.COLOR_RGB2BGR))
    np.savez_compressed(folder / "masks.npz", masks=masks)
    (folder / "meta.json").write_text(json.dumps({"label": label, "fps": fps}))


@pytest.fixture(scope="module")
def dev_set(tmp_path_factory):
    """Two retrieval clips (walk, wave) and two real ones (a wave, an unknown kick),
    rendered on a body the database was not built with."""
    by_name = {m.name: m for m in load_library()}
    body = load_default_avatar().with_shape(height_m=1.62, girth=1.15).decimated(4000)
    rng = np.random.default_rng(3)
    dev = tmp_path_factory.mktemp("devset") / "dev"
    walk, wave, kick = by_name["walk_02_01"], by_name["wave_14_24"], by_name["kick_135_04"]
    _write_clip(dev / "retrieval" / "walk_t_v0", "walk", walk.motion, body, 40, rng, (320, 240))
    _write_clip(dev / "retrieval" / "wave_t_v0", "wave", wave.motion, body, 320, rng, (320, 240))
    _write_clip(dev / "real" / "wave-real", "wave", wave.motion, body, 0, rng, (64, 64), 25.0)
    _write_clip(dev / "real" / "kick-real", "unknown", kick.motion, body, 90, rng, (64, 64))
    for real in (dev / "real").iterdir():
        (real / "masks.npz").unlink()
        (real / "background.png").unlink()
    return dev


@pytest.fixture(scope="module")
def db_path(four_motion_database):
    return four_motion_database


def test_loader_reads_labels_and_rates(dev_set):
    clips = load_dev_clips(dev_set, "retrieval")
    assert [c.clip_id for c in clips] == ["walk_t_v0", "wave_t_v0"]
    assert clips[0].label == "walk" and clips[0].fps == 30.0
    assert clips[0].true_masks().shape == (75, 240, 320)
    real = load_dev_clips(dev_set, "real", only=["wave"])
    assert [(c.clip_id, c.label, c.fps) for c in real] == [("wave-real", "wave", 25.0)]
    with pytest.raises(InvalidParameterError):
        load_dev_clips(dev_set, "tracking")


def test_eval_recognition_answers_as_query_does(dev_set, db_path, tmp_path, capsys):
    out = tmp_path / "dev.json"
    args = ["eval", "recognition", "--dev", str(dev_set), "--db", str(db_path)]
    assert main([*args, "--json-out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "## bg:" in printed and "## real:" in printed and "## all modes" in printed
    report = json.loads(out.read_text())
    assert list(report["modes"]) == ["bg", "nobg", "masks", "masks_small", "real"]
    for mode, part in report["modes"].items():
        assert part["summary"]["n_queries"] == 2
        for answer in part["clips"]:
            assert answer["mode"] == mode and answer["query_s"] > 0
            assert (answer["iou"] is not None) == (mode in ("bg", "nobg"))
    assert report["modes"]["bg"]["summary"]["iou"] > 0.5
    assert report["modes"]["real"]["summary"]["unknown"]["n"] == 1
    # every answer is the one ``eigmotion query CLIP --json`` gives
    for mode, part in report["modes"].items():
        for answer in part["clips"]:
            folder = dev_set / ("real" if mode == "real" else "retrieval") / answer["id"]
            clip = folder / "video.mp4"
            extra = ["--background", str(folder / "background.png")] if mode == "bg" else []
            if mode in ("masks", "masks_small"):
                clip = tmp_path / f"{answer['id']}.npz"
                masks = np.load(folder / "masks.npz")["masks"]
                if mode == "masks_small":  # 320 × 240 → 160 × 120: a pixel from 2 × 2
                    masks = masks.reshape(len(masks), 120, 2, 160, 2).mean(axis=(2, 4)) >= 0.5
                np.savez_compressed(clip, masks=masks, fps=np.float64(30.0))
            rc = main(["query", str(clip), "--db", str(db_path), "--json", *extra])
            if answer["error"] is not None:
                assert rc == 2 and answer["error"] in capsys.readouterr().err
                continue
            assert rc == 0
            single = json.loads(capsys.readouterr().out)
            assert answer["label"] == single["label"]
            assert answer["labels"] == [m["label"] for m in single["labels"]]
            assert answer["accepted"] == single["accepted"]
            assert answer["p_known"] == single["p_known"]
    # --only and --modes
    assert main([*args, "--modes", "masks", "--only", "walk"]) == 0
    printed = capsys.readouterr().out
    assert "## masks:" in printed and "## bg:" not in printed and "walk" in printed
    assert "| masks | " in printed and "/1 (" in printed


def test_eval_recognition_bad_input_is_one_line(dev_set, db_path, tmp_path, capsys):
    assert main(["eval", "recognition", "--dev", str(tmp_path / "nope")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "pass --dev" in err
    assert main(["eval", "recognition", "--dev", str(dev_set), "--db", str(tmp_path / "x.fs")]) == 2
    assert "no such database file" in capsys.readouterr().err
    args = ["eval", "recognition", "--dev", str(dev_set), "--db", str(db_path)]
    assert main([*args, "--only", "nothing-like-this"]) == 2
    assert "no clips" in capsys.readouterr().err
