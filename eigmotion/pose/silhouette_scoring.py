"""Silhouettes of a reference motion scored against a clip's, under one virtual camera.

The pieces of :mod:`eigmotion.pose.continuous_pose`: the matched window of the basic
motion on the avatar (:func:`reference_window`), what each clip frame's silhouette
tells (:func:`observe_silhouettes`), the virtual camera fitted to the clip
(:func:`fitted_camera`) and the similarity of (clip frame, reference frame) pairs
(:class:`SilhouetteScorer`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from eigmotion.body.avatar import Avatar
from eigmotion.body.retarget import animation_to_motion, retarget
from eigmotion.errors import InvalidParameterError, VideoError
from eigmotion.imaging.cameras import Camera, virtual_rig
from eigmotion.imaging.silhouettes import render_masks
from eigmotion.mocap.motion import Motion
from eigmotion.retrieval.library_views import hull_points
from eigmotion.tracking.body import PostureBodies, avatar_bodies
from eigmotion.tracking.dictionary import PostureSequence, dictionary_from_sequences
from eigmotion.tracking.similarity import score_masks, view_window


@dataclass(frozen=True, eq=False)
class ReferenceWindow:
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


def reference_window(
    motion: Motion,
    window: tuple[int, int],
    reference_fps: float,
    margin_s: float,
    avatar: Avatar,
    n_faces: int,
) -> ReferenceWindow:
    """The matched window ± ``margin_s`` of ``motion`` on the avatar, resampled to
    ``reference_fps``, with the low-poly body posed in every frame."""
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
    return ReferenceWindow(
        animation_to_motion(anim, avatar),
        sequence.root_positions,
        bodies,
        lo,
        per,
        (w0, w1),
    )


@dataclass(frozen=True, eq=False)
class ObservedSilhouettes:
    """Per clip frame: the silhouette's box, centroid and whether it holds a person."""

    masks: np.ndarray  # (F, H, W) bool
    present: np.ndarray  # (F,) bool
    centroids_px: np.ndarray  # (F, 2) (u, v), NaN where absent
    boxes_px: np.ndarray  # (F, 4) x0, y0, x1, y1 (inclusive), NaN where absent
    areas_px: np.ndarray  # (F,) silhouette pixels


def observe_silhouettes(masks: np.ndarray, min_px: int) -> ObservedSilhouettes:
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
    return ObservedSilhouettes(
        masks, present, centroids, boxes, masks.sum(axis=(1, 2)).astype(np.float64)
    )


def fitted_camera(
    reference: ReferenceWindow,
    observed: ObservedSilhouettes,
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


class SilhouetteScorer:
    """Similarity of reference frames against clip frames, under one virtual camera.

    Calling it with a clip frame and (M,) reference frames returns their (M,) scores.

    Parameters
    ----------
    reference : ReferenceWindow
    observed : ObservedSilhouettes
    camera : Camera
        The virtual camera, fitted to the clip (:func:`fitted_camera`).
    scales : tuple of float
        2D scales of the candidate silhouettes about the observed centroid.
    shift_radius_px : int
        Shifts searched by the similarity, ± pixels of the comparison grid.
    comparison_height_px : float
        Silhouettes are compared on a grid where the person is about this tall (the
        clip is block-averaged by an integer factor), pixels.
    """

    def __init__(
        self,
        reference: ReferenceWindow,
        observed: ObservedSilhouettes,
        camera: Camera,
        scales: tuple[float, ...],
        shift_radius_px: int,
        comparison_height_px: float,
    ):
        self.reference = reference
        self.observed = observed
        self.camera = camera
        self.scales = scales
        self.shift_radius_px = shift_radius_px
        boxes = observed.boxes_px[observed.present]
        person_px = float(np.median(boxes[:, 3] - boxes[:, 1] + 1))
        self.downsample = max(1, int(person_px // comparison_height_px))
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
        entries = np.asarray(entries, dtype=np.int64).reshape(-1)
        if not self.observed.present[frame] or len(entries) == 0:
            return np.zeros(len(entries))
        cam = self.camera
        verts = self.placed_vertices(frame, entries)
        centre = self.observed.centroids_px[frame]
        lo, hi = verts.min(axis=1), verts.max(axis=1)
        corners = np.concatenate(
            [np.where(np.array(bits, bool), hi, lo) for bits in np.ndindex(2, 2, 2)]
        )
        corners_px, _ = cam.project(corners.astype(np.float64))
        x0, y0, x1, y1 = self.observed.boxes_px[frame]
        points = np.concatenate(
            [centre + s * (corners_px - centre) for s in self.scales] + [[[x0, y0], [x1, y1]]]
        )
        margin_px = (self.shift_radius_px + 1) * self.downsample
        try:
            window = view_window(cam, points, margin_px, self.downsample)
        except InvalidParameterError:  # nothing of it inside the image
            return np.zeros(len(entries))
        observed = window.crop(self.observed.masks[frame])
        best = np.full(len(entries), -np.inf)
        for s in self.scales:
            camera = window.window_camera(s, centre)
            rendered = render_masks(verts, self.reference.bodies.faces, camera)
            scores, _ = score_masks(observed, rendered, self.shift_radius_px)
            best = np.maximum(best, scores)
        return best
