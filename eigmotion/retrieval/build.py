"""Building a motion database, and storing a motion's renderings in one.

Steps 4–6 of the retrieval engine put together: :func:`build_database` renders the
library through the rig (:func:`~eigmotion.retrieval.library_views.render_views`), fits the
eigenspace (:mod:`eigmotion.retrieval.eigenspace`) and the pose eigenspace of the
silhouette sequences, cuts the keys (:mod:`eigmotion.retrieval.keys`), calibrates the
"unknown" threshold (:mod:`eigmotion.retrieval.calibration`) and writes everything
through :class:`~eigmotion.retrieval.store.Store` in one transaction.
:meth:`MotionDatabase.index_motion <eigmotion.retrieval.database.MotionDatabase.index_motion>`
stores a further motion with the same helpers (:class:`CollectedViews`,
:func:`store_motion`, :func:`store_sequences`).
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np

from eigmotion.errors import InvalidParameterError
from eigmotion.imaging.cameras import CameraRig, rig_to_plain
from eigmotion.mocap.bvh import format_bvh
from eigmotion.mocap.library import LibraryMotion
from eigmotion.retrieval.calibration import (
    calibration_quantiles,
    leave_one_motion_out_distances,
    threshold_from_distances,
)
from eigmotion.retrieval.eigenspace import Eigenspace
from eigmotion.retrieval.keys import Quantizer
from eigmotion.retrieval.library_views import BuildConfig, ViewImages, render_views
from eigmotion.retrieval.results import BuildReport
from eigmotion.retrieval.sequences import fit_pose_space, pose_coordinates
from eigmotion.retrieval.storage import DEFAULT_DB_PATH, check_target, replacing
from eigmotion.retrieval.store import Store


@dataclass
class CollectedViews:
    """The motion images and silhouette sequences of renderings, gathered view by view
    (:meth:`add`) and handed over as arrays (:meth:`arrays`)."""

    vectors: list = field(default_factory=list)
    motion: list = field(default_factory=list)
    body: list = field(default_factory=list)
    azimuth: list = field(default_factory=list)
    elevation: list = field(default_factory=list)
    start: list = field(default_factory=list)
    stop: list = field(default_factory=list)
    labels: list = field(default_factory=list)
    #: (motion index, azimuth, elevation, (F, SEQUENCE_SIZE**2 + 1) frames) per rendering
    sequences: list = field(default_factory=list)

    def add(self, view: ViewImages, rig: CameraRig) -> None:
        """Gather one rendering (``view``) seen by its camera of ``rig``."""
        n = len(view.vectors)
        cam = rig[view.view_index]
        if len(view.sequence):
            self.sequences.append(
                (view.motion_index, cam.azimuth_deg, cam.elevation_deg, view.sequence)
            )
        self.vectors.append(view.vectors)
        self.motion += [view.motion_index] * n
        self.body += [view.shape_index] * n
        self.azimuth += [cam.azimuth_deg] * n
        self.elevation += [cam.elevation_deg] * n
        self.start += view.windows[:, 0].tolist()
        self.stop += view.windows[:, 1].tolist()
        self.labels += view.labels

    def arrays(self):
        """``(vectors (N, D) float32, *columns)``: every motion image gathered, one row
        each, then :meth:`columns`."""
        return (np.concatenate(self.vectors).astype(np.float32, copy=False), *self.columns())

    def columns(self):
        """``(motion (N,) int64, body (N,) int64, azimuth (N,) float64, elevation (N,)
        float64, start (N,) int64, stop (N,) int64, labels list of N str)``: what is
        known of each motion image gathered."""
        return (
            np.asarray(self.motion, dtype=np.int64),
            np.asarray(self.body, dtype=np.int64),
            np.asarray(self.azimuth, dtype=np.float64),
            np.asarray(self.elevation, dtype=np.float64),
            np.asarray(self.start, dtype=np.int64),
            np.asarray(self.stop, dtype=np.int64),
            list(self.labels),
        )


def build_database(
    library: Sequence[LibraryMotion],
    rig: CameraRig,
    uri: str | os.PathLike = DEFAULT_DB_PATH,
    config: BuildConfig | None = None,
    workers: int | None = None,
    progress: bool = True,
    views: Iterable[ViewImages] | None = None,
) -> BuildReport:
    """Build a database from a motion library and a rig of virtual cameras.

    Renders every (motion, body shape, view), fits the eigenspace, cuts the keys,
    calibrates the "unknown" threshold and writes everything in one transaction.  A
    file database is written beside the target and moved over it only once complete,
    so a failed or interrupted build leaves any previous database as it was.

    Parameters
    ----------
    library : sequence of LibraryMotion
    rig : CameraRig
    uri : str or path
        Where to write (see :mod:`eigmotion.retrieval.store`); an existing database there is
        replaced.
    config : BuildConfig, optional
    workers : int, optional
        Processes for rendering.
    progress : bool
        Progress bars on stderr.
    views : iterable of ViewImages, optional
        The motion images of every (motion, body, view), as
        :func:`~eigmotion.retrieval.library_views.render_views` yields them for ``library``,
        ``rig`` and ``config`` (its ``motion_index`` an index into ``library``), when they
        were made already —
        e.g. from stored silhouettes; default: rendered here.

    Returns
    -------
    BuildReport
    """
    t0 = time.perf_counter()
    config = config or BuildConfig()
    if not library:
        raise InvalidParameterError("the motion library is empty: nothing to build")
    names = [m.name for m in library]
    if len(set(names)) != len(names):
        raise InvalidParameterError("motion names in the library must be unique")
    check_target(uri)  # an unreachable server is told before minutes of rendering
    collected = CollectedViews()
    if views is None:
        views = render_views(library, rig, config, workers=workers, progress=progress)
    for view in views:
        collected.add(view, rig)
    X, motion_of, body_of, az, el, start, stop, labels = collected.arrays()
    if not collected.sequences:
        raise InvalidParameterError("no rendering of the library shows a person: nothing to build")
    stage = _stage_lines(progress, t0)
    stage(f"fitting the eigenspace to {len(X):,} motion images")
    space = Eigenspace(config.n_components, config.explained_variance).fit(X)
    pose_space = fit_pose_space(np.concatenate([seq for *_, seq in collected.sequences]))
    points = space.transform(X).astype(np.float32)
    stage(f"cutting the keys (k = {space.n_components_})")
    n_axes = min(config.key_axes, space.n_components_)
    quantizer = Quantizer(n_axes, config.key_sections, config.key_method).fit(points)
    keys = quantizer.keys(points)
    stage("calibrating the unknown threshold")
    whole = (start == 0) & (stop == np.array([m.motion.n_frames for m in library])[motion_of])
    originals = [m.mirror_of or m.name for m in library]
    performance = np.unique(originals, return_inverse=True)[1]
    calibration = leave_one_motion_out_distances(
        points, performance[motion_of], whole, body_of, config.alike_bodies()
    )
    threshold = threshold_from_distances(calibration, points)
    recon = space.reconstruction_error(X)
    stored_config = {
        "build": config.to_dict(),
        "rig": rig_to_plain(rig),
        "threshold": threshold,
        "calibration_quantiles": calibration_quantiles(calibration),
        "reconstruction_error_median": float(np.median(recon)),
        "reconstruction_error_p95": float(np.quantile(recon, 0.95)),
    }
    stage(f"storing {len(points):,} entries and {len(library)} motions")
    with replacing(uri) as target:
        store = Store.create(target, overwrite=True)
        try:
            fitted = (stored_config, space, quantizer, pose_space)
            store_library(store, fitted, library, collected, points, keys)
        finally:
            store.close()
    return BuildReport(
        os.fspath(uri),
        len(library),
        len(points),
        int(space.n_components_),
        float(np.sum(space.explained_variance_ratio_)),
        threshold,
        time.perf_counter() - t0,
    )


def store_library(
    store: Store,
    fitted: tuple,
    library: Sequence[LibraryMotion],
    collected: CollectedViews,
    points: np.ndarray,
    keys: np.ndarray,
) -> None:
    """Write a built database: its configuration and eigenspaces, then each motion with
    its entries and silhouette sequences in a transaction of its own, then the packed
    columns (so damage to the end of the file costs the last motion, not the database:
    ``eigmotion repair``).  Entry ids run motion by motion, in library order.

    Parameters
    ----------
    store : Store
        Created, empty, writable.
    fitted : tuple
        ``(stored config, eigenspace, quantizer, pose eigenspace)`` for
        :meth:`Store.initialise`.
    library : sequence of LibraryMotion
    collected : CollectedViews
        Every rendering of ``library``.
    points : (N, k) float32
        The eigen-coordinates of ``collected``'s motion images.
    keys : (N,) int64
        Their B-tree keys.
    """
    motion_of, body_of, az, el, start, stop, labels = collected.columns()
    pose_space = fitted[3]
    with store.transaction():
        store.initialise(*fitted)
    sequences: dict[int, list] = {}  # each motion's, filed under motion index 0
    for motion_index, *view in collected.sequences:
        sequences.setdefault(motion_index, []).append((0, *view))
    ids, order, motion_ids = [], [], []
    for index, item in enumerate(library):
        rows = np.flatnonzero(motion_of == index)
        with store.transaction():
            motion_id = store_motion(store, item)
            ids.append(
                store.add_entries(
                    np.full(len(rows), motion_id), points[rows], keys[rows], az[rows],
                    el[rows], start[rows], stop[rows], [labels[i] for i in rows],
                    body_of[rows], columns=False,
                )
            )  # fmt: skip
            store_sequences(store, [motion_id], sequences.get(index, []), pose_space)
        order.append(rows)
        motion_ids.append(motion_id)
    rows = np.concatenate(order)
    with store.transaction():
        store.append_columns(
            np.concatenate(ids), keys[rows], points[rows], np.asarray(motion_ids)[motion_of[rows]]
        )


def _stage_lines(progress: bool, t0: float):
    """``stage(text)``: one line on stderr as each step after the rendering starts."""

    def stage(text: str) -> None:
        if progress:
            sys.stderr.write(f"build: {text} … ({time.perf_counter() - t0:.0f} s)\n")
            sys.stderr.flush()

    return stage


def store_motion(store: Store, item: LibraryMotion) -> int:
    """Store a library motion (its BVH text and metadata); returns its motion id."""
    motion = item.motion
    return store.add_motion(
        item.label,
        ";".join(str(p) for p in item.source),
        format_bvh(motion),
        {
            "name": item.name,
            "performer": item.performer,
            "variation": item.variation,
            "role": item.role,
            "mirror_of": item.mirror_of or "",
            "action": list(item.action or ()),
            "filler": item.filler or "",
            "n_frames": motion.n_frames,
            "frame_time_s": motion.frame_time_s,
            "length_unit_m": -1.0 if motion.length_unit_m is None else motion.length_unit_m,
        },
    )


def store_sequences(
    store: Store, motion_ids: Sequence[int], sequences: list, pose_space: Eigenspace
) -> None:
    """Store every rendering's silhouette sequence in the pose eigenspace, motion by
    motion (``sequences`` as :class:`CollectedViews` holds them, motion indices into
    ``motion_ids``)."""
    by_motion: dict[int, list] = {}
    for motion_index, azimuth, elevation, frames in sequences:
        by_motion.setdefault(motion_index, []).append((azimuth, elevation, frames))
    for motion_index, rows in by_motion.items():
        azimuth, elevation, frames = zip(*rows, strict=True)
        coordinates = [pose_coordinates(pose_space, f) for f in frames]
        store.add_sequences(motion_ids[motion_index], azimuth, elevation, coordinates)
