"""``eigmotion track --calib CAMS.json VIDEO0 VIDEO1 …``: multi-camera posture tracking.

One video per calibrated camera (same order as the calibration file, same frame
count and rate), each a video file, a folder of frames or an ``.npz`` of silhouettes
(key ``masks``).  The person is cut out as ``eigmotion query`` cuts it out
(``--segmenter``): by default (``auto``) the learned person masks plus what
background subtraction against the ``--background`` images (one per video) finds
next to them (``fused``), or the learned masks alone without background images;
``subtraction`` is background subtraction alone (against a background estimated from
the clip when no image is given).  Every ``video fps / --estimate-fps``-th frame is
tracked against a posture dictionary built from ``--dictionary`` motions (default:
CMU walks and turns in every direction), or loaded from a saved dictionary ``.npz``.

With the learned and fused front ends, each estimate is then fitted to the joints
triangulated from every camera's pose landmarks (the keypoints stage,
:mod:`eigmotion.tracking.keypoint_fit`; ``--no-keypoints``: not).  Last, with any
front end, the joints' paths are smoothed over time and each estimate fitted to them
(``--joint-smooth-s``; 0: not).

Outputs: ``--bvh-out`` (the estimated motion; with ``--reference``, variable-speed
playback of that reference motion), ``--joints-out`` (``.npz``: ``names``,
``positions`` (n_frames, n_joints, 3) metres in the calibration's world frame,
``frame_time_s``, ``frames``), ``--overlay-out`` (the input views side by side with
the estimated silhouette's outline drawn in yellow, and the fitted skeleton in cyan),
``--dictionary-out`` (the dictionary as ``.npz``, for reuse).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from eigmotion.errors import InvalidParameterError
from eigmotion.imaging.media import read_frames, write_video
from eigmotion.mocap.bvh import write_bvh
from eigmotion.mocap.kinematics import forward_kinematics
from eigmotion.segmentation.learned import SEGMENTERS
from eigmotion.segmentation.video import load_clip_masks
from eigmotion.tracking.calibration import load_calibration
from eigmotion.tracking.dictionary import posture_sequence
from eigmotion.tracking.generation import (
    playback_motion,
    smooth_headings_deg,
    variable_speed_playback,
)
from eigmotion.tracking.overlay import draw_outline, draw_skeleton
from eigmotion.tracking.pipeline import (
    DEFAULT_DICTIONARY,
    DEFAULT_HEADING_STEP_DEG,
    dictionary_from_specs,
    read_motion,
    track_clip,
)
from eigmotion.tracking.postures import heading_deg, posture_vectors
from eigmotion.tracking.tracker import SilhouetteTracker, TrackerConfig


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "videos",
        nargs="+",
        type=Path,
        help="one clip per camera, in calibration order: video, frame folder or .npz masks",
    )
    parser.add_argument(
        "--calib", type=Path, required=True, help="calibration JSON (see `eigmotion calibrate`)"
    )
    parser.add_argument(
        "--background",
        nargs="+",
        type=Path,
        help="an image of the empty scene per video (default: estimated from each clip)",
    )
    parser.add_argument(
        "--segmenter",
        choices=SEGMENTERS,
        default="auto",
        help="how the person is cut out of the videos: learned (person networks), "
        "subtraction (background subtraction), fused (learned plus what subtraction finds "
        "next to them; needs --background); default auto: fused with --background, "
        "learned without",
    )
    parser.add_argument(
        "--dictionary",
        nargs="+",
        help="motions for the posture dictionary (.bvh, .amc with --asf, library names) "
        "or one saved dictionary .npz "
        f"(default: {' '.join(DEFAULT_DICTIONARY)})",
    )
    parser.add_argument("--asf", type=Path, help="the skeleton (.asf) of .amc motions")
    parser.add_argument(
        "--heading-step-deg",
        type=float,
        default=DEFAULT_HEADING_STEP_DEG,
        help="dictionary postures are turned to every multiple of this angle about the "
        "vertical; 0 keeps the recorded headings (default: %(default)s)",
    )
    parser.add_argument(
        "--prune-deg",
        type=float,
        default=5.0,
        help="near-duplicate postures (d1 below this) are dropped (default: %(default)s)",
    )
    parser.add_argument(
        "--estimate-fps",
        type=float,
        default=25.0,
        help="estimates per second of video (default: %(default)s, as the paper)",
    )
    parser.add_argument("--t", type=int, default=3, help="search tree: layer-1 step (default 3)")
    parser.add_argument("--k", type=int, default=3, help="search tree: layer-1 postures expanded")
    parser.add_argument(
        "--max-candidates", type=int, default=40, help="T_n, candidates kept (default 40)"
    )
    parser.add_argument("--max-d1-deg", type=float, default=30.0, help="T_d1, degrees (default 30)")
    parser.add_argument("--max-d2-m", type=float, default=0.3, help="T_d2, metres (default 0.3)")
    parser.add_argument(
        "--shift-px", type=int, default=6, help="silhouette shift search radius, pixels"
    )
    parser.add_argument(
        "--downsample", type=int, default=2, help="compare silhouettes at 1/N resolution"
    )
    parser.add_argument(
        "--exhaustive", action="store_true", help="score every candidate (no search tree)"
    )
    parser.add_argument(
        "--body-scale",
        type=float,
        help="the person's size relative to the body model (e.g. height / 1.67 m); "
        "default: measured from the silhouettes on the first frames",
    )
    parser.add_argument(
        "--no-recovery",
        action="store_true",
        help="never search the whole dictionary again when the match gets poor",
    )
    parser.add_argument(
        "--no-travel-prior",
        action="store_true",
        help="do not expect the person to face where they walk (e.g. walking backwards)",
    )
    parser.add_argument(
        "--scale-from-top",
        action="store_true",
        help="measure the person's height from the top of the silhouettes down to where "
        "the estimate stands (when background subtraction loses the feet)",
    )
    parser.add_argument(
        "--no-keypoints",
        action="store_true",
        help="do not fit the estimates to the joints triangulated from the pose "
        "network's landmarks",
    )
    parser.add_argument(
        "--joint-smooth-s",
        type=float,
        default=TrackerConfig.joint_smooth_s,
        help="the joints' paths smoothed over time by a Gaussian of this sigma, seconds, "
        "and each estimate fitted to them (default: %(default)s; 0: the silhouette "
        "tracker's postures as they are, with --no-keypoints)",
    )
    parser.add_argument(
        "--reference",
        help="reference motion replayed at variable speed for --bvh-out/--joints-out",
    )
    parser.add_argument(
        "--playback-window-s",
        type=float,
        default=0.1,
        help="largest step in reference time per estimate, seconds (default: %(default)s)",
    )
    parser.add_argument("--bvh-out", type=Path, help="write the motion as BVH")
    parser.add_argument("--joints-out", type=Path, help="write joint positions (.npz)")
    parser.add_argument("--overlay-out", type=Path, help="write the overlay video (.mp4, .gif)")
    parser.add_argument("--dictionary-out", type=Path, help="save the dictionary (.npz)")


def load_dictionary(args: argparse.Namespace):
    """The posture dictionary the command line asks for."""
    return dictionary_from_specs(args.dictionary, args.asf, args.heading_step_deg, args.prune_deg)


def _load_masks(args: argparse.Namespace, cameras) -> tuple[list[np.ndarray], float, list]:
    """Each camera's silhouettes, the videos' rate, and each camera's pose landmarks
    (None where the front end gives none)."""
    backgrounds = args.background or [None] * len(args.videos)
    all_masks, rates, landmarks = [], [], []
    for cam, video, background in zip(cameras, args.videos, backgrounds, strict=True):
        clip = load_clip_masks(video, background, segmenter=args.segmenter, progress=True)
        masks, fps = clip.masks, clip.fps
        if masks.shape[1:] != (cam.height, cam.width):
            raise InvalidParameterError(
                f"{video}: frames are {masks.shape[2]}×{masks.shape[1]}, camera {cam.name!r} "
                f"was calibrated at {cam.width}×{cam.height}"
            )
        all_masks.append(masks)
        rates.append(fps)
        landmarks.append(clip.landmarks)
    counts = {len(m) for m in all_masks}
    if len(counts) != 1:
        listed = ", ".join(f"{v}: {len(m)}" for v, m in zip(args.videos, all_masks, strict=True))
        raise InvalidParameterError(f"the videos have different frame counts ({listed})")
    return all_masks, float(rates[0]), landmarks


def _root_shift(tracked) -> np.ndarray:
    """(E, 3) how far the fit (keypoints stage, smoothing) moved each estimate's root,
    metres."""
    return tracked.joints_m[:, 0] - _held(tracked.result.joint_positions_m[:, 0], tracked)


def _held(values: np.ndarray, tracked) -> np.ndarray:
    """``values`` per estimate with those before the person was first seen set to the
    first found one's."""
    values = values.copy()
    values[: tracked.first] = values[tracked.first]
    return values


def _overlay_frames(args, tracker, tracked, masks) -> np.ndarray:
    """(E, H, W_total, 3) uint8: input views with the estimate's outline in yellow and,
    where the postures were fitted (:func:`~eigmotion.tracking.pipeline.fitted_poses`),
    the fitted skeleton in cyan."""
    result = tracked.result
    views = []
    for c, video in enumerate(args.videos):
        if Path(video).suffix.lower() == ".npz":
            rgb = np.repeat((masks[c][result.frames] * 160).astype(np.uint8)[..., None], 3, -1)
        else:
            frames, _ = read_frames(video)
            rgb = frames[result.frames]
        out = np.empty_like(rgb)
        for i, estimate in enumerate(result.estimates):
            out[i] = draw_outline(rgb[i], tracker.silhouette(estimate, c))
            if tracked.fitted is not None:
                out[i] = draw_skeleton(
                    out[i], tracker.cameras[c], tracked.joints_m[i], tracker.dictionary.parents
                )
        views.append(out)
    height = max(v.shape[1] for v in views)
    padded = [
        v if v.shape[1] == height else np.pad(v, ((0, 0), (0, height - v.shape[1]), (0, 0), (0, 0)))
        for v in views
    ]
    return np.concatenate(padded, axis=2)


def run(args: argparse.Namespace) -> int:
    calibration = load_calibration(args.calib)
    if len(args.videos) != len(calibration.cameras):
        raise InvalidParameterError(
            f"{len(args.videos)} videos given for the {len(calibration.cameras)} cameras of "
            f"{args.calib}"
        )
    if args.background is not None and len(args.background) != len(args.videos):
        raise InvalidParameterError(
            f"{len(args.background)} backgrounds given for {len(args.videos)} videos; give "
            "one per video or none"
        )
    if not (np.isfinite(args.estimate_fps) and args.estimate_fps > 0):
        raise InvalidParameterError(f"--estimate-fps must be > 0, got {args.estimate_fps}")
    config = TrackerConfig(
        layer_step=args.t,
        top_k=args.k,
        max_candidates=args.max_candidates,
        max_d1_deg=args.max_d1_deg,
        max_d2_m=args.max_d2_m,
        shift_radius_px=args.shift_px,
        downsample=args.downsample,
        exhaustive=args.exhaustive,
        body_scale=args.body_scale,
        recovery_ratio=None if args.no_recovery else TrackerConfig.recovery_ratio,
        travel_tolerance_deg=None if args.no_travel_prior else TrackerConfig.travel_tolerance_deg,
        scale_from_top=args.scale_from_top,
        keypoints=not args.no_keypoints,
        joint_smooth_s=args.joint_smooth_s,
    )
    masks, fps, landmarks = _load_masks(args, calibration.cameras)
    dictionary = load_dictionary(args)
    if args.dictionary_out:
        dictionary.save(args.dictionary_out)
    tracker = SilhouetteTracker(
        dictionary, calibration.cameras, config=config, pairs=calibration.pairs
    )
    tracked = track_clip(tracker, masks, fps, args.estimate_fps, landmarks)
    result, step = tracked.result, tracked.frame_step
    entries, positions = tracked.entries, tracked.positions_m
    if args.reference:
        sequence = posture_sequence(read_motion(args.reference, args.asf))
        joint_ids = [dictionary.joint_names.index(n) for n in dictionary.vector_joints]
        reference = posture_vectors(sequence.local_rotations(), joint_ids)
        window = max(1, int(round(args.playback_window_s / sequence.frame_time_s)))
        frames = variable_speed_playback(
            reference, dictionary.vectors[entries], window_frames=window
        )
        headings = smooth_headings_deg(heading_deg(dictionary.world_rotations(entries)[:, 0]))
        motion = playback_motion(
            sequence, frames, positions, result.frame_time_s, headings, name="tracked"
        )
        joints = forward_kinematics(motion, ground=False).positions
        names = motion.skeleton.names
    else:
        fitted = tracked.fitted
        motion = dictionary.to_motion(
            entries,
            positions if fitted is None else positions + _root_shift(tracked),
            result.frame_time_s,
            scale=tracker.body_scale_,
            local_rotations=None if fitted is None else _held(fitted.local_rotations, tracked),
        )
        joints = tracked.joints_m
        names = dictionary.joint_names
    if args.bvh_out:
        write_bvh(motion, args.bvh_out)
    if args.joints_out:
        np.savez_compressed(
            args.joints_out,
            names=np.array(names),
            positions=joints.astype(np.float64),
            frame_time_s=np.float64(result.frame_time_s),
            frames=result.frames,
        )
    if args.overlay_out:
        write_video(_overlay_frames(args, tracker, tracked, masks), args.overlay_out, fps / step)
    print(
        f"tracked {result.n_estimates} frames of {len(masks[0])} ({fps:g} fps, every {step}): "
        f"{result.n_estimates / tracked.wall_s:.1f} estimates/s, "
        f"{result.n_evaluations[1:].mean() if result.n_estimates > 1 else 0:.1f} "
        f"postures scored per frame, dictionary of {len(dictionary)} postures",
        file=sys.stdout,
    )
    return 0
