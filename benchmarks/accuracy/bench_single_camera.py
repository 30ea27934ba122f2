"""Single-camera 3D pose: continuous pose against the linear stretch, on time-warped clips.

Each query clip is a library motion performed by a body shape the database was not
built with (1.62 m / girth 1.2, 1.85 m / girth 0.9), TIME-WARPED (its first half
played at one speed, its second at another: 0.8× then 1.2×, or the reverse), filmed
by one still camera from a view halfway between the database rig's cameras (azimuth
half a step off; elevation between two rows, or 10° for a single row) over a textured
background with a cast shadow, camouflaged clothing and sensor noise
(:func:`eigmotion.synth.clips.render_clip`, 320 × 240, 30 fps).  The silhouettes come from
background subtraction against the empty scene (:func:`eigmotion.segmentation.video.
extract_silhouettes`; ``--masks true`` takes the renderer's instead).

Each clip is answered by the database (:meth:`MotionDatabase.query_masks`), then:

* **continuous pose** — :func:`eigmotion.pose.continuous_pose.continuous_pose`: the matched
  motion aligned to the clip frame by frame;
* **linear stretch** — :func:`eigmotion.pose.replay.replay`: the matched window stretched
  over the clip (the baseline; the matched view);
* **world and keypoints cues** (where LiteRT is installed) — the continuous pose moved
  toward the pose landmark network's 3D posture of the rendered frames
  (:func:`eigmotion.pose.keypoint_fit.toward_network`), as ``query --pose-cue world``,
  or refined with its 2D keypoints (:func:`eigmotion.pose.keypoint_fit.fit_keypoints`),
  as ``query --pose-cue keypoints``.

Both are compared with the true joints of the rendered body (the avatar animation of
the warped motion on that body), all turned so that the clip's camera is at azimuth 0
(the outputs' convention).  MPJPE over the 25 body joints (fingers and thumbs left
out), millimetres, after subtracting the root joint per frame ("root"); and also after
the one rotation about the vertical axis that fits the whole clip best ("root+yaw",
which forgives an error in the view's azimuth).  Bone lengths differ between the
avatar and the clip's body (another height; one camera cannot tell size from
distance): that part of the error is in every column, and "floor" shows it alone —
the warped motion itself on the avatar against the clip's body, what a perfect
alignment would score.

Run from the repository root::

    python benchmarks/accuracy/bench_single_camera.py              # the default database
    python benchmarks/accuracy/bench_single_camera.py --quick      # 4 clips
    python benchmarks/accuracy/bench_single_camera.py --db other.fs --masks true
    python benchmarks/accuracy/bench_single_camera.py --config speed_weight=0   # an ablation

``--config NAME=VALUE`` (repeatable) changes one field of
:class:`eigmotion.pose.continuous_pose.ContinuousPoseConfig` (numbers; tuples as
``scales=0.9,1.0,1.1``).

Without ``--db`` the default database (``database/eigmotion.fs``) is used; if it is
missing, a database of the whole library with ``virtual_cameras/ring6.toml`` is built
into a temporary folder first (about a minute).  A clip takes about 5–10 s to render
and 5–15 s to align on a 2-core machine.
"""

from __future__ import annotations

import os

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

import argparse  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
import zlib  # noqa: E402
from dataclasses import dataclass  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from eigmotion.body.avatar import load_default_avatar  # noqa: E402
from eigmotion.body.retarget import retarget  # noqa: E402
from eigmotion.evaluation.query_clips import halfway_views  # noqa: E402
from eigmotion.imaging.cameras import CameraRig, load_rig  # noqa: E402
from eigmotion.mocap.kinematics import forward_kinematics  # noqa: E402
from eigmotion.mocap.library import load_library  # noqa: E402
from eigmotion.mocap.rotations import axis_rotation  # noqa: E402
from eigmotion.pose.continuous_pose import ContinuousPoseConfig, continuous_pose  # noqa: E402
from eigmotion.pose.keypoint_fit import fit_keypoints, toward_network  # noqa: E402
from eigmotion.pose.keypoints import frame_keypoints, keypoints_available  # noqa: E402
from eigmotion.pose.replay import replay  # noqa: E402
from eigmotion.retrieval.build import build_database  # noqa: E402
from eigmotion.retrieval.database import MotionDatabase  # noqa: E402
from eigmotion.retrieval.storage import DEFAULT_DB_PATH  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
RING6 = REPO / "virtual_cameras" / "ring6.toml"
WIDTH_PX, HEIGHT_PX = 320, 240
CLIP_FPS = 30.0
MARGIN = 0.08
BODY_SHAPES = ((1.62, 1.2), (1.85, 0.9))
WARPS = ((0.8, 1.2), (1.2, 0.8))
#: One clip per motion, in this order (``--quick``: the first four).
MOTIONS = (
    "walk_02_01",
    "kick_135_07",
    "sit_down_14_29",
    "fall_down_sideways",
    "run_16_35",
    "jump_16_01",
    "pick_up_02_06_a",
    "wave_14_25",
    "punch_02_05",
    "turn_16_19",
    "pick_up_heavy_box_to_chest",
    "cover_head_standing",
)
GOAL_MM = 80.0


@dataclass(frozen=True)
class Row:
    motion: str
    matched: str
    view: str
    frames: int
    ours_mm: float
    linear_mm: float
    ours_yaw_mm: float
    linear_yaw_mm: float
    floor_mm: float
    seconds: float
    keypoints_mm: float = float("nan")
    world_mm: float = float("nan")


def root_relative(positions: np.ndarray, azimuth_deg: float) -> np.ndarray:
    """(F, J, 3) joints minus the root, turned so that a camera at ``azimuth_deg``
    stands at azimuth 0."""
    rel = positions - positions[:, :1]
    return rel @ axis_rotation("Y", -azimuth_deg).T


def mpjpe_mm(estimate: np.ndarray, truth: np.ndarray, joints: list[int]) -> float:
    return float(1000 * np.linalg.norm(estimate - truth, axis=-1)[:, joints].mean())


def yaw_fitted(estimate: np.ndarray, truth: np.ndarray, joints: list[int]) -> np.ndarray:
    """The estimate turned about +Y by the one angle that brings it closest to the
    truth over all frames (least squares, closed form)."""
    e, t = estimate[:, joints], truth[:, joints]
    a = np.sum(t[..., 0] * e[..., 0] + t[..., 2] * e[..., 2])
    b = np.sum(t[..., 0] * e[..., 2] - t[..., 2] * e[..., 0])
    turn = axis_rotation("Y", np.rad2deg(np.arctan2(b, a)))
    return estimate @ turn.T


def pose_config(overrides: list[str]) -> ContinuousPoseConfig:
    """A :class:`ContinuousPoseConfig` with ``NAME=VALUE`` overrides."""
    fields = {}
    for item in overrides:
        name, sep, value = item.partition("=")
        if not sep or name not in ContinuousPoseConfig.__dataclass_fields__:
            raise SystemExit(f"--config {item!r}: expected NAME=VALUE with a config field name")
        numbers = [float(v) for v in value.split(",")]
        fields[name] = tuple(numbers) if "," in value else numbers[0]
        if name in ("shift_radius_px", "smoothing_frames", "min_silhouette_px", "n_faces"):
            fields[name] = int(numbers[0])
    return ContinuousPoseConfig(**fields)


def open_database(path: str | None, workdir: Path) -> tuple[MotionDatabase, str]:
    if path is None and DEFAULT_DB_PATH.exists():
        path = str(DEFAULT_DB_PATH)
    if path is None:
        path = str(workdir / "ring6.fs")
        print(f"building a database of the library with {RING6.name} into {path} …", flush=True)
        library = [m for m in load_library() if m.role == "basic"]
        build_database(library, load_rig(RING6), path, progress=False)
    return MotionDatabase.open(path), path


def run_clip(db, item, j: int, rig: CameraRig, args, body_cache: dict) -> Row:
    from eigmotion.segmentation.video import extract_silhouettes
    from eigmotion.synth.clips import render_clip, time_warped

    azimuths, elevations = halfway_views(rig)
    azimuth_deg = float(azimuths[(5 * j + 1) % len(azimuths)])
    elevation_deg = float(elevations[j % len(elevations)])
    shape = BODY_SHAPES[j % len(BODY_SHAPES)]
    speeds = WARPS[j % len(WARPS)]
    if shape not in body_cache:
        body_cache[shape] = load_default_avatar().with_shape(height_m=shape[0], girth=shape[1])
    body = body_cache[shape]
    warped = time_warped(item.motion, speeds, CLIP_FPS)
    seed = zlib.crc32(f"{args.seed}/{item.name}".encode()) & 0x7FFFFFFF
    clip = render_clip(
        warped,
        body,
        azimuth_deg,
        elevation_deg,
        np.random.default_rng(seed),
        WIDTH_PX,
        HEIGHT_PX,
        CLIP_FPS,
        MARGIN,
    )
    if args.masks == "true":
        masks = clip.true_masks
    else:
        masks = extract_silhouettes(clip.frames, clip.background)
    truth = root_relative(retarget(warped, body).joint_positions, azimuth_deg)
    # The warped motion itself on the avatar: a perfect alignment's error (bone lengths).
    avatar = load_default_avatar()
    on_avatar = root_relative(retarget(warped, avatar).joint_positions, azimuth_deg)

    result = db.query_masks(masks, CLIP_FPS)
    best = result.best
    t0 = time.perf_counter()
    pose = continuous_pose(db, result, masks, CLIP_FPS, args.pose_config)
    seconds = time.perf_counter() - t0
    linear = replay(
        db.motion(best.motion_id),
        best.window,
        best.azimuth_deg,
        best.elevation_deg,
        len(masks),
        CLIP_FPS,
    )
    joints = [i for i, n in enumerate(pose.names) if not n.endswith(("1", "Thumb"))]
    ours = root_relative(pose.positions, 0.0)
    base = forward_kinematics(linear.motion, length_unit_m=1.0, ground=False).positions
    base = root_relative(base, 0.0)
    keypoints_mm = world_mm = float("nan")
    if keypoints_available():
        keypoints = frame_keypoints(clip.frames, masks)
        fitted = fit_keypoints(pose, keypoints)
        keypoints_mm = mpjpe_mm(root_relative(fitted.positions, 0.0), truth, joints)
        moved = toward_network(pose, keypoints)
        world_mm = mpjpe_mm(root_relative(moved.positions, 0.0), truth, joints)
    view = (
        f"{azimuth_deg:.0f}/{elevation_deg:.0f} → {best.azimuth_deg:.0f}/"
        f"{best.elevation_deg:.0f} → {pose.azimuth_deg:.1f}/{pose.elevation_deg:.0f}"
    )
    return Row(
        f"{item.name} ({speeds[0]}×, {speeds[1]}×)",
        best.motion,
        view,
        len(masks),
        mpjpe_mm(ours, truth, joints),
        mpjpe_mm(base, truth, joints),
        mpjpe_mm(yaw_fitted(ours, truth, joints), truth, joints),
        mpjpe_mm(yaw_fitted(base, truth, joints), truth, joints),
        mpjpe_mm(on_avatar, truth, joints),
        seconds,
        keypoints_mm,
        world_mm,
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--db", help="database (default database/eigmotion.fs, else built)")
    parser.add_argument("--quick", action="store_true", help="the first four clips only")
    parser.add_argument(
        "--masks",
        choices=("video", "true"),
        default="video",
        help="silhouettes by background subtraction (default) or the renderer's",
    )
    parser.add_argument("--seed", type=int, default=0, help="scene randomness")
    parser.add_argument(
        "--config",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="override a ContinuousPoseConfig field (repeatable)",
    )
    args = parser.parse_args()
    args.pose_config = pose_config(args.config)

    by_name = {m.name: m for m in load_library()}
    names = MOTIONS[:4] if args.quick else MOTIONS
    rows: list[Row] = []
    with tempfile.TemporaryDirectory() as tmp:
        db, path = open_database(args.db, Path(tmp))
        with db:
            print(
                f"database {path}: rig {db.rig.name or '?'} ({len(db.rig)} views), "
                f"{db.store.n_motions} motions; silhouettes: {args.masks}; "
                f"config overrides: {args.config or 'none'}",
                flush=True,
            )
            bodies: dict = {}
            for j, name in enumerate(names):
                row = run_clip(db, by_name[name], j, db.rig, args, bodies)
                rows.append(row)
                print(
                    f"  {row.motion}: {row.ours_mm:.1f} mm vs {row.linear_mm:.1f} mm "
                    f"(world cue {row.world_mm:.1f} mm, keypoints cue {row.keypoints_mm:.1f} "
                    f"mm; {row.seconds:.1f} s)",
                    flush=True,
                )

    print()
    print(
        "| clip (warp) | matched motion | view: clip → matched → refined (az/el °) | frames "
        "| continuous mm (root) | linear mm (root) | ratio | continuous mm (root+yaw) "
        "| linear mm (root+yaw) | floor mm | align s |"
    )
    print("| --- | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for r in rows:
        print(
            f"| {r.motion} | {r.matched} | {r.view} | {r.frames} | {r.ours_mm:.1f} | "
            f"{r.linear_mm:.1f} | {r.ours_mm / r.linear_mm:.2f} | {r.ours_yaw_mm:.1f} | "
            f"{r.linear_yaw_mm:.1f} | {r.floor_mm:.1f} | {r.seconds:.1f} |"
        )
    ours = np.array([r.ours_mm for r in rows])
    linear = np.array([r.linear_mm for r in rows])
    ours_yaw = np.array([r.ours_yaw_mm for r in rows])
    linear_yaw = np.array([r.linear_yaw_mm for r in rows])
    floor = np.array([r.floor_mm for r in rows])
    same = np.array([r.matched == r.motion.split(" ")[0] for r in rows])
    print()
    print(
        f"all {len(rows)} clips, MPJPE (root): continuous {ours.mean():.1f} mm, linear "
        f"{linear.mean():.1f} mm, ratio {ours.mean() / linear.mean():.3f}; median "
        f"{np.median(ours):.1f} vs {np.median(linear):.1f} mm; worst {ours.max():.1f} mm"
    )
    print(
        f"MPJPE (root+yaw): continuous {ours_yaw.mean():.1f} mm, linear "
        f"{linear_yaw.mean():.1f} mm, ratio {ours_yaw.mean() / linear_yaw.mean():.3f}"
    )
    keypoints = np.array([r.keypoints_mm for r in rows])
    world = np.array([r.world_mm for r in rows])
    if np.isfinite(keypoints).all() and np.isfinite(world).all():
        print(
            f"world cue, MPJPE (root): {world.mean():.1f} mm; keypoints cue: "
            f"{keypoints.mean():.1f} mm"
        )
    print(
        f"floor (the true motion on the avatar, whose bones differ from the clip's body): "
        f"{floor.mean():.1f} mm"
    )
    if same.any() and (~same).any():
        print(
            f"retrieved its own motion in {same.sum()} clips: continuous "
            f"{ours[same].mean():.1f} mm, linear {linear[same].mean():.1f} mm; another "
            f"motion in {(~same).sum()}: {ours[~same].mean():.1f} vs "
            f"{linear[~same].mean():.1f} mm"
        )
    print(
        f"mean alignment time {np.mean([r.seconds for r in rows]):.1f} s per clip; goal "
        f"MPJPE <= {GOAL_MM:.0f} mm: {'met' if ours.mean() <= GOAL_MM else 'NOT met'} "
        f"(mean), {int(np.sum(ours <= GOAL_MM))}/{len(rows)} clips"
    )


if __name__ == "__main__":
    main()
