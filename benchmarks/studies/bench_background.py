"""Silhouettes without an image of the empty scene: the grabcut background against the median.

Library motions, some performed in place (waving, lifting, covering the head, picking
up, punching, sitting down, turning on the spot) and some travelling (walking,
running, jumping forwards), on the default avatar, filmed by one still camera
(azimuths ``--azimuths``, elevation 10°) over a textured background with a cast
shadow, camouflaged clothing and sensor noise (:func:`eigmotion.synth.clips.render_clip`,
320 × 240, 30 fps, scene seeds ``0 .. --seeds - 1``).  The person is in view from the
first frame to the last: there is never an empty frame.

Each clip is cut out as a query cuts it (:meth:`eigmotion.retrieval.database.MotionDatabase.
query_clip`): the frames the motion image samples (15 per second), segmented at the
query working size (longer side 160 px) by :func:`eigmotion.segmentation.video.extract_silhouettes`
with the background

* ``given`` — the image of the empty scene (the reference);
* ``median`` — estimated by the refined temporal median (the baseline);
* ``grabcut`` — estimated with the person's still body found by grabCut and replaced
  by the scene uncovered elsewhere in the clip, or inpainted.

The table gives, per clip, the intersection over union with the true masks (shrunk to
the working size; mean over the frames) and the seconds each estimate took for the
whole clip, then the means per kind of motion; "ratio" is grabcut's figure over the
median's.

Run from the repository root with the venv active::

    python benchmarks/studies/bench_background.py [--seeds 1] [--azimuths 30 100]
        [--motions wave_14_24,walk_02_01,...] [--clips-dir DIR]

With the defaults (12 motions, 2 views, 1 seed) it takes about 4 minutes on two
cores, most of it rendering; ``--clips-dir`` keeps the renders for the next run.
"""

from __future__ import annotations

import os

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

import argparse  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from eigmotion.evaluation.measures import iou, ratio  # noqa: E402
from eigmotion.imaging.media import sample_indices  # noqa: E402
from eigmotion.retrieval.database import QUERY_SILHOUETTE_SIDE_PX  # noqa: E402
from eigmotion.retrieval.motion_image import MotionImageConfig  # noqa: E402
from eigmotion.segmentation.config import SilhouetteConfig  # noqa: E402
from eigmotion.segmentation.video import extract_silhouettes  # noqa: E402

IN_PLACE = (
    "wave_14_24",
    "wave_both_hands",
    "pick_up_heavy_box_to_chest",
    "cover_head_standing",
    "pick_up_02_06_a",
    "punch_02_05",
    "sit_down_14_27",
    "turn_in_place_90",
)
TRAVELLING = ("walk_02_01", "run_09_01", "jump_forward_standing", "turn_walking_180")

#: (column, background given?, SilhouetteConfig.background); "median" is the baseline.
METHODS = (("given", True, "median"), ("median", False, "median"), ("grabcut", False, "grabcut"))

WIDTH_PX, HEIGHT_PX, CLIP_FPS, ELEVATION_DEG = 320, 240, 30.0, 10.0


def render(name: str, azimuth_deg: float, seed: int, clips_dir: Path | None, avatar):
    """(frames, background, true masks) of one clip, from ``clips_dir`` when stored."""
    from eigmotion.mocap.library import find_motion
    from eigmotion.synth.clips import render_clip

    path = None if clips_dir is None else clips_dir / f"{name}_az{azimuth_deg:g}_s{seed}.npz"
    if path is not None and path.is_file():
        with np.load(path) as data:
            return data["frames"], data["background"], data["true_masks"]
    clip = render_clip(
        find_motion(name),
        avatar,
        azimuth_deg,
        ELEVATION_DEG,
        np.random.default_rng(seed),
        width=WIDTH_PX,
        height=HEIGHT_PX,
        fps=CLIP_FPS,
    )
    if path is not None:
        np.savez_compressed(
            path, frames=clip.frames, background=clip.background, true_masks=clip.true_masks
        )
    return clip.frames, clip.background, clip.true_masks


def warm_up() -> None:
    """Compile the silhouette stages once, so that no clip's time includes it."""
    from eigmotion.synth.scene import compose_scene, stick_figure_masks

    frames, _ = compose_scene(None, stick_figure_masks(8, 120, 160), np.random.default_rng(0))
    for _, _, method in METHODS:
        extract_silhouettes(frames, None, SilhouetteConfig(background=method))


def shrunk_truth(truth: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """True masks (F, H, W) averaged over whole blocks down to ``shape`` (rows, cols),
    as :func:`eigmotion.segmentation.video.extract_silhouettes` shrinks the frames;
    >= half: person."""
    rows, cols = shape
    factor = truth.shape[1] // rows
    blocks = truth[:, : rows * factor, : cols * factor].reshape(-1, rows, factor, cols, factor)
    return blocks.mean(axis=(2, 4)) >= 0.5


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, default=1, help="scenes per view (1)")
    parser.add_argument(
        "--azimuths", type=float, nargs="+", default=[30.0, 100.0], help="views, ° (30 100)"
    )
    parser.add_argument(
        "--motions",
        default=",".join(IN_PLACE + TRAVELLING),
        help="comma-separated library motions (default: the in-place and travelling sets)",
    )
    parser.add_argument("--clips-dir", type=Path, help="keep the rendered clips here")
    args = parser.parse_args(argv)
    if args.clips_dir is not None:
        args.clips_dir.mkdir(parents=True, exist_ok=True)

    from eigmotion.body.avatar import load_default_avatar

    avatar = load_default_avatar()
    sample_fps = MotionImageConfig().sample_fps
    warm_up()
    rows = []
    print(
        f"{'motion':<24} {'kind':<10} {'az':>4} {'seed':>4} {'frames':>6}  "
        + "  ".join(f"{name + ' IoU':>12}" for name, _, _ in METHODS)
        + f"  {'ratio':>5}  {'median s':>8} {'grabcut s':>9} {'ratio':>5}"
    )
    for name in [m.strip() for m in args.motions.split(",") if m.strip()]:
        kind = "travelling" if name in TRAVELLING else "in place"
        for azimuth in args.azimuths:
            for seed in range(args.seeds):
                frames, background, truth = render(name, azimuth, seed, args.clips_dir, avatar)
                taken = sample_indices(len(frames), CLIP_FPS, sample_fps)
                frames, truth = frames[taken], truth[taken]
                scores, seconds = {}, {}
                for column, given, method in METHODS:
                    config = SilhouetteConfig(
                        background=method, work_max_side_px=QUERY_SILHOUETTE_SIDE_PX
                    )
                    t0 = time.perf_counter()
                    masks = extract_silhouettes(frames, background if given else None, config)
                    seconds[column] = time.perf_counter() - t0
                    scores[column] = iou(masks, shrunk_truth(truth, masks.shape[1:]))
                rows.append((kind, scores, seconds))
                print(
                    f"{name:<24} {kind:<10} {azimuth:>4g} {seed:>4} {len(frames):>6}  "
                    + "  ".join(f"{scores[column]:>12.3f}" for column, _, _ in METHODS)
                    + f"  {ratio(scores['grabcut'], scores['median']):>5.2f}"
                    + f"  {seconds['median']:>8.3f} {seconds['grabcut']:>9.3f}"
                    + f" {ratio(seconds['grabcut'], seconds['median']):>5.2f}",
                    flush=True,
                )

    print("\nmean per kind (clips): IoU given / median / grabcut (ratio); s per clip (ratio)")
    for kind in ("in place", "travelling"):
        chosen = [(s, t) for k, s, t in rows if k == kind]
        if not chosen:
            continue
        mean = {c: np.mean([s[c] for s, _ in chosen]) for c, _, _ in METHODS}
        time_of = {c: np.mean([t[c] for _, t in chosen]) for c, _, _ in METHODS}
        print(
            f"{kind:<10} ({len(chosen):>2})  IoU {mean['given']:.3f} / {mean['median']:.3f} / "
            f"{mean['grabcut']:.3f} ({ratio(mean['grabcut'], mean['median']):.2f})   "
            f"s {time_of['median']:.3f} / {time_of['grabcut']:.3f} "
            f"({ratio(time_of['grabcut'], time_of['median']):.2f})"
        )


if __name__ == "__main__":
    main()
