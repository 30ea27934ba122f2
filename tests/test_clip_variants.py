"""benchmarks/accuracy/bench_clip_variants.py: the development set's clips written again
as other cameras would give them, each copy readable by the query as it reads a user's."""

from __future__ import annotations

import importlib.util
import json
import shutil
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from eigmotion.evaluation.devset import load_dev_clips
from eigmotion.imaging.media import read_frames, sample_indices
from eigmotion.imaging.still_images import read_image_rgb

REPO = Path(__file__).resolve().parents[1]
SAMPLES = REPO / "database" / "samples"


def _bench():
    """The benchmark script as a module (registered first: its dataclass needs that)."""
    name = "bench_clip_variants"
    if name not in sys.modules:
        path = REPO / "benchmarks" / "accuracy" / f"{name}.py"
        spec = importlib.util.spec_from_file_location(name, path)
        sys.modules[name] = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(sys.modules[name])
    return sys.modules[name]


@pytest.fixture(scope="module")
def dev_set(tmp_path_factory):
    """A development set of one retrieval clip in the set's layout: the bundled 3 s walk
    (a body the database was not built with, 320 × 240, 30 frames/s) and its
    empty-scene image."""
    root = tmp_path_factory.mktemp("dev")
    clip = root / "retrieval" / "walk_3s"
    clip.mkdir(parents=True)
    shutil.copy(SAMPLES / "walk_3s.mp4", clip / "video.mp4")
    shutil.copy(SAMPLES / "walk_3s_background.png", clip / "background.png")
    (clip / "meta.json").write_text(json.dumps({"label": "walk", "fps": 30}))
    return root


@pytest.mark.parametrize(
    "name", ["hd", "x2", "far", "half", "wide", "tall", "fps60", "fps24", "shake", "dark", "jpeg"]
)
def test_each_copy_is_a_clip_of_the_size_and_rate_it_claims(dev_set, tmp_path, name):
    bench = _bench()
    (clip,) = load_dev_clips(dev_set, "retrieval")
    variant = bench.VARIANTS[name]
    copy = bench.write_copy(clip, variant, tmp_path, with_background=True)
    original, _ = read_frames(clip.video)
    frames, fps = read_frames(copy.video)
    meta = json.loads((copy.folder / "meta.json").read_text())
    assert meta["label"] == "walk" and meta["variant"] == name
    assert fps == pytest.approx(meta["fps"]) == pytest.approx(copy.fps)
    assert len(frames) == meta["frames"]
    h, w = original.shape[1:3]
    expected = {"hd": (4 * h, 4 * w), "x2": (2 * h, 2 * w), "far": (4 * h, 4 * w),
                "half": (h // 2, w // 2),
                "wide": (h, 2 * round((h * 16 / 9 - w) / 2) + w),
                "tall": (2 * round((w * 16 / 9 - h) / 2) + h, w)}.get(name, (h, w))  # fmt: skip
    assert frames.shape[1:3] == expected
    if name == "far":  # the twice-as-large clip in the middle, the edges around it
        middle = frames[0, h : 3 * h, w : 3 * w].astype(np.int16)
        large = cv2.resize(original[0], (2 * w, 2 * h), interpolation=cv2.INTER_CUBIC)
        assert np.abs(middle - large).mean() < 8  # (the copy is written as a video)
        assert (
            np.abs(
                frames[0, :h, w : 3 * w].astype(np.int16) - frames[0, h : h + 1, w : 3 * w]
            ).mean()
            < 8
        )
    if name == "fps60":  # each frame twice
        assert fps == pytest.approx(60.0) and len(frames) == 2 * len(original)
    if name == "fps24":  # the frames nearest to each 1/24 s
        assert fps == pytest.approx(24.0)
        assert len(frames) == len(sample_indices(len(original), 30.0, 24.0)) < len(original)
    if variant.background is None:  # a moving camera has no one image of the empty scene
        assert not (copy.folder / "background.png").exists()
    else:  # the query refuses an empty-scene image of another size than the frames
        assert read_image_rgb(copy.folder / "background.png").shape[:2] == frames.shape[1:3]


def test_the_shaking_camera_moves_and_the_dark_one_is_dark(dev_set, tmp_path):
    bench = _bench()
    (clip,) = load_dev_clips(dev_set, "retrieval")
    original, _ = read_frames(clip.video)
    shaken, _ = read_frames(bench.write_copy(clip, bench.VARIANTS["shake"], tmp_path, False).video)
    dark, _ = read_frames(
        bench.write_copy(clip, bench.VARIANTS["dark"], tmp_path / "d", False).video
    )
    # The scene's texture moves from frame to frame under the shaking camera only.
    still = np.abs(original[1:].astype(int) - original[:-1]).mean()
    moving = np.abs(shaken[1:].astype(int) - shaken[:-1]).mean()
    assert moving > 2 * still
    assert dark.mean() < 0.6 * original.mean()


def test_the_benchmark_answers_every_copy_and_prints_the_ratio(
    dev_set, four_motion_database, capsys
):
    bench = _bench()
    db = four_motion_database
    argv = ["--db", str(db), "--dev", str(dev_set), "--modes", "nobg", "bg"]
    code = bench.main([*argv, "--variants", "x2", "shake"])
    out = capsys.readouterr().out
    assert code == 0
    rows = {line.split("|")[1].strip(): line for line in out.splitlines() if line.startswith("| ")}
    assert set(rows) >= {"original", "x2", "shake"}
    assert rows["x2"].split("|")[3].strip() == "1.00×"  # the ratio to the original's
    assert "—" in rows["shake"]  # no empty-scene image under a moving camera: no bg mode
    for name in ("original", "x2"):
        cells = [c.strip() for c in rows[name].split("|")[2:-1]]
        assert cells[-1] == "0", f"{name}: a query raised"  # errors column
        assert cells[0] == cells[3] == "1/1", f"{name}: the walk is not answered walk"
