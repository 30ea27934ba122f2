"""Scores of dictionary entries against one frame's silhouettes (the tracker's inner
loop): candidates rendered inside the rectangles ``R(c)`` at a reduced resolution,
compared with the observed silhouettes over small shifts (and 2D scales), less the
direction-of-travel penalty; the best shifts refine the body-centre position.
"""

from __future__ import annotations

import numpy as np

from eigmotion.errors import VideoError
from eigmotion.tracking.position import intersect_plane_lines
from eigmotion.tracking.similarity import ViewWindow, score_masks, view_window


class FrameScorer:
    """Scores of dictionary entries against one frame's silhouettes.

    Holds the rectangles ``R(c)`` (fitted to a pool of candidate entries at the
    tracker's current body scale) and the observed silhouettes sampled in them.
    Calling it with (M,) entries returns their (M,) scores (the search functions'
    interface: the similarity summed over cameras, less the tracker's
    direction-of-travel penalty) and records each entry's best shifts in :attr:`detail`.
    """

    def __init__(self, tracker, masks, used, position, pool):
        cfg = tracker.config
        self.tracker = tracker
        self.used = list(used)
        self.position = np.asarray(position, dtype=np.float64)
        self.body_scale = float(tracker.body_scale_)
        self.detail: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        heights = tracker.dictionary.body_height_m
        root = np.zeros((len(pool), 1, 3))
        root[:, 0, [0, 2]] = self.position[[0, 2]]
        root[:, 0, 1] = self.body_scale * heights[pool]
        corners = tracker.bodies.box_corners(pool, np.zeros(3), self.body_scale) + root
        corners = corners.reshape(-1, 3)
        self.windows: list[ViewWindow] = []
        self.observed: list[np.ndarray] = []
        self.centers: list[np.ndarray] = []
        for c in self.used:
            cam = tracker.cameras[c]
            px, depth = cam.project(corners)
            center, _ = cam.project(self.position[None])
            pts = px[depth > 0]
            if len(pts) == 0:
                raise VideoError(f"camera {cam.name!r}: the person's position is behind it")
            pts = np.concatenate([center + s * (pts - center) for s in cfg.scales])
            window = view_window(cam, pts, cfg.shift_radius_px + 1, cfg.downsample)
            self.windows.append(window)
            self.observed.append(window.crop(masks[c]))
            self.centers.append(center[0])
        self.radius = -(-cfg.shift_radius_px // cfg.downsample)

    def root_positions(self, entries: np.ndarray, body_scale: float) -> np.ndarray:
        """(M, 3): each entry's body centre: at G horizontally, its own height."""
        root = np.repeat(self.position[None], len(entries), axis=0)
        root[:, 1] = body_scale * self.tracker.dictionary.body_height_m[entries]
        return root

    def __call__(self, entries: np.ndarray) -> np.ndarray:
        """(M,) float64 similarity ``s(m)`` of entries."""
        tracker, cfg = self.tracker, self.tracker.config
        body_scale = self.body_scale
        entries = np.asarray(entries, dtype=np.int64)
        verts = tracker.bodies.vertices(entries, np.zeros(3), body_scale)
        verts += self.root_positions(entries, body_scale)[:, None, :].astype(np.float32)
        total = np.zeros(len(entries))
        shifts = np.zeros((len(entries), len(self.used), 2))
        scales = np.ones((len(entries), len(self.used)))
        views = zip(self.windows, self.observed, self.centers, strict=True)
        for k, (window, obs, center) in enumerate(views):
            best = np.full(len(entries), -np.inf)
            for s in cfg.scales:
                rendered = tracker.render_masks(
                    verts, tracker.bodies.faces, window.window_camera(s, center)
                )
                sc, sh = score_masks(obs, rendered, self.radius)
                better = sc > best
                best[better] = sc[better]
                shifts[better, k] = sh[better] * cfg.downsample
                scales[better, k] = s
            total += best
        total -= tracker.travel_penalty(entries)
        for i, e in enumerate(entries.tolist()):
            self.detail[e] = (shifts[i], scales[i])
        return total

    def refined_position(self, entry: int, shifts_px: np.ndarray) -> np.ndarray:
        """(3,) the body centre moved by the best shifts: new rays, new intersection."""
        root = self.root_positions(np.array([entry]), self.body_scale)[0]
        cams = [self.tracker.cameras[c] for c in self.used]
        pixels = np.stack([cam.project(root[None])[0][0] for cam in cams]) + shifts_px
        return intersect_plane_lines(cams, pixels, float(root[1]), root)
