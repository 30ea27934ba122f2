"""The motion database, open: queries, and new motions indexed into it.

Steps 4–6 of the retrieval engine, on top of :mod:`eigmotion.retrieval.build` (which
builds it), :mod:`eigmotion.retrieval.eigenspace`, :mod:`eigmotion.retrieval.search` and
:mod:`eigmotion.retrieval.store` (which reads and writes its objects).  Every query takes
the patent's path: motion image → eigenspace point → exact nearest entries through the
B-tree → label, motion, view; a distance over the stored threshold
(:mod:`eigmotion.retrieval.calibration`) means "unknown motion".  The clip's sliding
windows are searched and cut into segments by :mod:`eigmotion.retrieval.query_windows`;
the answers are :mod:`eigmotion.retrieval.results`.
"""

from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from eigmotion.errors import DatabaseError, InvalidParameterError
from eigmotion.imaging.cameras import rig_from_plain
from eigmotion.mocap.bvh import parse_bvh
from eigmotion.mocap.library import LibraryMotion
from eigmotion.mocap.motion import Motion
from eigmotion.retrieval.brute_force import brute_force
from eigmotion.retrieval.build import CollectedViews, store_motion, store_sequences
from eigmotion.retrieval.calibration import (
    share_known,
    stored_quantiles,
    threshold_for_false_rejection,
)
from eigmotion.retrieval.library_views import BuildConfig, render_views, window_bounds
from eigmotion.retrieval.motion_cues import (
    answer_by_raised_foot,
    answer_by_raised_hands,
    answer_by_travel,
    answer_by_turning,
    floor_cues,
    foot_raise,
    hands_raised,
)
from eigmotion.retrieval.motion_image import STILL_CHANGE_SHARE, ClipMotionImages
from eigmotion.retrieval.neighbours import NO_ENTRY
from eigmotion.retrieval.query_windows import (
    clip_segments,
    search_windows,
    snapped_to_cuts,
    specific_window_entry,
    within_person,
)
from eigmotion.retrieval.results import (
    IndexReport,
    Match,
    QueryResult,
    lost_person_warning,
    people_warning,
    shots_warning,
)
from eigmotion.retrieval.search import TreeIndex
from eigmotion.retrieval.sequences import (
    CANDIDATE_MOTIONS,
    fused_scores,
    nearest_sequence_distances,
    pace_factors,
    pose_coordinates,
    pose_speeds,
    sequence_frames,
    view_reach,
    widen_frames,
)
from eigmotion.retrieval.storage import DEFAULT_DB_PATH
from eigmotion.retrieval.store import Store, damage_named
from eigmotion.segmentation.camera_motion import stabilised
from eigmotion.segmentation.config import SilhouetteConfig
from eigmotion.segmentation.video import ClipMasks, load_clip_masks
from eigmotion.segmentation.workers import opencv_in_calling_threads, worker_threads

#: Working resolution of query silhouettes: the longer side of a frame, pixels.  The
#: motion image is 32–64 pixels, so segmenting at full video resolution only costs
#: time (measured in docs/retrieval.md).
QUERY_SILHOUETTE_SIDE_PX = 160
#: Frames smaller than this on their longer side are enlarged (bicubic, by a whole
#: factor) before the person networks look at them
#: (:attr:`~eigmotion.segmentation.config.SilhouetteConfig.work_min_side_px`): the
#: least square the networks look at around the person
#: (:data:`~eigmotion.segmentation.learned.CROP_MIN_SIDE_PX`), which a smaller frame
#: would fill only in part (measured in docs/segmentation.md).
QUERY_SILHOUETTE_MIN_SIDE_PX = 128
#: How a query cuts the person out of its clip.
QUERY_SILHOUETTE_CONFIG = SilhouetteConfig(
    work_max_side_px=QUERY_SILHOUETTE_SIDE_PX, work_min_side_px=QUERY_SILHOUETTE_MIN_SIDE_PX
)
#: Nearest entries the whole clip's search returns: enough to hold the
#: :data:`~eigmotion.retrieval.sequences.CANDIDATE_MOTIONS` nearest distinct motions that are
#: ranked again by their silhouette sequences (a motion's renderings from neighbouring
#: views and bodies crowd its nearest entries), and the labels beyond them
#: (:func:`candidate_motions`).
CANDIDATE_ENTRIES = 256


def candidate_motions(nearest: Sequence[Match]) -> list[Match]:
    """The motions a query ranks again by their silhouette sequences.

    The :data:`~eigmotion.retrieval.sequences.CANDIDATE_MOTIONS` nearest, and then the nearest
    motion of every other label among ``nearest``: the nearest motions of a clip often
    show only three or four labels, and a label the sequences never see cannot be
    ranked in, first or among the first three.

    Parameters
    ----------
    nearest : sequence of Match
        Distinct motions, each by its nearest entry, nearest first.

    Returns
    -------
    list of Match
        A subsequence of ``nearest``, in its order.
    """
    chosen = list(nearest[:CANDIDATE_MOTIONS])
    labels = {m.label for m in chosen}
    for match in nearest[CANDIDATE_MOTIONS:]:
        if match.label not in labels:
            chosen.append(match)
            labels.add(match.label)
    return chosen


def _rows_of(firsts: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """(sum of lengths,) int64: the rows of sequences that start at rows ``firsts`` (R,)
    and hold ``lengths`` (R,) frames each, one sequence after the other."""
    ends = np.cumsum(lengths)
    return np.arange(int(ends[-1])) + np.repeat(firsts - (ends - lengths), lengths)


class MotionDatabase:
    """An open motion database, ready for queries (and, opened writable, indexing).

    Use :meth:`open`; it is a context manager.

    Attributes
    ----------
    store : Store
    config : BuildConfig
    rig : CameraRig
    threshold : float
        The "unknown" threshold, eigenspace units.
    calibration_quantiles : (201,) float or None
        The quantiles of
        :func:`~eigmotion.retrieval.calibration.leave_one_motion_out_distances` at
        :data:`~eigmotion.retrieval.calibration.CALIBRATION_LEVELS`; None for a database
        built without them.
    """

    def __init__(self, store: Store):
        self.store = store
        stored = store.config
        self.config = BuildConfig.from_dict(stored["build"])
        self.rig = rig_from_plain(stored["rig"])
        self.threshold = float(stored["threshold"])
        self.calibration_quantiles = stored_quantiles(store.uri, stored)
        self.reconstruction_error_p95 = float(stored["reconstruction_error_p95"])
        self.eigenspace = store.eigenspace()
        self.pose_space = store.pose_space()
        self._load_index()

    def _load_index(self) -> None:
        arrays = self.store.arrays()
        self.index = TreeIndex.from_store(self.store)
        # entry id → motion id (-1: no such entry); an array, made at once
        self._motion_of = np.full(int(arrays.ids.max(initial=-1)) + 1, -1, np.int64)
        self._motion_of[arrays.ids] = arrays.motions
        self._entry_labels: dict[int, str] = {}
        self._motions: dict[int, dict] = {}  # motion id → record, read on first use
        self._sequences: dict = {}  # motion id → (MotionSequences, order, firsts), on first use

    @classmethod
    def open(cls, uri: str | os.PathLike = DEFAULT_DB_PATH, read_only: bool = True):
        """Open a database built by :func:`~eigmotion.retrieval.build.build_database`."""
        if Path(os.fspath(uri)) == DEFAULT_DB_PATH and not DEFAULT_DB_PATH.is_file():
            raise DatabaseError(
                f"{DEFAULT_DB_PATH}: the default database has not been built yet; "
                "run 'eigmotion build' (or pass --db)"
            )
        if not read_only:  # every stored motion readable before the file is opened to write
            with cls.open(uri, read_only=True) as db:
                db.motion_records()
        store = Store.open(uri, read_only=read_only)
        try:
            with damage_named(store.uri, "its build configuration and motions"):
                return cls(store)
        except BaseException:
            store.close()
            raise

    def close(self) -> None:
        self.store.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    @property
    def n_entries(self) -> int:
        return self.index.n_entries

    def motion_record(self, motion_id: int) -> dict:
        """A stored motion's record (``label``, ``source``, ``bvh``, ``metadata``): read
        from the store on first use, then kept (a query reads only its candidates')."""
        record = self._motions.get(motion_id)
        if record is None:
            record = self._motions[motion_id] = self.store.motion(motion_id)
        return record

    def motion_records(self) -> dict[int, dict]:
        """Every stored motion's record by id, ascending (each read once, then kept)."""
        return {int(mid): self.motion_record(int(mid)) for mid in self.store.motion_ids()}

    def threshold_at(self, false_rejection: float) -> float:
        """The distance beyond which a query is "unknown" when about
        ``false_rejection`` of new performances of the library's motions may be turned
        away (the database's own threshold turns away 5 %; more turns away more
        unknown motions too).

        Parameters
        ----------
        false_rejection : float
            In (0, 1).

        Returns
        -------
        float
            Eigenspace units.
        """
        if not 0.0 < false_rejection < 1.0:
            raise InvalidParameterError(
                f"the false rejection must be between 0 and 1, got {false_rejection}"
            )
        if self.calibration_quantiles is None:
            raise DatabaseError(
                f"{self.store.uri}: built without the distances of its own motions' "
                "performances, so only its own threshold can be used; build it again"
            )
        return threshold_for_false_rejection(self.calibration_quantiles, false_rejection)

    def p_known(self, distance: float) -> float | None:
        """The share of new performances of the library's motions that lie at least
        ``distance`` (eigenspace units) from the database, in [0, 1]; None for a
        database built without those distances.  ``distance <= threshold_at(r)``
        exactly when ``p_known(distance) >= r``."""
        if self.calibration_quantiles is None:
            return None
        return share_known(self.calibration_quantiles, distance)

    def motion(self, motion_id: int) -> Motion:
        """A stored basic motion, read back from its BVH text."""
        rec = self.motion_record(motion_id)
        meta = rec["metadata"]
        motion = parse_bvh(rec["bvh"])
        unit = meta.get("length_unit_m", -1.0)
        return motion.replace(
            name=meta.get("name", str(motion_id)), length_unit_m=None if unit < 0 else unit
        )

    def _match(self, entry_id: int, distance: float) -> Match:
        entry = self.store.entry(entry_id)
        rec = self.motion_record(int(entry["motion"]))
        return Match(
            self._label_of(entry_id),
            rec["metadata"].get("name", str(entry["motion"])),
            int(entry["motion"]),
            int(entry_id),
            float(distance),
            float(entry["view_azimuth_deg"]),
            float(entry["view_elevation_deg"]),
            (int(entry["start_frame"]), int(entry["end_frame"])),
        )

    def _label_of(self, entry_id: int) -> str:
        """The entry's label: its motion's, or the filler's for a window outside the
        motion's action (:func:`eigmotion.retrieval.library_views.window_labels`); read once,
        then kept."""
        label = self._entry_labels.get(entry_id)
        if label is None:
            label = self._entry_labels[entry_id] = self.store.entry(entry_id)["label"]
        return label

    @opencv_in_calling_threads()
    def query_masks(
        self,
        masks: np.ndarray,
        fps: float,
        top_k: int = 3,
        false_rejection: float | None = None,
        hidden_below_px: int = 0,
        floor_track: bool = True,
        raised_foot_heights: float | None = None,
        raised_hands_heights: float | None = None,
        camera: np.ndarray | None = None,
    ) -> QueryResult:
        """Answer a clip given as silhouettes.

        Parameters
        ----------
        masks : (F, H, W) bool
            The person's silhouette per frame.
        fps : float
            The clip's frame rate, frames per second.
        top_k : int
            Distinct motions to list in ``top``: the :data:`~eigmotion.retrieval.sequences.
            CANDIDATE_MOTIONS` nearest and the nearest of every further label
            (:func:`candidate_motions`) ranked by both distances, then further
            motions by motion image distance (as many as the whole clip's search
            returned).  ``labels`` lists every ranked label whatever ``top_k`` is.
        false_rejection : float, optional
            In (0, 1): judge ``accepted`` at the threshold that turns away this share
            of new performances of the library's motions (:meth:`threshold_at`);
            default the database's own threshold (5 %).
        hidden_below_px : int
            Rows of the body below the frames' bottom edge
            (:attr:`~eigmotion.segmentation.video.ClipMasks.hidden_below_px`): the motion
            images continue the silhouettes down by as many rows.
        floor_track : bool
            Let the person's track over the floor choose among the first three labels:
            its speed between walk and run (:func:`~eigmotion.retrieval.motion_cues.
            travel_speed`, :func:`~eigmotion.retrieval.motion_cues.answer_by_travel`),
            then a bend in it between walk and turn (:func:`~eigmotion.retrieval.
            motion_cues.heading_change`, :func:`~eigmotion.retrieval.motion_cues.
            answer_by_turning`); both are reported either way.
        raised_foot_heights : float, optional
            How far one foot rose above the other, body heights
            (:func:`~eigmotion.retrieval.motion_cues.foot_raise` of the pose network's
            landmarks): high enough, it makes a kick among the first three labels the
            answer (:func:`~eigmotion.retrieval.motion_cues.answer_by_raised_foot`).
        raised_hands_heights : float, optional
            How far the lower wrist rose above the nose, body heights
            (:func:`~eigmotion.retrieval.motion_cues.hands_raised`): high enough, an
            answer ``punch`` gives way to a label whose motions raise both hands among
            the first three (:func:`~eigmotion.retrieval.motion_cues.
            answer_by_raised_hands`).
        camera : (F, 2, 3) float, optional
            How the camera moved, per mask the similarity taking its pixels to the first
            mask's (:attr:`~eigmotion.segmentation.video.ClipMasks.camera`): the floor
            track is read in the first frame's pixels.  None: a still camera.

        Returns
        -------
        QueryResult

        Raises
        ------
        VideoError
            No person in the masks, or in too few of the frames sampled;
            :class:`~eigmotion.errors.StillPersonError` where the person does not move.
        """
        if top_k < 1:
            raise InvalidParameterError(f"top_k must be >= 1, got {top_k}")
        if camera is not None:
            camera = np.asarray(camera, dtype=np.float64)
            if camera.shape != (len(masks), 2, 3) or not np.isfinite(camera).all():
                raise InvalidParameterError(
                    f"camera must be finite, shape ({len(masks)}, 2, 3) (one similarity "
                    f"per mask), got {camera.shape}"
                )
        threshold = self.threshold
        if false_rejection is not None:
            threshold = self.threshold_at(false_rejection)
        timing: dict[str, float] = {}
        t0 = time.perf_counter()
        cfg = self.config
        windows = window_bounds(len(masks), fps, cfg.window_s, cfg.window_step_s)
        # A camera that moved: the silhouettes as the still camera of the first frame
        # would see them (the motion image accumulates every move of their edges).
        seen = masks if camera is None else stabilised(masks, camera)
        images = ClipMotionImages(
            seen, cfg.motion_image, fps, hidden_below_px, min_change=STILL_CHANGE_SHARE
        )
        whole_vector = images.window(*windows[0])  # no person or no motion: raised here
        # The windows' search and the clip's silhouette sequence do not wait for the
        # whole clip's search: they run beside it.
        workers = worker_threads()
        windowed_job = workers.submit(
            search_windows, images, windows[1:], self.eigenspace, self.index
        )
        sequence_job = workers.submit(
            lambda: pose_coordinates(self.pose_space, sequence_frames(images))
        )
        point = self.eigenspace.transform(whole_vector[None])  # (1, D) float32 already
        t1 = time.perf_counter()
        timing["motion_images"] = (t1 - t0) * 1e3
        whole = self.index.search(point, top_k=min(CANDIDATE_ENTRIES, self.n_entries))
        t2 = time.perf_counter()
        timing["search"] = (t2 - t1) * 1e3
        nearest = self._nearest_motions(whole.ids[0], whole.distances[0])
        candidates = candidate_motions(nearest)
        ranked = self._ranked_by_sequence(sequence_job.result(), candidates)
        timing["sequences"] = (time.perf_counter() - t2) * 1e3
        kept, windowed = windowed_job.result()
        compared = {m.motion_id for m in candidates}
        ranking = ranked + [m for m in nearest if m.motion_id not in compared]
        speed, turned = floor_cues(masks, fps, camera)
        if floor_track:
            ranking = answer_by_turning(answer_by_travel(ranking, speed), turned)
        ranking = answer_by_raised_foot(ranking, raised_foot_heights, speed)
        ranking = answer_by_raised_hands(ranking, raised_hands_heights)
        best = self._most_specific(ranking[0], windowed)
        segments = within_person(
            clip_segments(kept, windowed, len(masks), best, self._label_of, self.threshold),
            masks.any(axis=(1, 2)),
        )
        ranking = [best] + [m for m in ranking if m.motion_id != best.motion_id]
        by_label: dict[str, Match] = {}
        for match in ranking:
            by_label.setdefault(match.label, match)
        examined_windows = 0 if windowed is None else int(windowed.examined.sum())
        timing["total"] = (time.perf_counter() - t0) * 1e3
        nearest_distance = min(float(whole.distances[0, 0]), best.distance)
        return QueryResult(
            best,
            bool(nearest_distance <= threshold),
            threshold,
            self.p_known(nearest_distance),
            ranking[:top_k],
            list(by_label.values()),
            segments,
            int(whole.examined[0]),
            examined_windows,
            self.n_entries,
            timing,
            whole_vector,
            travel_speed=speed,
            heading_change=turned,
            foot_raise=raised_foot_heights,
            hands_raised=raised_hands_heights,
        )

    def _nearest_motions(self, entry_ids: np.ndarray, distances: np.ndarray) -> list[Match]:
        """The nearest entry of each distinct motion among ``entry_ids`` (nearest
        first; ``NO_ENTRY`` slots at the end are skipped)."""
        nearest: list[Match] = []
        seen: set[int] = set()
        for entry_id, dist in zip(entry_ids.tolist(), distances.tolist(), strict=True):
            if entry_id == NO_ENTRY:
                break
            motion_id = int(self._motion_of[entry_id])
            if motion_id in seen:
                continue
            seen.add(motion_id)
            nearest.append(self._match(entry_id, dist))
        return nearest

    def _ranked_by_sequence(self, query: np.ndarray, nearest: list[Match]) -> list[Match]:
        """The candidate motions ranked by motion image and silhouette sequence together.

        Parameters
        ----------
        query : (F, p + 1) float32
            The clip's silhouette sequence in pose coordinates
            (:func:`~eigmotion.retrieval.sequences.pose_coordinates` of
            :func:`~eigmotion.retrieval.sequences.sequence_frames`).
        nearest : list of Match
            Each candidate motion's nearest entry, nearest first.

        Returns
        -------
        list of Match
            The same motions, each with its ``sequence_distance`` — to its nearest
            rendering seen from within :data:`~eigmotion.retrieval.sequences.VIEW_REACH_DEG` of
            its entry's view, times what their difference of pace costs
            (:func:`~eigmotion.retrieval.sequences.pace_factors`) — in order of
            :func:`~eigmotion.retrieval.sequences.fused_scores`.
        """
        taken, lengths, owners = [], [], []  # per candidate: (stored, its rows in order)
        speed_slots = []  # per run: (the motion's pose speeds, the renderings taken)
        for candidate, match in enumerate(nearest):
            stored, by_azimuth, firsts, motion_speeds = self._stored_sequences(match.motion_id)
            azimuths = stored.azimuth_deg[by_azimuth]
            near = np.flatnonzero(view_reach(azimuths, match.azimuth_deg))
            # In order of azimuth, the renderings in reach are one run, or two where the
            # reach wraps around 0°: the first run's renderings come first.
            for run in np.split(near, np.flatnonzero(np.diff(near) > 1) + 1):
                if run.size:
                    chosen = by_azimuth[run]
                    taken.append((stored, _rows_of(firsts[chosen], stored.lengths[chosen])))
                    lengths.append(stored.lengths[chosen])
                    owners.append(np.full(run.size, candidate))
                    speed_slots.append((motion_speeds, chosen))
        compared = np.full(len(nearest), np.inf)
        if lengths:
            lengths = np.concatenate(lengths)
            frames = np.empty((int(lengths.sum()), taken[0][0].frames.shape[1]), np.float32)
            at = 0
            for stored, rows in taken:  # float16 as stored: converted as gathered
                widen_frames(np.take(stored.frames, rows, axis=0), frames[at : at + len(rows)])
                at += len(rows)
            speeds = _rendering_speeds(frames, lengths, speed_slots)
            compared = nearest_sequence_distances(
                query,
                frames,
                lengths,
                np.concatenate(owners),
                pace_factors(pose_speeds(query, [len(query)])[0], speeds),
                len(nearest),
                workers=worker_threads(),
            )
        order = np.argsort(
            fused_scores(np.array([m.distance for m in nearest]), np.array(compared)),
            kind="stable",
        )
        return [
            dataclasses.replace(
                nearest[i],
                sequence_distance=float(compared[i]) if np.isfinite(compared[i]) else None,
            )
            for i in order
        ]

    def _stored_sequences(self, motion_id: int):
        """A motion's :class:`~eigmotion.retrieval.schema.MotionSequences`, its renderings
        in order of azimuth (R,), the (R,) first frame of each rendering and their (R,)
        pose speeds (as stored; in a record written without them NaN until measured,
        see :func:`_rendering_speeds`): read from the store once, then kept, its frames
        float16 as stored."""
        found = self._sequences.get(motion_id)
        if found is None:
            stored = self.store.sequences(motion_id, np.float16)
            by_azimuth = np.argsort(stored.azimuth_deg, kind="stable")
            firsts = np.cumsum(stored.lengths) - stored.lengths
            if stored.speeds is None:
                speeds = np.full(len(stored.lengths), np.nan)
            else:
                speeds = stored.speeds.copy()
            found = self._sequences[motion_id] = (stored, by_azimuth, firsts, speeds)
        return found

    def _most_specific(self, whole: Match, windowed) -> Match:
        """The clip's answer: the whole clip's nearest entry, unless that is filler and
        the windows show a specific action (:func:`~eigmotion.retrieval.query_windows.
        specific_window_entry`) — then the nearest of those window entries."""
        found = specific_window_entry(whole.label, windowed, self._label_of, self.threshold)
        if found is None:
            return whole
        dist, entry_id = found
        return self._match(entry_id, dist)

    def query_clip(
        self,
        path: str | os.PathLike,
        background: str | os.PathLike | None = None,
        top_k: int = 3,
        every_frame: bool = False,
        progress: bool = False,
        false_rejection: float | None = None,
        segmenter: str = "auto",
        floor_track: bool = True,
        raised_foot: bool = True,
        raised_hands: bool = True,
    ) -> tuple[QueryResult, ClipMasks]:
        """Answer a clip on disk (video, folder of frames, or .npz of masks).

        Parameters
        ----------
        path : str or PathLike
        background : str or PathLike, optional
            An image of the empty scene.
        top_k : int
        every_frame : bool
            Also cut the person out of every frame, for a frame-by-frame 3D answer, and
            return those silhouettes.  The answer itself always comes from the frames
            the motion image samples (the database's ``sample_fps``), cut out on their
            own: without a background image the empty scene is estimated from the
            frames segmented, and the noise levels are taken over them, so silhouettes
            cut from every frame differ a little; the answer does not depend on
            whether a 3D answer was asked for.
        progress : bool
            Progress bars on stderr while a long video is read.
        false_rejection : float, optional
            As for :meth:`query_masks`.
        segmenter : {"auto", "learned", "subtraction", "fused"}
            How the person is cut out of video (:func:`~eigmotion.segmentation.video.
            load_clip_masks`): ``auto`` fuses the learned masks with the subtraction of
            the background image when one is given and runs the learned segmenter
            alone when none is.
        floor_track : bool
            As for :meth:`query_masks`.
        raised_foot : bool
            Measure how far one foot rose above the other from the pose network's
            landmarks (the learned and fused front ends keep them) and let a foot raised
            as only a kick raises it make a kick among the first three labels the
            answer (:meth:`query_masks`).
        raised_hands : bool
            Measure how far both hands rose over the head from the same landmarks and
            let hands over the head turn an answer ``punch`` into a label whose motions
            raise them, among the first three (:meth:`query_masks`).

        Returns
        -------
        result : QueryResult
            Segment frames are frames of the clip; ``warnings`` says when more than
            one person is in view (:attr:`~eigmotion.segmentation.video.ClipMasks.
            people`), when no person was found in many of the frames taken
            (:func:`~eigmotion.retrieval.results.lost_person_warning`) and when the
            clip cuts between shots (:func:`~eigmotion.retrieval.results.shots_warning`).
            ``timing_ms["silhouettes"]`` is the time the answer's silhouettes took;
            with ``every_frame``,
            ``timing_ms["every_frame_silhouettes"]`` that of the others.
        clip : ClipMasks
            The silhouettes the answer was computed from; with ``every_frame``, those
            of every frame.

        Raises
        ------
        VideoError
            A clip that cannot be read, or no person in it; as :meth:`query_masks`,
            :class:`~eigmotion.errors.StillPersonError` where the person does not move.
        """
        t0 = time.perf_counter()
        if false_rejection is not None:
            self.threshold_at(false_rejection)  # a bad value is told before the video is read
        config = QUERY_SILHOUETTE_CONFIG
        sample_fps = self.config.motion_image.sample_fps
        with ThreadPoolExecutor(1, thread_name_prefix="eigmotion-index") as beside:
            ready = beside.submit(self.index.prepare)  # while the person is cut out
            clip = load_clip_masks(path, background, config, sample_fps, progress, segmenter)
            ready.result()
        t1 = time.perf_counter()
        result = self.query_masks(
            clip.masks,
            clip.fps,
            top_k,
            false_rejection,
            clip.hidden_below_px,
            floor_track,
            foot_raise(clip.landmarks) if raised_foot else None,
            hands_raised(clip.landmarks) if raised_hands else None,
            clip.camera,
        )
        lost = lost_person_warning(~clip.masks.any(axis=(1, 2)), clip.frame_indices)
        # Segments come in mask indices; a mask's successor starts the next segment.
        segments = result.segments
        if clip.shot_starts is not None:  # a change of label within half a window of a cut
            reach = int(round(0.5 * self.config.window_s * clip.fps))
            segments = snapped_to_cuts(segments, clip.shot_starts[1:], reach)
        starts = np.append(clip.frame_indices, clip.n_frames)
        segments = [
            dataclasses.replace(seg, start_frame=int(starts[seg.start_frame]),
                                end_frame=int(starts[seg.end_frame]))
            for seg in segments
        ]  # fmt: skip
        timing = {"silhouettes": (t1 - t0) * 1e3, **result.timing_ms}
        if every_frame:
            t2 = time.perf_counter()
            people = clip.people
            # the camera's motion is read by the answer alone, from the frames it samples
            every = dataclasses.replace(config, measure_camera=False)
            clip = load_clip_masks(path, background, every, progress=progress, segmenter=segmenter)
            clip = dataclasses.replace(clip, people=people)
            timing["every_frame_silhouettes"] = (time.perf_counter() - t2) * 1e3
        timing["total"] = (time.perf_counter() - t0) * 1e3
        warnings = () if clip.people <= 1 else (people_warning(clip.people),)
        warnings += () if lost is None else (lost,)
        cuts = shots_warning(clip.shot_starts, clip.frame_indices)
        warnings += () if cuts is None else (cuts,)
        result = dataclasses.replace(result, segments=segments, timing_ms=timing, warnings=warnings)
        return result, clip

    # -- indexing ---------------------------------------------------------------------
    def index_motion(
        self, item: LibraryMotion, progress: bool = True, scheduler: str | None = None
    ) -> IndexReport:
        """Add a motion to this (writable) database without changing the eigenspace.

        Its motion images are rendered with the stored build configuration and rig,
        projected into the stored eigenspace and inserted under their keys, and its
        silhouette sequences into the stored pose eigenspace, in one transaction; it
        is queryable at once.  With ``scheduler`` (a Dask scheduler's address) the views
        are rendered on that cluster (see
        :func:`~eigmotion.retrieval.library_views.render_views`).

        Returns
        -------
        IndexReport
            Including how well the eigenspace represents the new motion.
        """
        if self.store.read_only:
            raise DatabaseError(f"{self.store.uri}: opened read-only; indexing needs writing")
        names = {rec["metadata"].get("name") for rec in self.motion_records().values()}
        if item.name in names:
            raise InvalidParameterError(
                f"a motion named {item.name!r} is already in the database; give it another "
                "name (eigmotion index --name)"
            )
        collected = CollectedViews()
        views = render_views([item], self.rig, self.config, progress=progress, scheduler=scheduler)
        for view in views:
            collected.add(view, self.rig)
        if not sum(len(v) for v in collected.vectors):
            motion = item.motion
            raise InvalidParameterError(
                f"{item.name}: its {motion.n_frames} frame(s) "
                f"({motion.n_frames * motion.frame_time_s:.3g} s) give no motion image to "
                "index; a motion needs at least two frames in which the person moves"
            )
        X, _, body_of, az, el, start, stop, labels = collected.arrays()
        points = self.eigenspace.transform(X).astype(np.float32)
        keys = self.store.quantizer().keys(points)
        error = float(np.median(self.eigenspace.reconstruction_error(X)))
        with self.store.transaction():
            motion_id = store_motion(self.store, item)
            of_entry = np.full(len(points), motion_id)
            self.store.add_entries(of_entry, points, keys, az, el, start, stop, labels, body_of)
            store_sequences(self.store, [motion_id], collected.sequences, self.pose_space)
        self._load_index()
        return IndexReport(
            item.name,
            motion_id,
            len(points),
            error,
            self.reconstruction_error_p95,
            error > self.reconstruction_error_p95,
        )

    def stored_library(self) -> list[LibraryMotion]:
        """Every stored motion as a :class:`LibraryMotion` (for a refit rebuild)."""
        out = []
        for mid, rec in self.motion_records().items():
            meta = rec["metadata"]
            out.append(
                LibraryMotion(
                    name=meta.get("name", str(mid)),
                    label=rec["label"],
                    motion=self.motion(mid),
                    source=tuple(Path(s) for s in rec["source"].split(";") if s),
                    performer=meta.get("performer", ""),
                    variation=meta.get("variation", ""),
                    licence="",
                    role=meta.get("role", "basic"),
                    mirror_of=meta.get("mirror_of") or None,
                    action=tuple(meta["action"]) if meta.get("action") else None,
                    filler=meta.get("filler") or None,
                )
            )
        return out


def _rendering_speeds(frames: np.ndarray, lengths: np.ndarray, slots: list) -> np.ndarray:
    """The pose speeds (:func:`~eigmotion.retrieval.sequences.pose_speeds`) of the
    renderings gathered in ``frames``, measured once per open database.

    Parameters
    ----------
    frames : (M, d) float32
        The gathered renderings' frames, one after the other.
    lengths : (R,) int
        Frames of each gathered rendering.
    slots : list of ((S,) float64, (r,) int)
        Per run of gathered renderings, in order: its motion's pose speeds (NaN where
        not measured yet; filled here) and the renderings of that motion it holds.

    Returns
    -------
    (R,) float64
        Each rendering's speed is its own frames' alone, so those measured by an
        earlier query are the same to the bit; the others are measured here, all at once.
    """
    speeds = np.concatenate([known[chosen] for known, chosen in slots])
    missing = np.isnan(speeds)
    if missing.any():
        # A database's first query measures every rendering: no copy of the frames then.
        unknown = frames if missing.all() else frames[np.repeat(missing, lengths)]
        speeds[missing] = pose_speeds(unknown, lengths[missing])
        at = 0
        for known, chosen in slots:
            known[chosen] = speeds[at : at + len(chosen)]
            at += len(chosen)
    return speeds


def brute_force_check(db: MotionDatabase, queries: np.ndarray, top_k: int = 1) -> bool:
    """True when the tree's answers (walked, never scanned) equal brute force over every
    entry."""
    arrays = db.store.arrays()
    exact = brute_force(arrays.points, arrays.ids, queries, top_k)
    tree = db.index.walk(queries, top_k)
    return bool(
        np.array_equal(exact.ids, tree.ids) and np.array_equal(exact.distances, tree.distances)
    )
