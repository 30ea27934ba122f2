"""The layout of a motion database's root, and its data packed into bytes and back.

Layout of the root (plain data only: numbers, strings, bytes, tuples, dicts and the
ZODB/BTrees containers; never a class of this package, so renaming a module never
breaks a stored database)::

    schema_version  int                       SCHEMA_VERSION
    config          PersistentMapping         the build configuration (plain values)
    eigenspace      PersistentMapping         Eigenspace.to_state() (arrays as bytes)
    quantizer       PersistentMapping         Quantizer.to_state()
    keys            LOBTree  key → LLTreeSet  the B-tree: entry ids under each key
    entries         LOBTree  id  → dict       one record per motion image
    motions         LOBTree  id  → PersistentMapping  label, source, BVH text, metadata
    columns         LOBTree  chunk → PersistentMapping  ids, keys, points, motions
                                              of 65,536 entries each, as bytes
    pose_space      PersistentMapping         the pose eigenspace of the sequences'
                                              frames, Eigenspace.to_state()
    sequences       LOBTree  motion id → PersistentMapping  the silhouette sequences
                                              of the motion's renderings, as bytes
    counters        PersistentMapping         next_entry, next_motion

An entry record is ``{"motion": int, "label": str, "view_azimuth_deg": float,
"view_elevation_deg": float, "start_frame": int, "end_frame": int, "key": int,
"point": bytes (k float32, little-endian)}``, with ``"body": int`` (which of the
build's bodies the motion image was rendered on) where it was stored; databases built
before 2026-11-27 lack it.  Entry ids count up from 0, so the columns are in id order;
they repeat the records' ids, keys and points in packed form so that opening a database
of a million entries reads a few dozen objects instead of unpickling a million
records.  A motion's sequences record is ``{"azimuth": bytes (R float64),
"elevation": bytes (R float64), "lengths": bytes (R int64), "frames": bytes
(sum of lengths × (p + 1) float16), "speeds": bytes (R float64)}``: one row per
rendering (body × view) of the whole motion, each frame its p coordinates in the pose
eigenspace and its weighted rise (:func:`eigmotion.retrieval.sequences.pose_coordinates`),
and each rendering's pose speed (:func:`eigmotion.retrieval.sequences.pose_speeds` of its
frames as stored), which a query would otherwise measure; records written before
2026-11-30 lack the speeds (a query measures them).  It is read only when a query
compares the motion.  :meth:`~eigmotion.retrieval.store.Store.check` verifies
that the B-tree, the records and the columns agree.

:class:`~eigmotion.retrieval.store.Store` reads and writes this layout; the functions
here check what is written and pack and unpack its bytes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from persistent.mapping import PersistentMapping

from eigmotion.errors import DatabaseError, InvalidParameterError

#: Version of the root layout; a database of another version is refused.  Version 2
#: added the silhouette sequences; version 3 weighs their lower body
#: (:data:`eigmotion.retrieval.sequences.LOWER_BODY_WEIGHT`); version 4 adds the rise of the top
#: of the body to each of their frames.
SCHEMA_VERSION = 4

#: Entries per packed column chunk.
CHUNK_ENTRIES = 65536

_PLAIN_SCALARS = (bool, int, float, str, bytes, type(None))


@dataclass(frozen=True)
class MotionSequences:
    """The silhouette sequences of one motion's renderings.

    Attributes
    ----------
    azimuth_deg, elevation_deg : (R,) float64
        The virtual camera of each rendering, degrees.
    lengths : (R,) int64
        Frames of each sequence, each >= 1.
    frames : (sum of lengths, p + 1) float32 (float16 where asked for)
        The sequences' frames, one after the other: the p pose-eigenspace coordinates
        and the weighted rise (:func:`eigmotion.retrieval.sequences.pose_coordinates`).
    speeds : (R,) float64 or None
        Each sequence's pose speed (:func:`eigmotion.retrieval.sequences.pose_speeds`
        of its stored frames); ``None`` where the record was written without them.
    """

    azimuth_deg: np.ndarray
    elevation_deg: np.ndarray
    lengths: np.ndarray
    frames: np.ndarray
    speeds: np.ndarray | None = None


@dataclass(frozen=True)
class StoreArrays:
    """Everything a query needs, held in memory.

    Attributes
    ----------
    ids : (N,) int64
        Entry ids, ascending.
    keys : (N,) int64
        Each entry's B-tree key.
    points : (N, k) float32
        Each entry's eigen-coordinates.
    motions : (N,) int64
        Each entry's motion id.
    """

    ids: np.ndarray
    keys: np.ndarray
    points: np.ndarray
    motions: np.ndarray


def plain_copy(value, where: str):
    """A deep copy of ``value`` made of built-in types only, or InvalidParameterError."""
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, _PLAIN_SCALARS):
        if isinstance(value, float) and not math.isfinite(value):
            raise InvalidParameterError(f"{where}: {value} is not a finite number")
        return value
    if isinstance(value, list | tuple):
        return tuple(plain_copy(v, f"{where}[{i}]") for i, v in enumerate(value))
    if isinstance(value, dict):
        out = {}
        for k, v in value.items():
            if not isinstance(k, str):
                raise InvalidParameterError(f"{where}: key {k!r} is not a string")
            out[k] = plain_copy(v, f"{where}.{k}")
        return out
    raise InvalidParameterError(
        f"{where}: {type(value).__name__} cannot be stored; use numbers, strings, bytes, "
        "lists and dicts"
    )


def frame_columns(root) -> int:
    """Columns of a stored sequence frame: the pose eigenspace's axes and the rise
    (:func:`eigmotion.retrieval.sequences.pose_coordinates`)."""
    return int(root["pose_space"]["components"]["shape"][0]) + 1


def thawed(value):
    """Copy stored plain data (and ZODB mappings) back into plain dicts and lists."""
    if hasattr(value, "items"):
        return {k: thawed(v) for k, v in value.items()}
    if isinstance(value, tuple):
        return [thawed(v) for v in value]
    return value


@dataclass(frozen=True)
class EntryColumns:
    """N entries' values, checked, as :meth:`~eigmotion.retrieval.store.Store.add_entries`
    stores them.

    Attributes
    ----------
    points : (N, k) float32
    motions, keys, start, end : (N,) int64
    azimuth, elevation : (N,) float64
    body : (N,) int64 or None
    """

    points: np.ndarray
    motions: np.ndarray
    keys: np.ndarray
    azimuth: np.ndarray
    elevation: np.ndarray
    start: np.ndarray
    end: np.ndarray
    body: np.ndarray | None


def entry_columns(
    k, points, motion_ids, keys, view_azimuth_deg, view_elevation_deg, start_frame, end_frame,
    bodies,
) -> EntryColumns:  # fmt: skip
    """The arguments of :meth:`~eigmotion.retrieval.store.Store.add_entries` checked
    (the eigenspace's ``k`` axes, finite values, ``0 <= start_frame <= end_frame``, bodies
    >= 0) and converted; InvalidParameterError naming the first that is wrong."""
    pts = np.asarray(points)
    if pts.ndim != 2 or pts.shape[1] != k or not np.issubdtype(pts.dtype, np.number):
        raise InvalidParameterError(f"points must be (N, {k}) numbers, got {pts.dtype} {pts.shape}")
    pts = np.ascontiguousarray(pts, dtype=np.float32)
    n = pts.shape[0]
    if not np.all(np.isfinite(pts)):
        raise InvalidParameterError("points hold NaN or infinity (as float32)")

    def column(values, name, integer):
        a = np.asarray(values)
        if a.shape != (n,):
            raise InvalidParameterError(f"{name} must have shape ({n},), got {a.shape}")
        if integer:
            if n and not np.issubdtype(a.dtype, np.integer):
                raise InvalidParameterError(f"{name} must be integers, got {a.dtype}")
            return a.astype(np.int64)
        a = a.astype(np.float64)
        if not np.all(np.isfinite(a)):
            raise InvalidParameterError(f"{name} holds NaN or infinity")
        return a

    motions = column(motion_ids, "motion_ids", True)
    keys = column(keys, "keys", True)
    azimuth = column(view_azimuth_deg, "view_azimuth_deg", False)
    elevation = column(view_elevation_deg, "view_elevation_deg", False)
    start = column(start_frame, "start_frame", True)
    end = column(end_frame, "end_frame", True)
    body = None if bodies is None else column(bodies, "bodies", True)
    if body is not None and np.any(body < 0):
        raise InvalidParameterError(f"bodies must be >= 0, got {int(body.min())}")
    if np.any(start < 0) or np.any(end < start):
        row = int(np.flatnonzero((start < 0) | (end < start))[0])
        raise InvalidParameterError(
            f"entry {row}: time window {start[row]}..{end[row]} is not 0 <= start <= end"
        )
    return EntryColumns(pts, motions, keys, azimuth, elevation, start, end, body)


def append_to_columns(columns, first: int, ids, keys, point_bytes, motions) -> None:
    """Pack new entries onto the root's ``columns``, :data:`CHUNK_ENTRIES` to a chunk.

    Parameters
    ----------
    columns : LOBTree
        The root's ``columns``.
    first : int
        The first new entry's id (the entries before it are packed already).
    ids, keys, motions : (N,) int64
    point_bytes : (N, k) little-endian float32
    """
    n = len(ids)
    done = 0
    while done < n:
        chunk_no = int((first + done) // CHUNK_ENTRIES)
        room = (chunk_no + 1) * CHUNK_ENTRIES - (first + done)
        part = slice(done, done + min(room, n - done))
        chunk = columns.get(chunk_no)
        if chunk is None:
            chunk = columns[chunk_no] = PersistentMapping(
                {"ids": b"", "keys": b"", "points": b"", "motions": b""}
            )
        chunk["ids"] += ids[part].astype("<i8").tobytes()
        chunk["keys"] += keys[part].astype("<i8").tobytes()
        chunk["points"] += point_bytes[part].tobytes()
        chunk["motions"] += motions[part].astype("<i8").tobytes()
        done = part.stop


def unpack_columns(root, uri: str) -> StoreArrays:
    """The root's packed ``columns`` as arrays; DatabaseError (naming ``uri``) when they
    do not hold as many entries as its counter says."""
    k = int(root["eigenspace"]["components"]["shape"][0])
    parts = {"ids": [], "keys": [], "points": [], "motions": []}
    for chunk in root["columns"].values():
        for name in parts:
            parts[name].append(chunk[name])
    ids = _concatenated(parts, "ids", "<i8", np.int64, uri)
    keys = _concatenated(parts, "keys", "<i8", np.int64, uri)
    motions = _concatenated(parts, "motions", "<i8", np.int64, uri)
    points = _concatenated(parts, "points", "<f4", np.float32, uri)
    n = int(root["counters"]["next_entry"])
    if not (ids.size == keys.size == motions.size == n and points.size == n * k):
        raise DatabaseError(f"{uri}: packed columns hold {ids.size} entries, the counter says {n}")
    return StoreArrays(ids, keys, points.reshape(n, k), motions)


def _concatenated(parts: dict, name: str, stored: str, dtype: type, uri: str) -> np.ndarray:
    """The values packed in the chunks' ``parts[name]`` (bytes of little-endian
    ``stored``, e.g. ``"<f4"``) as one writable (n,) array of ``dtype``, copied once (no
    joined bytes in between: at a million entries the points alone are 160 MB);
    DatabaseError (naming ``uri`` and the column) when a chunk holds a cut value."""
    size = np.dtype(stored).itemsize
    if any(len(part) % size for part in parts[name]):
        raise DatabaseError(f"{uri}: the packed column {name!r} is cut inside a value")
    out = np.empty(sum(len(part) for part in parts[name]) // size, dtype)
    at = 0
    for part in parts[name]:
        values = np.frombuffer(part, dtype=stored)
        out[at : at + values.size] = values
        at += values.size
    return out


def checked_sequences(p: int, view_azimuth_deg, view_elevation_deg, sequences):
    """The arguments of :meth:`~eigmotion.retrieval.store.Store.add_sequences` checked
    (R sequences of (F >= 1, ``p``) finite values within float16, R finite view
    directions): ``(azimuth (R,) float64, elevation (R,) float64, list of R arrays)``;
    InvalidParameterError naming the first that is wrong."""
    sequences = [np.asarray(seq) for seq in sequences]
    azimuth = np.asarray(view_azimuth_deg, dtype=np.float64)
    elevation = np.asarray(view_elevation_deg, dtype=np.float64)
    r = len(sequences)
    if azimuth.shape != (r,) or elevation.shape != (r,):
        raise InvalidParameterError(
            f"view_azimuth_deg and view_elevation_deg must have shape ({r},), got "
            f"{azimuth.shape} and {elevation.shape}"
        )
    for i, seq in enumerate(sequences):
        if seq.ndim != 2 or seq.shape[0] < 1 or seq.shape[1] != p:
            raise InvalidParameterError(
                f"sequence {i} must be (F >= 1, {p}) pose coordinates and rise, got {seq.shape}"
            )
        if not np.all(np.isfinite(seq)):
            raise InvalidParameterError(f"sequence {i} holds NaN or infinity")
        if np.any(np.abs(seq) > np.finfo(np.float16).max):
            raise InvalidParameterError(f"sequence {i} holds values beyond float16")
    if not (np.all(np.isfinite(azimuth)) and np.all(np.isfinite(elevation))):
        raise InvalidParameterError("view directions hold NaN or infinity")
    return azimuth, elevation, sequences


def unpack_sequences(
    record, p: int, uri: str, motion_id: int, dtype: type = np.float32
) -> MotionSequences:
    """A motion's sequences record (``p`` columns a frame) as arrays, its frames of
    ``dtype`` (float32, or float16 as stored: a query converts only the frames it
    compares); DatabaseError when its frames do not fill its lengths."""
    lengths = np.frombuffer(record["lengths"], dtype="<i8").astype(np.int64)
    frames = np.frombuffer(record["frames"], dtype="<f2").astype(dtype)
    speeds = record.get("speeds")
    if speeds is not None:
        speeds = np.frombuffer(speeds, dtype="<f8").astype(np.float64)
    speeds_fit = speeds is None or (
        speeds.size == lengths.size and bool(np.all(np.isfinite(speeds) & (speeds >= 0.0)))
    )
    if frames.size != int(lengths.sum()) * p or not speeds_fit:
        raise DatabaseError(f"{uri}: the sequences of motion {motion_id} are damaged")
    return MotionSequences(
        np.frombuffer(record["azimuth"], dtype="<f8").astype(np.float64),
        np.frombuffer(record["elevation"], dtype="<f8").astype(np.float64),
        lengths,
        frames.reshape(-1, p),
        speeds,
    )
