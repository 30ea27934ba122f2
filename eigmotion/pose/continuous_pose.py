"""Continuous pose: the retrieved motion aligned to a single-camera clip frame by frame.

Retrieval answers a clip with a basic motion, the window of it that matched and the
view (azimuth, elevation) of the virtual camera that saw it like the clip's camera
sees the person.  The linear replay (:mod:`eigmotion.pose.replay`) stretches that window
over the clip; a person who speeds up or slows down is then out of step.  Here the
tracker's machinery aligns the motion to the clip instead (MISSION, "How the two
meet"):

1. **Dictionary.** The matched window and ``margin_s`` around it, on the avatar, at
   ``reference_fps``: entry ``i`` is reference frame ``i``
   (:func:`eigmotion.tracking.dictionary_from_sequences`, no pruning), posed on the
   low-poly body (:func:`eigmotion.tracking.avatar_bodies`).
2. **Virtual camera.** One camera at the matched view, aimed at the reference as the
   database build aimed its rig; its image is the clip's.  The person's apparent size
   and place are unknown: the camera's intrinsics are fitted so that the box around
   the reference's silhouettes over the matched window covers the box around the
   clip's silhouettes (a 2D scale and translation).
3. **Similarity.** A candidate (clip frame, reference frame) is the body in that
   reference posture, moved (not scaled) along the camera's axis until its silhouette
   has the clip frame's area and parallel to the image until the two centroids
   coincide, rendered inside the rectangle around the candidates and the observed
   silhouette, and scored with the tracker's similarity
   (:func:`eigmotion.tracking.score_masks`) maximised over small shifts and over 2D
   scales (``scales``) about the centroid.  Size and place thus come from each frame's
   silhouette: another performer does not follow the reference's path, and walking
   towards the camera changes the apparent size several tens of per cent.
4. **Variable-speed playback, solved for the whole clip.** Reference frames are chosen
   for all clip frames at once, maximising the summed similarity under the playback's
   rule: never back, at most ``max_speed`` times the clip's speed per frame (dynamic
   programming over (clip frame, reference frame)), with a small cost for playing at
   another speed than the reference's (``speed_weight``: a walk repeats itself, and a
   silhouette hardly tells the left leg from the right, so without it the playback
   may hold a posture for a step and catch up a cycle later).  A coarse pass (clip
   at ``coarse_fps``, every reference frame at ``coarse_reference_fps``) gives the
   path; the view is refined on it, first the azimuth then the elevation (the rig's
   cameras are tens of degrees apart; a clip filmed between them fits best a little
   off the matched view); a fine pass searches ``band_s`` around the coarse path at
   full rate.
5. **Output.** The chosen reference frames, lightly smoothed (still never back), are
   sampled from the reference (slerp) at the clip's frame rate, and the motion is
   turned so that the clip's camera stands at azimuth 0, as in :mod:`eigmotion.pose.replay`.

Why not :meth:`eigmotion.tracking.SilhouetteTracker.step`: it places the body where
the ray through the silhouette's centroid meets the plane of the body centre's height;
a level camera (elevation 0°, most rig views) looks along that plane, so the place is
undetermined.  Here size and place come from each silhouette, and the whole clip is
known, so the playback is solved over all frames rather than greedily.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from eigmotion.errors import InvalidParameterError, VideoError
from eigmotion.imaging.cameras import Camera, virtual_rig
from eigmotion.mocap.motion import Motion

if TYPE_CHECKING:
    from eigmotion.body.avatar import Avatar
    from eigmotion.pose.replay import Replay
    from eigmotion.retrieval.database import MotionDatabase
    from eigmotion.retrieval.results import QueryResult
    from eigmotion.tracking import PostureBodies


@dataclass(frozen=True)
class ContinuousPoseConfig:
    """How a retrieved motion is aligned to a clip.

    Parameters
    ----------
    margin_s : float
        Reference motion taken before and after the matched window, seconds (≥ 0).
    reference_fps : float or None
        Rate of the dictionary's frames, frames per second; ``None``: twice the clip's,
        at least 30.
    max_speed : float
        Largest speed of the playback relative to the reference (reference seconds per
        clip second), > 0; also the largest step per clip frame.
    speed_weight : float
        Cost per clip frame of playing at another speed than the reference's:
        ``speed_weight * |speed - 1|``, in similarity units (≥ 0).  Walking repeats
        itself and left and right legs look alike in a silhouette; without a prior the
        playback may hold a posture for a step and then catch up a cycle later.
    coarse_fps : float
        Clip frames per second scored in the coarse pass (> 0).
    coarse_reference_fps : float
        Reference frames per second scored in the coarse pass (> 0).
    band_s : float
        Fine pass: reference time searched either side of the coarse path, seconds.
    azimuth_search_deg : float
        The view's azimuth is searched within ± this of the matched one, degrees (0:
        keep the matched view).
    azimuth_step_deg : float
        Step of that search, degrees (> 0).
    elevation_search_deg, elevation_step_deg : float
        The same for the elevation, searched after the azimuth (a clip filmed from
        above or below the rig's rows), degrees.
    scales : tuple of float
        2D scales of the candidate silhouettes about the observed centroid.
    comparison_height_px : float
        Silhouettes are compared on a grid where the person is about this tall (the
        clip is block-averaged by an integer factor), pixels.
    shift_radius_px : int
        Shifts searched by the similarity, ± pixels of the comparison grid.
    smoothing_frames : int
        Width of the moving average applied to the chosen reference frames (1: none).
    min_silhouette_px : int
        A clip frame with fewer silhouette pixels carries no evidence.
    n_faces : int
        Triangles of the low-poly body that is rendered.
    """

    margin_s: float = 1.0
    reference_fps: float | None = None
    max_speed: float = 2.5
    speed_weight: float = 0.03
    coarse_fps: float = 10.0
    coarse_reference_fps: float = 15.0
    band_s: float = 0.3
    azimuth_search_deg: float = 30.0
    azimuth_step_deg: float = 7.5
    elevation_search_deg: float = 10.0
    elevation_step_deg: float = 5.0
    scales: tuple[float, ...] = (0.94, 1.0, 1.06)
    comparison_height_px: float = 64.0
    shift_radius_px: int = 3
    smoothing_frames: int = 5
    min_silhouette_px: int = 30
    n_faces: int = 4000

    def __post_init__(self):
        positive = (
            "max_speed",
            "coarse_fps",
            "coarse_reference_fps",
            "azimuth_step_deg",
            "elevation_step_deg",
            "comparison_height_px",
        )
        for name in positive:
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise InvalidParameterError(f"{name} must be > 0, got {value!r}")
        for name in (
            "margin_s",
            "band_s",
            "azimuth_search_deg",
            "elevation_search_deg",
            "speed_weight",
        ):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0):
                raise InvalidParameterError(f"{name} must be >= 0, got {value!r}")
        if self.reference_fps is not None and not (
            np.isfinite(self.reference_fps) and self.reference_fps > 0
        ):
            raise InvalidParameterError(
                f"reference_fps must be None or > 0, got {self.reference_fps!r}"
            )
        for name, low in (
            ("shift_radius_px", 0),
            ("smoothing_frames", 1),
            ("min_silhouette_px", 1),
            ("n_faces", 100),
        ):
            value = getattr(self, name)
            if int(value) != value or value < low:
                raise InvalidParameterError(f"{name} must be an integer >= {low}, got {value!r}")
        scales = tuple(float(s) for s in self.scales)
        if not scales or not all(np.isfinite(s) and 0.2 <= s <= 5.0 for s in scales):
            raise InvalidParameterError(f"scales must be factors in [0.2, 5], got {self.scales!r}")
        object.__setattr__(self, "scales", scales)


@dataclass(frozen=True, eq=False)
class ContinuousPose:
    """A retrieved motion aligned to a clip, one pose per clip frame.

    Attributes
    ----------
    motion : Motion
        On the avatar's canonical skeleton, metres (``length_unit_m = 1``), at the
        clip's frame rate and frame count, turned so that the clip's camera stands at
        azimuth 0 (on +Z, as in :mod:`eigmotion.pose.replay`); the root starts above the
        origin.
    reference_frames : (F,) int64
        The frame of the basic motion (its own frames and rate) each clip frame shows;
        non-decreasing, consecutive values at most :attr:`max_step_frames` apart.
    positions : (F, J, 3) float64
        World joint positions of :attr:`motion`, metres, Y up, floor at y = 0.
    names : tuple of str
        The ``J`` joint names.
    scores : (F,) float64
        Similarity of the chosen reference posture per clip frame, in [-1, 1] per
        scale (NaN where the clip frame shows no person).
    azimuth_deg, elevation_deg : float
        The view the motion was aligned under (the matched view, refined), degrees.
    matched_azimuth_deg, matched_elevation_deg : float
        The retrieved view, degrees.
    source_motion : str
        The basic motion's name.
    fps : float
        The clip's frame rate, frames per second.
    max_step_frames : int
        The playback's largest step between clip frames, in basic-motion frames
        (``max_speed`` times the clip's frame time, rounded up, plus one for rounding).
    timings_s : dict of str to float
        Wall time of each stage, seconds.
    """

    motion: Motion
    reference_frames: np.ndarray
    positions: np.ndarray
    names: tuple[str, ...]
    scores: np.ndarray
    azimuth_deg: float
    elevation_deg: float
    matched_azimuth_deg: float
    matched_elevation_deg: float
    source_motion: str
    fps: float
    max_step_frames: int
    timings_s: dict = field(default_factory=dict, repr=False)

    @property
    def n_frames(self) -> int:
        return len(self.reference_frames)

    def save_npz(self, path: str | os.PathLike) -> Path:
        """Write the joints per clip frame to an ``.npz`` file (at exactly ``path``).

        Keys: ``names (J,)`` str, ``positions (F, J, 3)`` float64 metres (Y up, floor
        y = 0, the clip's camera at azimuth 0), ``reference_frames (F,)`` int64 and
        ``fps`` float64 (the clip's frames per second).
        """
        path = Path(path)
        try:
            with path.open("wb") as fh:
                np.savez_compressed(
                    fh,
                    names=np.array(self.names, dtype=str),
                    positions=self.positions,
                    reference_frames=self.reference_frames,
                    fps=np.float64(self.fps),
                )
        except OSError as exc:
            raise InvalidParameterError(f"{path}: cannot write the pose: {exc.strerror}") from None
        return path

    def as_replay(self, avatar: Avatar | None = None) -> Replay:
        """The aligned motion skinned on the avatar (for :func:`eigmotion.pose.replay.
        replay_video`)."""
        from eigmotion.body.avatar import load_default_avatar
        from eigmotion.body.retarget import retarget
        from eigmotion.pose.replay import Replay

        avatar = avatar or load_default_avatar()
        anim = retarget(self.motion, avatar)
        return Replay(self.motion, avatar.pose(anim), avatar.faces, float(self.elevation_deg))


# -- the pieces --------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class _Reference:
    """The extended window on the avatar, frame ``i`` = dictionary entry ``i``."""

    on_avatar: Motion  # avatar skeleton, metres, reference_fps
    root_m: np.ndarray  # (R, 3) root positions, metres
    bodies: PostureBodies  # entry i = reference frame i, root at the origin
    first_source_frame: int
    source_per_reference: float  # source frames per reference frame
    window: tuple[int, int]  # matched window in reference frames

    @property
    def n_frames(self) -> int:
        return len(self.root_m)


def _reference(
    motion: Motion,
    window: tuple[int, int],
    reference_fps: float,
    margin_s: float,
    avatar: Avatar,
    n_faces: int,
) -> _Reference:
    """The matched window ± ``margin_s`` of ``motion`` on the avatar, resampled to
    ``reference_fps``, with the low-poly body posed in every frame."""
    from eigmotion.body.retarget import animation_to_motion, retarget
    from eigmotion.tracking import PostureSequence, avatar_bodies, dictionary_from_sequences

    start, stop = window
    margin = int(round(margin_s * motion.fps))
    lo, hi = max(0, start - margin), min(motion.n_frames, stop + margin)
    part = motion.trim(lo, hi).resample(reference_fps)
    anim = retarget(part, avatar)
    sequence = PostureSequence(
        tuple(avatar.joint_names),
        np.asarray(avatar.parents),
        np.asarray(avatar.joint_positions, dtype=np.float64),
        np.asarray(anim.joint_rotations, dtype=np.float64),
        np.asarray(anim.joint_positions[:, 0], dtype=np.float64),
        float(anim.frame_time_s),
        motion.name,
    )
    dictionary = dictionary_from_sequences([sequence], threshold_deg=0.0)
    bodies = avatar_bodies(dictionary, avatar, n_faces)
    per = motion.fps / reference_fps
    w0 = int(np.clip(round((start - lo) / per), 0, part.n_frames - 1))
    w1 = int(np.clip(round((stop - lo) / per), w0 + 1, part.n_frames))
    return _Reference(
        animation_to_motion(anim, avatar),
        sequence.root_positions,
        bodies,
        lo,
        per,
        (w0, w1),
    )


@dataclass(frozen=True, eq=False)
class _Observed:
    """Per clip frame: the silhouette's box, centroid and whether it holds a person."""

    masks: np.ndarray  # (F, H, W) bool
    present: np.ndarray  # (F,) bool
    centroids_px: np.ndarray  # (F, 2) (u, v), NaN where absent
    boxes_px: np.ndarray  # (F, 4) x0, y0, x1, y1 (inclusive), NaN where absent
    areas_px: np.ndarray  # (F,) silhouette pixels


def _observe(masks: np.ndarray, min_px: int) -> _Observed:
    """What the tracker needs of each clip frame's silhouette (``VideoError`` if no
    frame shows a person)."""
    n = len(masks)
    present = np.zeros(n, dtype=bool)
    centroids = np.full((n, 2), np.nan)
    boxes = np.full((n, 4), np.nan)
    for f, mask in enumerate(masks):
        ys, xs = np.nonzero(mask)
        if len(xs) < min_px:
            continue
        present[f] = True
        centroids[f] = xs.mean(), ys.mean()
        boxes[f] = xs.min(), ys.min(), xs.max(), ys.max()
    if not present.any():
        raise VideoError(
            f"no clip frame shows a silhouette of at least {min_px} pixels: nothing to align"
        )
    return _Observed(masks, present, centroids, boxes, masks.sum(axis=(1, 2)).astype(np.float64))


def _fitted_camera(
    reference: _Reference,
    observed: _Observed,
    azimuth_deg: float,
    elevation_deg: float,
    yfov_deg: float,
) -> Camera:
    """The virtual camera at a view, its intrinsics fitted to the clip's silhouettes.

    The camera is aimed at the whole reference as the build aims its rig; then a 2D
    scale (from the boxes' heights) and translation (their centres) map the box
    around the reference's silhouettes over the matched window onto the box around
    all of the clip's silhouettes.
    """
    from eigmotion.retrieval.build import hull_points

    height, width = observed.masks.shape[1:]
    every = max(1, reference.n_frames // 40)
    verts = reference.bodies.vertices(np.arange(0, reference.n_frames, every), np.zeros(3))
    verts = verts + reference.root_m[::every, None, :].astype(np.float32)
    cam = virtual_rig([azimuth_deg], [elevation_deg], width, height, yfov_deg).fitted(
        hull_points(verts)
    )[0]
    w0, w1 = reference.window
    step = max(1, (w1 - w0) // 30)
    frames = np.arange(w0, w1, step)
    window_verts = reference.bodies.vertices(frames, np.zeros(3))[:, ::4]
    window_verts = window_verts + reference.root_m[frames, None, :].astype(np.float32)
    px, _ = cam.project(window_verts.reshape(-1, 3))
    ref_box = np.array([px[:, 0].min(), px[:, 1].min(), px[:, 0].max(), px[:, 1].max()])
    boxes = observed.boxes_px[observed.present]
    obs_box = np.array(
        [boxes[:, 0].min(), boxes[:, 1].min(), boxes[:, 2].max() + 1, boxes[:, 3].max() + 1]
    )
    scale = (obs_box[3] - obs_box[1]) / max(ref_box[3] - ref_box[1], 1e-6)
    ref_centre = 0.5 * (ref_box[:2] + ref_box[2:])
    obs_centre = 0.5 * (obs_box[:2] + obs_box[2:])
    K = cam.K.copy()
    K[0, 0] *= scale
    K[1, 1] *= scale
    K[:2, 2] = obs_centre + scale * (K[:2, 2] - ref_centre)
    return Camera(K, cam.R, cam.t, width, height, cam.name, azimuth_deg, elevation_deg)


class _Scorer:
    """Similarity of reference frames against clip frames, under one virtual camera.

    Calling it with a clip frame and (M,) reference frames returns their (M,) scores.
    """

    def __init__(
        self,
        reference: _Reference,
        observed: _Observed,
        camera: Camera,
        config: ContinuousPoseConfig,
    ):
        self.reference = reference
        self.observed = observed
        self.camera = camera
        self.config = config
        boxes = observed.boxes_px[observed.present]
        person_px = float(np.median(boxes[:, 3] - boxes[:, 1] + 1))
        self.downsample = max(1, int(person_px // config.comparison_height_px))
        self.centroid_offsets_px, self.sizes_px = self._silhouette_facts()

    def _silhouette_facts(self) -> tuple[np.ndarray, np.ndarray]:
        """Each reference frame's silhouette at its place on the reference's path.

        Returns
        -------
        centroid_offsets_px : (R, 2) float64
            Silhouette centroid minus the root's projection, full-resolution pixels.
        sizes_px : (R,) float64
            Square root of the silhouette's area, full-resolution pixels (1 if empty).
        """
        from eigmotion.imaging.silhouettes import render_masks

        ref, cam = self.reference, self.camera
        offsets = np.zeros((ref.n_frames, 2))
        sizes = np.ones(ref.n_frames)
        root_px, _ = cam.project(ref.root_m)
        u = np.arange(cam.width, dtype=np.float64)
        v = np.arange(cam.height, dtype=np.float64)
        for lo in range(0, ref.n_frames, 64):
            entries = np.arange(lo, min(lo + 64, ref.n_frames))
            verts = ref.bodies.vertices(entries, np.zeros(3))
            verts += ref.root_m[entries, None, :].astype(np.float32)
            masks = render_masks(verts, ref.bodies.faces, cam)
            area = masks.sum(axis=(1, 2)).astype(np.float64)
            seen = area > 0
            safe = np.where(seen, area, 1.0)
            centroid = np.stack([masks.sum(axis=1) @ u, masks.sum(axis=2) @ v], axis=1)
            offsets[entries] = np.where(
                seen[:, None], centroid / safe[:, None] - root_px[entries], 0.0
            )
            sizes[entries] = np.where(seen, np.sqrt(safe), 1.0)
        return offsets, sizes

    def placed_vertices(self, frame: int, entries: np.ndarray) -> np.ndarray:
        """(M, V, 3) float32 candidate meshes placed for a clip frame, metres.

        Each posture is moved (not scaled) along the camera's axis until its
        silhouette's area is the clip frame's, and parallel to the image until its
        silhouette's centroid falls on the clip frame's: the person's distance and
        size are unknown, and another performance does not follow the reference's
        path.  The area, unlike the height, hardly depends on the posture (a raised
        arm, a body lying on the floor).
        """
        ref, cam = self.reference, self.camera
        magnify = np.sqrt(self.observed.areas_px[frame]) / self.sizes_px[entries]
        depth_m = cam.to_camera(ref.root_m[entries])[:, 2] / magnify
        root_px = (
            self.observed.centroids_px[frame] - magnify[:, None] * self.centroid_offsets_px[entries]
        )
        root_cam = np.stack(
            [
                (root_px[:, 0] - cam.cx) * depth_m / cam.fx,
                (root_px[:, 1] - cam.cy) * depth_m / cam.fy,
                depth_m,
            ],
            axis=1,
        )
        verts = ref.bodies.vertices(entries, np.zeros(3))
        verts += ((root_cam - cam.t) @ cam.R)[:, None, :].astype(np.float32)
        return verts

    def __call__(self, frame: int, entries: np.ndarray) -> np.ndarray:
        """(M,) float64: each entry's best similarity over shifts and scales (0 for a
        clip frame without a person)."""
        from eigmotion.imaging.silhouettes import render_masks
        from eigmotion.tracking import score_masks
        from eigmotion.tracking.similarity import view_window

        entries = np.asarray(entries, dtype=np.int64).reshape(-1)
        if not self.observed.present[frame] or len(entries) == 0:
            return np.zeros(len(entries))
        cfg, cam = self.config, self.camera
        verts = self.placed_vertices(frame, entries)
        centre = self.observed.centroids_px[frame]
        lo, hi = verts.min(axis=1), verts.max(axis=1)
        corners = np.concatenate(
            [np.where(np.array(bits, bool), hi, lo) for bits in np.ndindex(2, 2, 2)]
        )
        corners_px, _ = cam.project(corners.astype(np.float64))
        x0, y0, x1, y1 = self.observed.boxes_px[frame]
        points = np.concatenate(
            [centre + s * (corners_px - centre) for s in cfg.scales] + [[[x0, y0], [x1, y1]]]
        )
        margin_px = (cfg.shift_radius_px + 1) * self.downsample
        try:
            window = view_window(cam, points, margin_px, self.downsample)
        except InvalidParameterError:  # nothing of it inside the image
            return np.zeros(len(entries))
        observed = window.crop(self.observed.masks[frame])
        best = np.full(len(entries), -np.inf)
        for s in cfg.scales:
            camera = window.window_camera(s, centre)
            rendered = render_masks(verts, self.reference.bodies.faces, camera)
            scores, _ = score_masks(observed, rendered, cfg.shift_radius_px)
            best = np.maximum(best, scores)
        return best


def monotone_path(
    scores: np.ndarray, max_step: int, step_costs: np.ndarray | None = None
) -> np.ndarray:
    """The best non-decreasing path through a score matrix (variable-speed playback).

    Parameters
    ----------
    scores : (F, R) float
        Score of showing reference frame ``r`` at clip frame ``f`` (higher is better;
        ``-inf``: not allowed).
    max_step : int
        Largest step ``r[f + 1] - r[f]``, ≥ 1.
    step_costs : (max_step + 1,) float, optional
        Cost subtracted for each step of ``k`` frames (a prior on the speed); default
        none.

    Returns
    -------
    (F,) int64
        ``r[f]``, non-decreasing, steps at most ``max_step``, maximising
        ``sum_f scores[f, r[f]] - sum_f step_costs[r[f + 1] - r[f]]`` (ties: the
        smaller step).
    """
    scores = np.asarray(scores, dtype=np.float64)
    if scores.ndim != 2 or scores.shape[0] == 0 or scores.shape[1] == 0:
        raise InvalidParameterError(f"scores must be a non-empty (F, R) array, got {scores.shape}")
    if int(max_step) != max_step or max_step < 1:
        raise InvalidParameterError(f"max_step must be an integer >= 1, got {max_step!r}")
    max_step = int(max_step)
    if step_costs is None:
        costs = np.zeros(max_step + 1)
    else:
        costs = np.asarray(step_costs, dtype=np.float64).reshape(-1)
        if costs.shape != (max_step + 1,) or not np.all(np.isfinite(costs)):
            raise InvalidParameterError(
                f"step_costs must be {max_step + 1} finite numbers, got shape {costs.shape}"
            )
    n_f, n_r = scores.shape
    total = scores[0].copy()
    back = np.zeros((n_f, n_r), dtype=np.int64)
    idx = np.arange(n_r)
    for f in range(1, n_f):
        best = total - costs[0]
        arg = idx.copy()
        for k in range(1, min(max_step, n_r - 1) + 1):
            shifted = np.full(n_r, -np.inf)
            shifted[k:] = total[:-k] - costs[k]
            better = shifted > best
            best[better] = shifted[better]
            arg[better] = idx[better] - k
        total = best + scores[f]
        back[f] = arg
    if not np.isfinite(total).any():
        raise InvalidParameterError("no path through the allowed reference frames")
    path = np.empty(n_f, dtype=np.int64)
    path[-1] = int(np.argmax(total))
    for f in range(n_f - 1, 0, -1):
        path[f - 1] = back[f, path[f]]
    return path


def speed_costs(max_step: int, unit_step: float, weight: float) -> np.ndarray:
    """(max_step + 1,) float64: ``weight * |k / unit_step - 1|`` for steps ``k``.

    The playback's prior: the person moves at the reference's speed (a step of
    ``unit_step`` reference frames per clip frame), and every departure from it costs
    in proportion.
    """
    k = np.arange(int(max_step) + 1, dtype=np.float64)
    return float(weight) * np.abs(k / float(unit_step) - 1.0)


def _coarse_path(
    scorer: _Scorer, fps: float, reference_fps: float
) -> tuple[np.ndarray, np.ndarray]:
    """Clip frames sampled at ``coarse_fps`` and their reference frames (every
    reference frame at ``coarse_reference_fps`` scored)."""
    cfg = scorer.config
    n_clip = len(scorer.observed.masks)
    clip_step = max(1, int(round(fps / cfg.coarse_fps)))
    ref_step = max(1, int(round(reference_fps / cfg.coarse_reference_fps)))
    frames = np.arange(0, n_clip, clip_step)
    if frames[-1] != n_clip - 1:
        frames = np.append(frames, n_clip - 1)
    entries = np.arange(0, scorer.reference.n_frames, ref_step)
    matrix = np.stack([scorer(int(f), entries) for f in frames])
    unit = clip_step / fps * reference_fps / ref_step
    max_step = max(1, int(np.ceil(cfg.max_speed * unit)))
    costs = speed_costs(max_step, unit, cfg.speed_weight)
    return frames, entries[monotone_path(matrix, max_step, costs)]


def _path_score(scorer: _Scorer, frames: np.ndarray, path: np.ndarray) -> float:
    return float(sum(scorer(int(f), np.array([r]))[0] for f, r in zip(frames, path, strict=True)))


def _fine_path(
    scorer: _Scorer,
    coarse_frames: np.ndarray,
    coarse_path: np.ndarray,
    fps: float,
    reference_fps: float,
    max_step: int,
) -> tuple[np.ndarray, np.ndarray]:
    """Every clip frame, reference frames within ``band_s`` of the coarse path.

    Returns the (F,) reference frame per clip frame and its (F,) score (NaN where the
    clip frame shows no person)."""
    cfg = scorer.config
    n_clip = len(scorer.observed.masks)
    n_ref = scorer.reference.n_frames
    guess = np.interp(np.arange(n_clip), coarse_frames, coarse_path)
    band = max(1, int(np.ceil(cfg.band_s * reference_fps)))
    matrix = np.full((n_clip, n_ref), -np.inf)
    for f in range(n_clip):
        lo = max(0, int(np.floor(guess[f])) - band)
        hi = min(n_ref, int(np.ceil(guess[f])) + band + 1)
        entries = np.arange(lo, hi)
        matrix[f, lo:hi] = scorer(f, entries)
    unit = reference_fps / fps
    path = monotone_path(matrix, max_step, speed_costs(max_step, unit, cfg.speed_weight))
    scores = matrix[np.arange(n_clip), path]
    scores[~scorer.observed.present] = np.nan
    return path, scores


def _smooth_path(path: np.ndarray, width: int) -> np.ndarray:
    """(F,) float64 moving average (edges held), still non-decreasing."""
    path = np.asarray(path, dtype=np.float64)
    if width <= 1 or len(path) < 2:
        return path
    kernel = np.ones(width) / width
    padded = np.pad(path, (width // 2, width - 1 - width // 2), mode="edge")
    return np.convolve(padded, kernel, mode="valid")


def _sample(motion: Motion, frames: np.ndarray, frame_time_s: float) -> Motion:
    """The motion at fractional frames (slerp rotations, lerp translations)."""
    from eigmotion.mocap.rotations import slerp_matrices

    frames = np.clip(np.asarray(frames, dtype=np.float64), 0, motion.n_frames - 1)
    i0 = np.floor(frames).astype(np.int64)
    i1 = np.minimum(i0 + 1, motion.n_frames - 1)
    w = frames - i0
    rot = motion.local_rotations()
    trans = motion.local_translations()
    j = motion.skeleton.n_joints
    r = slerp_matrices(
        rot[i0].reshape(-1, 3, 3), rot[i1].reshape(-1, 3, 3), np.repeat(w, j)
    ).reshape(len(frames), j, 3, 3)
    t = trans[i0] * (1 - w)[:, None, None] + trans[i1] * w[:, None, None]
    return motion.with_local_transforms(r, t, frame_time_s=frame_time_s)


def _offsets(search_deg: float, step_deg: float) -> np.ndarray:
    """Offsets ``0, ±step, ±2 step … within ±search``, nearest first, degrees."""
    n = int(np.floor(search_deg / step_deg + 1e-9))
    offsets = np.arange(-n, n + 1) * step_deg
    return offsets[np.argsort(np.abs(offsets), kind="stable")]


# -- the stage ---------------------------------------------------------------------


def align_motion(
    motion: Motion,
    window: tuple[int, int],
    azimuth_deg: float,
    elevation_deg: float,
    masks: np.ndarray,
    fps: float,
    config: ContinuousPoseConfig | None = None,
    avatar: Avatar | None = None,
    yfov_deg: float = 40.0,
) -> ContinuousPose:
    """Align a known motion to a single-camera clip, frame by frame.

    Parameters
    ----------
    motion : Motion
        The basic motion (any skeleton the avatar can be driven by).
    window : (int, int)
        ``[start, stop)`` frames of ``motion`` that matched the clip.
    azimuth_deg, elevation_deg : float
        The matched virtual camera's view of the motion, degrees.
    masks : (F, H, W) bool
        The clip's silhouettes.
    fps : float
        The clip's frame rate, frames per second.
    config : ContinuousPoseConfig, optional
    avatar : Avatar, optional
        Default :func:`eigmotion.body.avatar.load_default_avatar`.
    yfov_deg : float
        Vertical field of view of the virtual camera, degrees (the database rig's
        lens; the clip camera's is unknown and matters little).

    Returns
    -------
    ContinuousPose
    """
    import time

    from eigmotion.mocap.kinematics import forward_kinematics
    from eigmotion.pose.replay import turn_about_vertical

    config = config or ContinuousPoseConfig()
    masks = np.asarray(masks)
    if masks.ndim != 3 or masks.shape[0] < 1:
        raise InvalidParameterError(f"masks must be a non-empty (F, H, W) array, got {masks.shape}")
    masks = masks.astype(bool, copy=False)
    if not (np.isfinite(fps) and fps > 0):
        raise InvalidParameterError(f"fps must be > 0, got {fps!r}")
    start, stop = int(window[0]), int(window[1])
    if not 0 <= start < stop <= motion.n_frames:
        raise InvalidParameterError(
            f"window [{start}, {stop}) is outside motion {motion.name!r} of "
            f"{motion.n_frames} frames"
        )
    if not (np.isfinite(azimuth_deg) and np.isfinite(elevation_deg) and -89 <= elevation_deg <= 89):
        raise InvalidParameterError(
            f"view must be a finite azimuth and an elevation in [-89, 89], got "
            f"({azimuth_deg!r}, {elevation_deg!r})"
        )
    if avatar is None:
        from eigmotion.body.avatar import load_default_avatar

        avatar = load_default_avatar()
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    reference_fps = config.reference_fps or max(2.0 * fps, 30.0)
    reference = _reference(
        motion, (start, stop), reference_fps, config.margin_s, avatar, config.n_faces
    )
    observed = _observe(masks, config.min_silhouette_px)
    t1 = time.perf_counter()
    timings["reference"] = t1 - t0

    def scorer_at(view: tuple[float, float]) -> _Scorer:
        camera = _fitted_camera(reference, observed, view[0], view[1], yfov_deg)
        return _Scorer(reference, observed, camera, config)

    matched = (float(azimuth_deg), float(elevation_deg))
    scorer = scorer_at(matched)
    coarse_frames, coarse = _coarse_path(scorer, fps, reference_fps)
    t2 = time.perf_counter()
    timings["coarse"] = t2 - t1
    view = _refine_view(scorer_at, matched, coarse_frames, coarse, config)
    if view != matched:
        scorer = scorer_at(view)
    t3 = time.perf_counter()
    timings["view"] = t3 - t2
    max_step = max(1, int(np.ceil(config.max_speed * reference_fps / fps)))
    path, scores = _fine_path(scorer, coarse_frames, coarse, fps, reference_fps, max_step)
    t4 = time.perf_counter()
    timings["fine"] = t4 - t3

    frames = _smooth_path(path, config.smoothing_frames)
    aligned = _sample(reference.on_avatar, frames, 1.0 / fps)
    aligned = turn_about_vertical(aligned, -view[0]).replace(
        name=f"{motion.name}_aligned", length_unit_m=1.0
    )
    source = reference.first_source_frame + np.round(frames * reference.source_per_reference)
    source = np.maximum.accumulate(np.clip(source.astype(np.int64), 0, motion.n_frames - 1))
    positions = forward_kinematics(aligned, length_unit_m=1.0, ground=False).positions
    timings["total"] = time.perf_counter() - t0
    return ContinuousPose(
        motion=aligned,
        reference_frames=source,
        positions=positions,
        names=tuple(aligned.skeleton.names),
        scores=scores,
        azimuth_deg=view[0],
        elevation_deg=view[1],
        matched_azimuth_deg=matched[0],
        matched_elevation_deg=matched[1],
        source_motion=motion.name,
        fps=float(fps),
        max_step_frames=int(np.ceil(max_step * reference.source_per_reference)) + 1,
        timings_s=timings,
    )


def _refine_view(
    scorer_at,
    matched: tuple[float, float],
    frames: np.ndarray,
    path: np.ndarray,
    config: ContinuousPoseConfig,
) -> tuple[float, float]:
    """The view, near the matched one, under which a path's postures score best:
    the azimuth first, then the elevation (degrees)."""
    view = matched
    for axis, search, step in (
        (0, config.azimuth_search_deg, config.azimuth_step_deg),
        (1, config.elevation_search_deg, config.elevation_step_deg),
    ):
        best, best_score = view, -np.inf
        for offset in _offsets(search, step):
            trial = list(view)
            trial[axis] += float(offset)
            if not -89.0 <= trial[1] <= 89.0:
                continue
            total = _path_score(scorer_at((trial[0], trial[1])), frames, path)
            if total > best_score + 1e-9:
                best, best_score = (trial[0], trial[1]), total
        view = best
    return view


def continuous_pose(
    db: MotionDatabase,
    result: QueryResult,
    masks: np.ndarray,
    fps: float,
    config: ContinuousPoseConfig | None = None,
    avatar: Avatar | None = None,
) -> ContinuousPose:
    """The best match of a query, aligned to its clip frame by frame.

    Parameters
    ----------
    db : MotionDatabase
        The database that answered (gives the motion and its rig's lens).
    result : QueryResult
        Its answer (:meth:`MotionDatabase.query_masks` or ``query_clip``).
    masks : (F, H, W) bool
        The clip's silhouettes.
    fps : float
        The clip's frame rate, frames per second.
    config : ContinuousPoseConfig, optional
    avatar : Avatar, optional

    Returns
    -------
    ContinuousPose
    """
    best = result.best
    yfov_deg = float(np.rad2deg(db.rig[0].yfov_rad))
    return align_motion(
        db.motion(best.motion_id),
        best.window,
        best.azimuth_deg,
        best.elevation_deg,
        masks,
        fps,
        config,
        avatar,
        yfov_deg,
    )
