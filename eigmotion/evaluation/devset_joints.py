"""The development set's 3D benchmarks, run in-process as the commands run them.

* Two cameras (:func:`track_set`): each ``tracking/<id>/`` set (``cams.json``,
  ``cam0.mp4``, ``cam1.mp4``, ``background0.png``, ``background1.png``, ``joints.npy``,
  ``joints.json``) tracked as ``eigmotion track --calib cams.json cam0.mp4 cam1.mp4
  --background background0.png background1.png --joints-out J.npz`` tracks it
  (:func:`eigmotion.tracking.pipeline.track_clip`, the default dictionary and tracker
  settings), scored by :func:`eigmotion.evaluation.joint_errors.tracking_errors`, with
  the estimates per second of this process's CPU time (:func:`time.process_time`
  around the tracking).
* One camera (:func:`pose_clip`): each ``retrieval/<id>/`` clip asked with its
  background as ``eigmotion query video.mp4 --background background.png --pose-out
  P.npz`` asks it (:meth:`~eigmotion.retrieval.database.MotionDatabase.query_clip` for
  every frame, then :func:`eigmotion.pose.continuous_pose.continuous_pose`), scored by
  PA-MPJPE per frame and per clip over the 12 limb joints.

The figures are those of ``shared/eval/score.py tracking`` and ``pose``.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from eigmotion.errors import EigmotionError, InvalidParameterError
from eigmotion.evaluation.devset import DevClip
from eigmotion.evaluation.joint_errors import (
    LIMB_JOINTS,
    TrackingErrors,
    match_joints,
    pa_mpjpe_per_clip,
    pa_mpjpe_per_frame,
    tracking_errors,
)
from eigmotion.evaluation.query_clips import TOP_K
from eigmotion.evaluation.statistics import markdown_table
from eigmotion.pose.keypoint_fit import fit_keypoints, toward_network
from eigmotion.pose.keypoints import (
    NETWORK_CUES,
    keypoints_available,
    limb_world_joints,
    pose_keypoints,
    resolve_cue,
)
from eigmotion.retrieval.database import MotionDatabase
from eigmotion.segmentation.video import load_clip_masks
from eigmotion.tracking.calibration import load_calibration
from eigmotion.tracking.dictionary import PostureDictionary
from eigmotion.tracking.pipeline import track_clip
from eigmotion.tracking.tracker import SilhouetteTracker, TrackerConfig


def load_truth(folder: Path) -> tuple[tuple[str, ...], np.ndarray]:
    """A clip's true joints: names (``joints.json``) and (F, 21, 3) positions, metres.

    Raises
    ------
    InvalidParameterError
        ``joints.npy`` or ``joints.json`` missing.
    """
    for name in ("joints.npy", "joints.json"):
        if not (folder / name).is_file():
            raise InvalidParameterError(f"{folder}: no {name}")
    names = json.loads((folder / "joints.json").read_text())
    names = names["names"] if isinstance(names, dict) else names
    return tuple(str(n) for n in names), np.load(folder / "joints.npy").astype(np.float64)


def load_tracking_sets(dev: Path, only: Sequence[str] | None = None) -> list[Path]:
    """The folders of ``dev/tracking/`` with a ``cams.json``, sorted by id; those whose
    id contains any of ``only`` if given."""
    root = Path(dev) / "tracking"
    if not root.is_dir():
        return []
    return [
        folder
        for folder in sorted(root.iterdir())
        if (folder / "cams.json").is_file() and (not only or any(o in folder.name for o in only))
    ]


@dataclass(frozen=True)
class TrackedSet:
    """One two-camera set, tracked and scored.

    Attributes
    ----------
    set_id : str
    errors : TrackingErrors or None
        None when the tracking raised.
    estimates : int
    cpu_s, wall_s : float
        Time of the tracking itself (not reading the videos or building the
        dictionary), seconds.
    error : str or None
        The message of the :class:`~eigmotion.errors.EigmotionError` raised.
    silhouette_iou : float or None
        The silhouettes' IoU against the set's true masks, mean over cameras and
        frames; None without true masks.
    keypoints_trusted : float or None
        Share of the triangulated joints the keypoints stage trusted, over estimates
        and joints; None when the stage did not run.
    """

    set_id: str
    errors: TrackingErrors | None
    estimates: int
    cpu_s: float
    wall_s: float
    error: str | None = None
    silhouette_iou: float | None = None
    keypoints_trusted: float | None = None

    @property
    def estimates_per_cpu_s(self) -> float:
        return self.estimates / self.cpu_s if self.cpu_s > 0 else float("nan")

    def to_json(self) -> dict:
        return {
            "id": self.set_id,
            **(self.errors.to_json() if self.errors else {}),
            "estimates": self.estimates,
            "cpu_s": round(self.cpu_s, 3),
            "wall_s": round(self.wall_s, 3),
            "estimates_per_cpu_s": round(self.estimates_per_cpu_s, 2) if self.cpu_s else None,
            "silhouette_iou": (
                None if self.silhouette_iou is None else round(self.silhouette_iou, 4)
            ),
            "keypoints_trusted": (
                None if self.keypoints_trusted is None else round(self.keypoints_trusted, 4)
            ),
            "error": self.error,
        }


def silhouette_iou(masks: np.ndarray, truth: np.ndarray) -> float:
    """Mean over frames of the intersection over union of two mask sequences.

    Parameters
    ----------
    masks, truth : (F, H, W) bool
        Frames where both are empty are left out.

    Returns
    -------
    float
        In [0, 1]; NaN when every frame is empty in both.
    """
    n = min(len(masks), len(truth))
    masks, truth = masks[:n], truth[:n]
    union = (masks | truth).sum(axis=(1, 2))
    inter = (masks & truth).sum(axis=(1, 2))
    seen = union > 0
    return float(np.mean(inter[seen] / union[seen])) if seen.any() else float("nan")


def track_set(
    folder: Path,
    dictionary: PostureDictionary,
    config: TrackerConfig | None = None,
    segmenter: str = "auto",
) -> TrackedSet:
    """Track one set as ``eigmotion track`` does (with its default settings, or
    ``config``), and score it.

    ``segmenter`` is the front end of ``eigmotion track --segmenter``; every front end
    but ``learned`` gets the set's empty-scene images.  Where the set has its true masks
    (``masks0.npz``, ``masks1.npz``) the silhouettes' IoU against them is kept.
    """
    folder = Path(folder)
    try:
        calibration = load_calibration(folder / "cams.json")
        masks, landmarks, ious, fps = [], [], [], None
        for c, camera in enumerate(calibration.cameras):
            background = None if segmenter == "learned" else folder / f"background{c}.png"
            clip = load_clip_masks(folder / f"cam{c}.mp4", background, segmenter=segmenter)
            if clip.masks.shape[1:] != (camera.height, camera.width):
                raise InvalidParameterError(
                    f"{folder}/cam{c}.mp4: frames do not match camera {camera.name!r}"
                )
            masks.append(clip.masks)
            landmarks.append(clip.landmarks)
            fps = fps or clip.fps
            if (folder / f"masks{c}.npz").is_file():
                with np.load(folder / f"masks{c}.npz") as stored:
                    ious.append(silhouette_iou(clip.masks, stored["masks"] > 0))
        tracker = SilhouetteTracker(
            dictionary, calibration.cameras, config=config, pairs=calibration.pairs
        )
        tracked = track_clip(tracker, masks, fps, landmarks=landmarks)
        true_names, truth = load_truth(folder)
        frames = tracked.result.frames
        keep = frames < len(truth)
        errors = tracking_errors(
            tracked.result.joint_names, tracked.joints_m[keep], true_names, truth[frames[keep]]
        )
    except EigmotionError as exc:
        return TrackedSet(folder.name, None, 0, 0.0, 0.0, " ".join(str(exc).split()))
    iou = float(np.mean(ious)) if len(ious) == len(masks) else None
    fitted = tracked.fitted
    trusted = None if fitted is None or fitted.trusted is None else float(fitted.trusted.mean())
    return TrackedSet(
        folder.name, errors, tracked.result.n_estimates, tracked.cpu_s, tracked.wall_s,
        silhouette_iou=iou, keypoints_trusted=trusted,
    )  # fmt: skip


#: The single-camera variants scored in one run, and how the report names them.
POSE_VARIANTS = {
    "silhouette": "ours, silhouette cue (query --pose-cue silhouette)",
    "world": "ours, world cue (query --pose-cue world)",
    "keypoints": "ours, keypoints cue (query --pose-cue keypoints)",
    "network": "pose landmark network alone, world landmarks",
}


@dataclass(frozen=True)
class PosedClip:
    """One single-camera clip's pose, scored.

    Attributes
    ----------
    clip_id, label : str
    per_frame_mm : float
        Mean over frames of the PA-MPJPE with one alignment per frame, mm, of the
        query's default pose (:data:`~eigmotion.pose.continuous_pose.CUES`: ``auto``).
    per_clip_mm : float
        PA-MPJPE with one alignment for the whole clip, mm, of the same.
    frames : int
    seconds : float
        Wall time of the query and the default pose, seconds.
    error : str or None
    variants : dict of str to (float, float)
        Per frame and per clip PA-MPJPE, mm, of each of :data:`POSE_VARIANTS` scored.
    network_ms_per_frame, fit_ms_per_frame : float
        Wall time per frame, ms (NaN when not run), of getting the pose network's answer
        once the query has its silhouettes (about 0 where the learned front end kept
        its own: :func:`~eigmotion.pose.keypoints.pose_keypoints`), and of the keypoint
        fit.
    network_found : float
        Share of the frames where the network found the person.
    """

    clip_id: str
    label: str
    per_frame_mm: float
    per_clip_mm: float
    frames: int
    seconds: float
    error: str | None = None
    variants: dict = field(default_factory=dict)
    network_ms_per_frame: float = float("nan")
    fit_ms_per_frame: float = float("nan")
    network_found: float = float("nan")

    def to_json(self) -> dict:
        ok = self.error is None
        return {
            "id": self.clip_id,
            "label": self.label,
            "pa_mpjpe_frame_mm": round(self.per_frame_mm, 2) if ok else None,
            "pa_mpjpe_clip_mm": round(self.per_clip_mm, 2) if ok else None,
            "frames": self.frames,
            "seconds": round(self.seconds, 3),
            "error": self.error,
            "variants": {
                name: {"pa_mpjpe_frame_mm": round(f, 2), "pa_mpjpe_clip_mm": round(c, 2)}
                for name, (f, c) in self.variants.items()
            },
            "network_ms_per_frame": _rounded(self.network_ms_per_frame),
            "fit_ms_per_frame": _rounded(self.fit_ms_per_frame),
            "network_found": _rounded(self.network_found),
        }


def _rounded(value: float) -> float | None:
    return round(float(value), 2) if np.isfinite(value) else None


def _scored(names, positions, true_names, truth) -> tuple[float, float]:
    est, true, _ = match_joints(names, positions, true_names, truth, LIMB_JOINTS)
    return float(pa_mpjpe_per_frame(est, true).mean()), pa_mpjpe_per_clip(est, true)


def pose_clip(db: MotionDatabase, clip: DevClip) -> PosedClip:
    """Ask one clip with its background for its pose, as ``eigmotion query CLIP
    --background B --pose-out P.npz`` does, and score it over :data:`LIMB_JOINTS`; in
    the same run each of :data:`POSE_VARIANTS` where the pose network runs (LiteRT)."""
    # Lazy, as in the query command: the 3D answer loads retargeting and scipy.spatial.
    from eigmotion.pose.continuous_pose import ContinuousPoseConfig, continuous_pose

    started = time.perf_counter()
    variants: dict[str, tuple[float, float]] = {}
    timing = {"network_ms_per_frame": np.nan, "fit_ms_per_frame": np.nan, "network_found": np.nan}
    try:
        result, cut = db.query_clip(clip.video, clip.background, TOP_K, every_frame=True)
        default_cue = resolve_cue(ContinuousPoseConfig().cue, clip.video)
        pose = continuous_pose(db, result, cut.masks, cut.fps)
        silhouette_s = time.perf_counter() - started
        true_names, truth = load_truth(clip.folder)
        variants["silhouette"] = _scored(pose.names, pose.positions, true_names, truth)
        if keypoints_available():
            t0 = time.perf_counter()
            keypoints = pose_keypoints(cut, clip.video)
            t1 = time.perf_counter()
            fitted = fit_keypoints(pose, keypoints)
            t2 = time.perf_counter()
            moved = toward_network(pose, keypoints)
            t3 = time.perf_counter()
            variants["keypoints"] = _scored(fitted.names, fitted.positions, true_names, truth)
            variants["world"] = _scored(moved.names, moved.positions, true_names, truth)
            if keypoints.found.any():
                variants["network"] = _scored(*limb_world_joints(keypoints), true_names, truth)
            timing = {
                "network_ms_per_frame": (t1 - t0) / pose.n_frames * 1000.0,
                "fit_ms_per_frame": (t2 - t1) / pose.n_frames * 1000.0,
                "network_found": float(keypoints.found.mean()),
            }
            cue_s = {"keypoints": t2 - t0, "world": (t1 - t0) + (t3 - t2)}
        frames = min(pose.n_frames, len(truth))
    except EigmotionError as exc:
        message = " ".join(str(exc).split())
        return PosedClip(clip.clip_id, clip.label, np.nan, np.nan, 0, 0.0, message)
    seconds = silhouette_s + (cue_s[default_cue] if default_cue in NETWORK_CUES else 0.0)
    per_frame, per_clip = variants[default_cue]
    return PosedClip(
        clip.clip_id, clip.label, per_frame, per_clip, frames, seconds, None, variants, **timing
    )


def _mean(values) -> float:
    values = [v for v in values if np.isfinite(v)]
    return float(np.mean(values)) if values else float("nan")


def summarise_tracking(sets: Sequence[TrackedSet]) -> dict:
    """The figures over every set tracked: mean MPJPE (the mean of the sets' MPJPE),
    the worst set, mean root error, swaps and heading flips over all frames, and the
    estimates per second of CPU time over all sets."""
    scored = [s for s in sets if s.errors is not None]
    cpu = sum(s.cpu_s for s in scored)
    return {
        "sets": len(sets),
        "failed": len(sets) - len(scored),
        "mpjpe_mm": _mean([s.errors.mpjpe_mm for s in scored]),
        "worst_set_mm": max((s.errors.mpjpe_mm for s in scored), default=float("nan")),
        "root_mm": _mean([s.errors.root_mm for s in scored if s.errors.root_mm is not None]),
        "swaps": sum(s.errors.swaps for s in scored),
        "heading_flips": sum(s.errors.heading_flips for s in scored),
        "frames": sum(s.errors.frames for s in scored),
        "estimates_per_cpu_s": sum(s.estimates for s in scored) / cpu if cpu else float("nan"),
        "silhouette_iou": _mean([s.silhouette_iou for s in scored if s.silhouette_iou is not None]),
    }


def format_tracking(sets: Sequence[TrackedSet]) -> str:
    """The sets as Markdown: one row per set, then MPJPE per joint and set."""
    scored = [s for s in sets if s.errors is not None]
    rows = [
        [
            s.set_id,
            f"{s.errors.mpjpe_mm:.0f}",
            "—" if s.errors.root_mm is None else f"{s.errors.root_mm:.0f}",
            f"{s.errors.swaps}/{s.errors.frames}",
            f"{s.errors.heading_flips}/{s.errors.frames}",
            f"{s.estimates_per_cpu_s:.1f}",
            "—" if s.silhouette_iou is None else f"{s.silhouette_iou:.2f}",
        ]
        for s in scored
    ]
    total = summarise_tracking(sets)
    if scored:
        rows.append(
            [
                "mean",
                f"{total['mpjpe_mm']:.0f}",
                f"{total['root_mm']:.0f}",
                f"{total['swaps']}/{total['frames']}",
                f"{total['heading_flips']}/{total['frames']}",
                f"{total['estimates_per_cpu_s']:.1f}",
                "—" if math.isnan(total["silhouette_iou"]) else f"{total['silhouette_iou']:.2f}",
            ]
        )
    header = ["set", "MPJPE mm", "root mm", "left/right swapped", "heading off > 90°",
              "estimates / CPU s", "silhouette IoU"]  # fmt: skip
    lines = ["## tracking: two cameras, 13 joints", "", *markdown_table(header, rows)]
    if scored:
        joints = scored[0].errors.joints
        per_joint = [
            [j, *(f"{s.errors.per_joint_mm[k]:.0f}" for s in scored)] for k, j in enumerate(joints)
        ]
        lines += ["", "MPJPE per joint, mm:", ""]
        lines += markdown_table(["joint", *(s.set_id for s in scored)], per_joint)
    staged = [s for s in scored if s.keypoints_trusted is not None]
    lines += [
        "",
        "keypoints stage: "
        + (
            ", ".join(f"{s.set_id} {s.keypoints_trusted:.0%}" for s in staged)
            + " of the triangulated joints trusted"
            if staged
            else "not run (no pose landmarks from the front end, or switched off)"
        ),
    ]
    failed = [s for s in sets if s.errors is None]
    if failed:
        lines += ["", f"failed ({len(failed)}):", *(f"- {s.set_id}: {s.error}" for s in failed)]
    return "\n".join(lines)


def summarise_pose(clips: Sequence[PosedClip]) -> dict:
    """Mean PA-MPJPE per frame and per clip over the clips scored, and per label."""
    scored = [c for c in clips if c.error is None]
    labels = sorted({c.label for c in scored})
    return {
        "clips": len(clips),
        "failed": len(clips) - len(scored),
        "pa_mpjpe_frame_mm": _mean([c.per_frame_mm for c in scored]),
        "pa_mpjpe_clip_mm": _mean([c.per_clip_mm for c in scored]),
        "per_label": {
            label: {
                "n": sum(c.label == label for c in scored),
                "pa_mpjpe_frame_mm": _mean([c.per_frame_mm for c in scored if c.label == label]),
                "pa_mpjpe_clip_mm": _mean([c.per_clip_mm for c in scored if c.label == label]),
            }
            for label in labels
        },
        "median_s": float(np.median([c.seconds for c in scored])) if scored else float("nan"),
        "variants": {
            name: {
                "n": sum(name in c.variants for c in scored),
                "pa_mpjpe_frame_mm": _mean(
                    [c.variants[name][0] for c in scored if name in c.variants]
                ),
                "pa_mpjpe_clip_mm": _mean(
                    [c.variants[name][1] for c in scored if name in c.variants]
                ),
            }
            for name in POSE_VARIANTS
            if any(name in c.variants for c in scored)
        },  # fmt: skip
        "network_ms_per_frame": _mean([c.network_ms_per_frame for c in scored]),
        "fit_ms_per_frame": _mean([c.fit_ms_per_frame for c in scored]),
        "network_found": _mean([c.network_found for c in scored]),
    }


def format_pose(clips: Sequence[PosedClip]) -> str:
    """The clips as Markdown: PA-MPJPE per label and overall, then the failures."""
    total = summarise_pose(clips)
    rows = [
        [label, v["n"], f"{v['pa_mpjpe_frame_mm']:.0f}", f"{v['pa_mpjpe_clip_mm']:.0f}"]
        for label, v in total["per_label"].items()
    ]
    n = total["clips"] - total["failed"]
    if n:
        rows.append(
            ["all", n, f"{total['pa_mpjpe_frame_mm']:.0f}", f"{total['pa_mpjpe_clip_mm']:.0f}"]
        )
    header = ["label", "clips", "PA-MPJPE per frame mm", "PA-MPJPE per clip mm"]
    lines = [
        "## pose: one camera with its background, 12 limb joints",
        "",
        *markdown_table(header, rows),
        "",
        f"median time per clip (query and pose): {total['median_s']:.2f} s",
    ]
    if total["variants"]:
        variant_rows = [
            [POSE_VARIANTS[name], v["n"], f"{v['pa_mpjpe_frame_mm']:.0f}",
             f"{v['pa_mpjpe_clip_mm']:.0f}"]
            for name, v in total["variants"].items()
        ]  # fmt: skip
        lines += [
            "",
            "the same clips, each variant (the pose network's answer from the query's front end):",
            "",
            *markdown_table(["variant", "clips", *header[2:]], variant_rows),
            "",
            f"pose network's answer {total['network_ms_per_frame']:.1f} ms per frame after the "
            f"query's silhouettes (found the person "
            f"in {total['network_found']:.0%} of frames), keypoint fit "
            f"{total['fit_ms_per_frame']:.1f} ms per frame",
        ]
    failed = [c for c in clips if c.error is not None]
    if failed:
        lines += ["", f"failed ({len(failed)}):", *(f"- {c.clip_id}: {c.error}" for c in failed)]
    return "\n".join(lines)
