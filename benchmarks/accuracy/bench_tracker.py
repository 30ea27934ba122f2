"""Benchmark of the silhouette-dictionary tracker: accuracy and speed, tree vs exhaustive.

Setup (as in the paper): a walkway along +X with two cameras on both sides of it,
320 × 240 pixels; the person is a body shape unlike the dictionary's (another height
and girth); the motions are CMU walks and a turn that the dictionary was NOT built
from.  The dictionary holds the library clips ``walk_02_01``, ``walk_16_15`` and
``turn_16_17``, pruned at d1 = 5°, each posture turned to every 15° of heading.

For every clip, the same silhouettes are tracked twice, with the 2-layer search tree
(t = 3, k = 3, T_n = 40) and with the exhaustive search over the same candidates, and
the script prints: MPJPE (mm, over the 25 body joints: fingers and thumbs left out;
world positions, so the body-centre position error counts), estimates per second on
one core (``est/s`` from the process's CPU time, ``wall`` from the clock: they differ
when other work shares the machine; the first frame's coarse-to-fine search apart),
similarity evaluations per frame, and how many frames triggered a recovery search;
then the tree's estimates with the joints' paths smoothed over time, as ``eigmotion
track`` ends (:func:`eigmotion.tracking.pipeline.fitted_poses`).
``--video`` runs the video front end too: the silhouettes are cut out of composed RGB
frames (textured background, cast shadow, sensor noise) against background images,
instead of taken from the renderer.

Run from the repository root::

    python benchmarks/accuracy/bench_tracker.py            # clean silhouettes
    python benchmarks/accuracy/bench_tracker.py --video    # through background subtraction
    python benchmarks/accuracy/bench_tracker.py --body-scale 1 --no-recovery   # the paper's tracker
    python benchmarks/accuracy/bench_tracker.py --front --garment long_coat    # front/back
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ[_var] = "1"  # one core, before numpy / numba load

import argparse  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from eigmotion.body.avatar import load_default_avatar  # noqa: E402
from eigmotion.body.retarget import retarget  # noqa: E402
from eigmotion.imaging.cameras import intrinsics, look_at  # noqa: E402
from eigmotion.imaging.silhouettes import render_masks  # noqa: E402
from eigmotion.mocap.library import find_motion  # noqa: E402
from eigmotion.tracking.body import avatar_bodies  # noqa: E402
from eigmotion.tracking.dictionary import dictionary_from_sequences, posture_sequence  # noqa: E402
from eigmotion.tracking.pipeline import fitted_poses  # noqa: E402
from eigmotion.tracking.postures import mean_heading_deg, yaw_rotation  # noqa: E402
from eigmotion.tracking.tracker import SilhouetteTracker, TrackerConfig  # noqa: E402

DICTIONARY_MOTIONS = ("walk_02_01", "walk_16_15", "turn_16_17")
#: (library motion, heading at the start in degrees): walking along the walkway (+X).
TEST_CLIPS = (("walk_02_02", 90.0), ("walk_16_22", 90.0), ("turn_16_19", 90.0))
SUBJECT = {"height_m": 1.58, "girth": 1.2}
WIDTH, HEIGHT, YFOV_DEG = 320, 240, 45.0
ESTIMATE_FPS = 25.0


def walkway_cameras(front: bool = False) -> list:
    """Both sides of the walkway, or (``front``) 1.5 m high at ±60° from the walking
    direction (+X), both ahead of the person, 6 m from the path's centre."""
    K = intrinsics(WIDTH, HEIGHT, YFOV_DEG)
    if front:
        target = np.array([0.6, 0.9, 0.0])
        a = np.deg2rad(60.0)
        return [
            look_at(target + [6 * np.cos(a), 0.6, side * 6 * np.sin(a)], target, K, WIDTH,
                    HEIGHT, name=name)
            for name, side in (("left_front", -1.0), ("right_front", 1.0))
        ]  # fmt: skip
    return [
        look_at([-2.5, 1.6, -3.5], [0.6, 0.9, 0.0], K, WIDTH, HEIGHT, name="left"),
        look_at([-2.5, 1.6, 3.5], [0.6, 0.9, 0.0], K, WIDTH, HEIGHT, name="right"),
    ]


def stage(name: str, heading_deg: float, subject) -> tuple[np.ndarray, np.ndarray]:
    """The clip at 25 fps on the subject, turned so that it starts walking at
    ``heading_deg`` and starting at x = -0.6 m on the walkway's centre line.

    Returns world rotations (F, J, 3, 3) and joint positions (F, J, 3), metres."""
    motion = find_motion(name).resample(ESTIMATE_FPS)
    anim = retarget(motion, subject)
    start = mean_heading_deg(anim.joint_rotations[: max(3, anim.n_frames // 6), 0])
    turn = yaw_rotation(heading_deg - start)
    rot = turn @ anim.joint_rotations
    pos = anim.joint_positions @ turn.T
    pos[..., [0, 2]] += np.array([-0.6, 0.0]) - pos[0, 0, [0, 2]]
    return rot, pos


def video_frames(masks: np.ndarray, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Masks → RGB frames over a textured background, with shadow and noise; and the
    empty background."""
    from eigmotion.synth.scene import compose_scene

    return compose_scene(None, masks, np.random.default_rng(seed))


def cut_out(frames: np.ndarray, background: np.ndarray) -> np.ndarray:
    """Silhouettes by background subtraction
    (:func:`eigmotion.segmentation.video.extract_silhouettes`)."""
    from eigmotion.segmentation.video import extract_silhouettes

    return extract_silhouettes(frames, background)


def save_figure(path: str, tracker: SilhouetteTracker, result, views: list, clip: str) -> None:
    """Six estimates drawn as outlines over both views (cf. the paper's figure 6),
    each view cropped around the person."""
    import cv2

    from eigmotion.imaging.figures import contact_sheet, save_image
    from eigmotion.tracking.overlay import draw_outline

    frames = np.linspace(0, result.n_estimates - 1, 6).round().astype(int)
    panels, labels = [], []
    for f in frames:
        est = result.estimates[f]
        drawn = []
        for c, view in enumerate(views):
            shape = tracker.silhouette(est, c)
            image = draw_outline(view[f], shape)
            rows, cols = np.flatnonzero(shape.any(1)), np.flatnonzero(shape.any(0))
            y0, y1 = max(rows[0] - 20, 0), min(rows[-1] + 21, image.shape[0])
            x0, x1 = max(cols[0] - 30, 0), min(cols[-1] + 31, image.shape[1])
            crop = image[y0:y1, x0:x1]
            size = (round(crop.shape[1] * 300 / crop.shape[0]), 300)
            drawn.append(cv2.resize(crop, size, interpolation=cv2.INTER_NEAREST))
        panels.append(np.concatenate(drawn, axis=1))
        labels.append(f"{clip} t={f / ESTIMATE_FPS:.2f}s")
    save_image(contact_sheet(panels, 3, labels), path)


def track(tracker: SilhouetteTracker, masks: list[np.ndarray]) -> tuple:
    """Track frame by frame.

    Returns (result, first-frame CPU seconds, later CPU seconds per frame, later wall
    seconds per frame).  CPU time is this process's: on a machine shared with other
    work it is the single-core cost, where wall time also counts waiting for a core.
    """
    tracker.reset()
    frames = np.arange(len(masks[0]))
    c0, w0 = time.process_time(), time.perf_counter()
    travel = tracker.travel_directions(masks, frames, 1.0 / ESTIMATE_FPS)
    # the direction of travel (all frames at once) counts in every frame's cost
    travel_cpu = (time.process_time() - c0) / len(frames)
    travel_wall = (time.perf_counter() - w0) / len(frames)
    estimates, cpu, wall = [], [], []
    for f in frames:
        c0, w0 = time.process_time(), time.perf_counter()
        estimates.append(tracker.step([m[f] for m in masks], travel[f]))
        cpu.append(time.process_time() - c0 + travel_cpu)
        wall.append(time.perf_counter() - w0 + travel_wall)
    result = tracker.result(estimates, np.arange(len(estimates)), 1.0 / ESTIMATE_FPS)
    return result, cpu[0], np.asarray(cpu[1:]), np.asarray(wall[1:])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--video", action="store_true", help="go through background subtraction")
    parser.add_argument("--frames", type=int, default=0, help="frames per clip (0: all)")
    parser.add_argument("--figure", help="save a picture of estimates drawn over both views (.png)")
    parser.add_argument(
        "--body-scale",
        type=float,
        help="fix the body model's scale (default: measured on the first frames)",
    )
    parser.add_argument(
        "--no-recovery", action="store_true", help="no whole-dictionary search on poor scores"
    )
    parser.add_argument(
        "--no-travel", action="store_true", help="no direction-of-travel prior on the heading"
    )
    parser.add_argument(
        "--scale-from-top", action="store_true", help="body height from the silhouettes' top"
    )
    parser.add_argument(
        "--front", action="store_true", help="both cameras ahead of the person, at ±60°"
    )
    parser.add_argument(
        "--garment", help="the person wears this garment (eigmotion.body.garments, e.g. long_coat)"
    )
    args = parser.parse_args()

    t0 = time.perf_counter()
    avatar = load_default_avatar()
    sequences = [posture_sequence(find_motion(n), avatar) for n in DICTIONARY_MOTIONS]
    dictionary = dictionary_from_sequences(
        sequences, 5.0, tuple(np.arange(-180.0, 180.0, 15.0)), face_forward=True
    )
    bodies = avatar_bodies(dictionary, avatar)
    build_s = time.perf_counter() - t0
    print(
        f"dictionary: {', '.join(DICTIONARY_MOTIONS)} -> {dictionary.n_base} postures x 24 "
        f"headings = {len(dictionary)} entries; body model {bodies.n_vertices} vertices, "
        f"{len(bodies.faces)} faces; built in {build_s:.1f} s"
    )
    dressed = avatar
    if args.garment:
        from eigmotion.body.garments import dress

        dressed = dress(avatar, [args.garment])
    subject = dressed.with_shape(**SUBJECT)
    print(
        f"subject: height {subject.height_m:.2f} m, girth {SUBJECT['girth']} "
        f"{'in ' + args.garment + ' ' if args.garment else ''}"
        f"(dictionary body {avatar.height_m:.2f} m, girth 1.0); cameras {WIDTH}x{HEIGHT}, "
        f"{'ahead at ±60°' if args.front else 'both sides of the walkway'}; silhouettes from "
        f"{'background subtraction of composed video' if args.video else 'the renderer'}"
    )
    cams = walkway_cameras(args.front)
    body_joints = [i for i, n in enumerate(avatar.joint_names) if not n.endswith(("1", "Thumb"))]
    names = [avatar.joint_names[i] for i in body_joints]
    rows, per_joint, smoothed_err = [], {"tree": [], "exhaustive": []}, []
    for c, (clip, heading) in enumerate(TEST_CLIPS):
        rot, pos = stage(clip, heading, subject)
        if args.frames:
            rot, pos = rot[: args.frames], pos[: args.frames]
        vertices = subject.skin(rot, pos)
        masks = [render_masks(vertices, subject.faces, cam) for cam in cams]
        cut = [m[:, [0, -1]].any() or m[:, :, [0, -1]].any() for m in masks]
        views = [np.repeat((m * 170).astype(np.uint8)[..., None], 3, -1) for m in masks]
        if args.video:
            composed = [video_frames(m, 10 * c + i) for i, m in enumerate(masks)]
            views = [frames for frames, _ in composed]
            masks = [cut_out(frames, bg) for frames, bg in composed]
        for mode in ("tree", "exhaustive"):
            config = TrackerConfig(
                exhaustive=mode == "exhaustive",
                body_scale=args.body_scale,
                recovery_ratio=None if args.no_recovery else TrackerConfig.recovery_ratio,
                travel_tolerance_deg=None if args.no_travel else TrackerConfig.travel_tolerance_deg,
                scale_from_top=args.scale_from_top,
            )
            tracker = SilhouetteTracker(dictionary, cams, bodies, config)
            result, first_s, later_s, later_wall_s = track(tracker, masks)
            err = np.linalg.norm(result.joint_positions_m - pos, axis=-1)[:, body_joints]
            root_err = np.linalg.norm(result.positions_m - pos[:, 0], axis=-1)
            per_joint[mode].append(err)
            if mode == "tree":
                smoothed = fitted_poses(tracker, result, None).joints_m
                smoothed_err.append(np.linalg.norm(smoothed - pos, axis=-1)[:, body_joints])
            if args.figure and c == 0 and mode == "tree":
                save_figure(args.figure, tracker, result, views, clip)
            rows.append(
                (
                    clip,
                    mode,
                    len(pos),
                    1000 * err.mean(),
                    1000 * np.median(err.mean(axis=1)),
                    1000 * root_err.mean(),
                    1.0 / later_s.mean(),
                    1.0 / later_wall_s.mean(),
                    first_s,
                    result.n_evaluations[1:].mean(),
                    int(result.n_evaluations[0]),
                    int(np.sum(result.n_evaluations[1:] > config.max_candidates)),
                    " (person leaves a view)" if any(cut) else "",
                )
            )
    print()
    header = (
        f"{'clip':<12} {'search':<10} {'frames':>6} {'MPJPE mm':>9} {'median':>7} "
        f"{'root mm':>8} {'est/s':>6} {'wall':>6} {'1st s':>6} {'evals/frame':>11} "
        f"{'1st evals':>9} {'recoveries':>10}"
    )
    print(header)
    print("-" * len(header))
    for r in rows:
        print(
            f"{r[0]:<12} {r[1]:<10} {r[2]:>6d} {r[3]:>9.1f} {r[4]:>7.1f} {r[5]:>8.1f} "
            f"{r[6]:>6.1f} {r[7]:>6.1f} {r[8]:>6.2f} {r[9]:>11.1f} {r[10]:>9d} {r[11]:>10d}{r[12]}"
        )
    print()
    total = {m: np.concatenate(per_joint[m]) for m in per_joint}
    speed = {m: np.mean([r[6] for r in rows if r[1] == m]) for m in per_joint}
    evals = {m: np.mean([r[9] for r in rows if r[1] == m]) for m in per_joint}
    for m in ("tree", "exhaustive"):
        print(
            f"all clips, {m:<10}: MPJPE {1000 * total[m].mean():6.1f} mm, "
            f"{speed[m]:5.1f} estimates/s (CPU time, after the first frame), "
            f"{evals[m]:5.1f} evaluations/frame"
        )
    ratio = total["tree"].mean() / total["exhaustive"].mean()
    print(
        f"tree / exhaustive MPJPE: {ratio:.3f} (goal <= 1.10); tree speed-up "
        f"{speed['tree'] / speed['exhaustive']:.2f}x"
    )
    smoothed_mm = 1000 * np.concatenate(smoothed_err).mean()
    print(
        f"all clips, tree with the joints' paths smoothed over "
        f"{TrackerConfig.joint_smooth_s:g} s (eigmotion track's last step): MPJPE "
        f"{smoothed_mm:6.1f} mm, {smoothed_mm / (1000 * total['tree'].mean()):.3f} x the tree's"
    )
    print()
    print("MPJPE per joint, mm (all clips):")
    print(f"{'joint':<16} {'tree':>7} {'exhaustive':>10}")
    for j, name in enumerate(names):
        print(
            f"{name:<16} {1000 * total['tree'][:, j].mean():>7.1f} "
            f"{1000 * total['exhaustive'][:, j].mean():>10.1f}"
        )


if __name__ == "__main__":
    main()
