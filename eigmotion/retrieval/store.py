"""The motion database on disk: ZODB + BTrees, behind one class.

This is the only module that touches ZODB.  A database is opened by URI:

``path`` or ``file:///abs/path.fs``
    A ZODB ``FileStorage`` file (the default).
``memory://``
    A ``MappingStorage`` in this process, for tests; it lives as long as the
    :class:`Store` that created it.
``zeo://host:port``
    A ZEO server's storage (``ZEO.ClientStorage``), shared by many processes.

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
(sum of lengths × (p + 1) float16)}``: one row per rendering (body × view) of the
whole motion, each frame its p coordinates in the pose eigenspace and its weighted rise
(:func:`eigmotion.retrieval.sequences.pose_coordinates`); it is read
only when a query compares the motion.  :meth:`Store.check` verifies that the B-tree, the
records and the columns agree.

Writes happen inside :meth:`Store.transaction` (one ``transaction.TransactionManager``
per store): a whole build or a whole index is one transaction, committed at the end
of the ``with`` block and aborted if anything in it raises, so a failed build leaves
nothing half-written.
"""

from __future__ import annotations

import contextlib
import math
import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from urllib.parse import unquote, urlparse

import numpy as np

from eigmotion.errors import DatabaseError, InvalidParameterError
from eigmotion.retrieval.eigenspace import Eigenspace
from eigmotion.retrieval.keys import Quantizer

#: Version of the root layout; a database of another version is refused.  Version 2
#: added the silhouette sequences; version 3 weighs their lower body
#: (:data:`eigmotion.retrieval.sequences.LOWER_BODY_WEIGHT`); version 4 adds the rise of the top
#: of the body to each of their frames.
SCHEMA_VERSION = 4

#: Entries per packed column chunk.
CHUNK_ENTRIES = 65536

#: Seconds a ``zeo://`` open waits for the server.
ZEO_WAIT_S = 10.0

_FILE_SUFFIXES = ("", ".index", ".lock", ".tmp", ".old")
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
    frames : (sum of lengths, p + 1) float32
        The sequences' frames, one after the other: the p pose-eigenspace coordinates
        and the weighted rise (:func:`eigmotion.retrieval.sequences.pose_coordinates`).
    """

    azimuth_deg: np.ndarray
    elevation_deg: np.ndarray
    lengths: np.ndarray
    frames: np.ndarray


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


def _plain(value, where: str):
    """A deep copy of ``value`` made of built-in types only, or InvalidParameterError."""
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, _PLAIN_SCALARS):
        if isinstance(value, float) and not math.isfinite(value):
            raise InvalidParameterError(f"{where}: {value} is not a finite number")
        return value
    if isinstance(value, list | tuple):
        return tuple(_plain(v, f"{where}[{i}]") for i, v in enumerate(value))
    if isinstance(value, dict):
        out = {}
        for k, v in value.items():
            if not isinstance(k, str):
                raise InvalidParameterError(f"{where}: key {k!r} is not a string")
            out[k] = _plain(v, f"{where}.{k}")
        return out
    raise InvalidParameterError(
        f"{where}: {type(value).__name__} cannot be stored; use numbers, strings, bytes, "
        "lists and dicts"
    )


def _frame_columns(root) -> int:
    """Columns of a stored sequence frame: the pose eigenspace's axes and the rise
    (:func:`eigmotion.retrieval.sequences.pose_coordinates`)."""
    return int(root["pose_space"]["components"]["shape"][0]) + 1


def _thaw(value):
    """Copy stored plain data (and ZODB mappings) back into plain dicts and lists."""
    if hasattr(value, "items"):
        return {k: _thaw(v) for k, v in value.items()}
    if isinstance(value, tuple):
        return [_thaw(v) for v in value]
    return value


def parse_uri(uri: str | os.PathLike) -> tuple[str, str]:
    """Split a database URI into ``(scheme, target)``.

    Returns
    -------
    ("file", path) or ("memory", "") or ("zeo", "host:port")

    Raises
    ------
    DatabaseError
        An unknown scheme or a ``zeo://`` address without a port.
    """
    text = os.fspath(uri)
    if "://" not in text:
        return "file", text
    parsed = urlparse(text)
    scheme = parsed.scheme.lower()
    if scheme == "file":
        path = unquote(parsed.path)
        if parsed.netloc and parsed.netloc != "localhost":
            path = parsed.netloc + path
        return "file", path
    if scheme == "memory":
        return "memory", ""
    if scheme == "zeo":
        if not parsed.hostname or parsed.port is None:
            raise DatabaseError(f"{text}: a ZEO address needs host and port (zeo://host:port)")
        return "zeo", f"{parsed.hostname}:{parsed.port}"
    raise DatabaseError(
        f"{text}: unknown database scheme {scheme!r}; use a path, file://, "
        "memory:// or zeo://host:port"
    )


class Store:
    """An open motion database (see the module docstring for the layout).

    Use :meth:`create` for a new database and :meth:`open` for an existing one; both
    return a store that is also a context manager (closing on exit).

    Attributes
    ----------
    uri : str
        The URI it was opened with.
    read_only : bool
        True when opened for queries only.
    """

    def __init__(self, uri: str, db, read_only: bool):
        import transaction

        self.uri = uri
        self.read_only = read_only
        self._db = db
        self._tm = transaction.TransactionManager()
        self._conn = db.open(transaction_manager=self._tm)
        self._in_transaction = False
        self._overwrite = False
        self._arrays: StoreArrays | None = None

    # -- opening ---------------------------------------------------------------------
    @classmethod
    def create(cls, uri: str | os.PathLike, *, overwrite: bool = False) -> Store:
        """A new, empty, writable database; fill it with :meth:`initialise` inside
        :meth:`transaction`.

        Parameters
        ----------
        uri : str or path
        overwrite : bool
            A file database already at the path is deleted first; a ZEO database
            that already holds data is emptied inside the first transaction (so an
            aborted rebuild keeps the old one).  Without it, either is an error.

        Raises
        ------
        DatabaseError
            The file exists (without ``overwrite``), its folder does not, the ZEO
            server does not answer, or it already holds a database.
        """
        text = os.fspath(uri)
        scheme, target = parse_uri(text)
        if scheme == "file":
            path = Path(target)
            if not path.parent.is_dir():
                raise DatabaseError(f"{path}: folder {path.parent} does not exist")
            if path.exists():
                if not overwrite:
                    raise DatabaseError(f"{path}: a database exists; pass overwrite=True")
                for suffix in _FILE_SUFFIXES:
                    with contextlib.suppress(FileNotFoundError):
                        Path(f"{path}{suffix}").unlink()
        store = cls(text, cls._open_db(scheme, target, text, read_only=False), False)
        store._overwrite = overwrite
        if "schema_version" in store._root() and not overwrite:
            store.close()
            raise DatabaseError(f"{text}: already holds a database; pass overwrite=True")
        return store

    @classmethod
    def open(cls, uri: str | os.PathLike, *, read_only: bool = True) -> Store:
        """An existing database, read-only (queries) by default.

        Parameters
        ----------
        uri : str or path
        read_only : bool
            False to add motions and entries (the index job).

        Raises
        ------
        DatabaseError
            The file does not exist, is not a ZODB file, holds no eigmotion
            database, or one of another schema version; ``memory://`` (which only
            :meth:`create` makes); the ZEO server does not answer.
        """
        text = os.fspath(uri)
        scheme, target = parse_uri(text)
        if scheme == "memory":
            raise DatabaseError(
                f"{text}: a memory:// database exists only inside the Store that created "
                "it; use Store.create"
            )
        if scheme == "file" and not Path(target).is_file():
            raise DatabaseError(f"{target}: no such database file")
        store = cls(text, cls._open_db(scheme, target, text, read_only), read_only)
        try:
            store._check_schema()
            store._load_arrays()
        except BaseException:
            store.close()
            raise
        return store

    @staticmethod
    def _open_db(scheme: str, target: str, uri: str, read_only: bool):
        import ZODB

        try:
            if scheme == "memory":
                from ZODB.MappingStorage import MappingStorage

                storage = MappingStorage()
            elif scheme == "file":
                from ZODB.FileStorage import FileStorage

                storage = FileStorage(target, read_only=read_only)
            else:
                from ZEO.ClientStorage import ClientStorage
                from ZEO.Exceptions import ClientDisconnected

                host, port = target.rsplit(":", 1)
                try:
                    storage = ClientStorage(
                        (host, int(port)),
                        read_only=read_only,
                        wait_timeout=ZEO_WAIT_S,
                        # a new transaction asks the server, so refresh() sees every
                        # commit made before it was called
                        server_sync=True,
                    )
                except ClientDisconnected as exc:
                    raise DatabaseError(f"{uri}: no ZEO server answered ({exc})") from exc
        except DatabaseError:
            raise
        except Exception as exc:  # lock held elsewhere, corrupt file, permissions
            raise DatabaseError(f"{uri}: cannot open database: {exc}") from exc
        return ZODB.DB(storage, large_record_size=1 << 31)

    def close(self) -> None:
        """Abort any open transaction and close the connection and the database."""
        if self._db is None:
            return
        with contextlib.suppress(Exception):
            self._tm.abort()
        self._conn.close()
        self._db.close()
        self._db = None

    def __enter__(self) -> Store:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __repr__(self) -> str:
        state = "closed" if self._db is None else ("read-only" if self.read_only else "writable")
        return f"Store({self.uri!r}, {state})"

    # -- helpers ---------------------------------------------------------------------
    def _root(self):
        if self._db is None:
            raise DatabaseError(f"{self.uri}: the store is closed")
        return self._conn.root()

    def _check_schema(self) -> None:
        root = self._root()
        if "schema_version" not in root:
            raise DatabaseError(
                f"{self.uri}: not an eigmotion database (no schema_version; was its build "
                "interrupted?)"
            )
        version = root["schema_version"]
        if version != SCHEMA_VERSION:
            raise DatabaseError(
                f"{self.uri}: database schema version {version!r}; this eigmotion reads "
                f"version {SCHEMA_VERSION} (rebuild the database)"
            )

    def _require_writing(self, what: str) -> None:
        if self._db is None:
            raise DatabaseError(f"{self.uri}: the store is closed")
        if self.read_only:
            raise DatabaseError(f"{self.uri}: opened read-only; {what} needs read_only=False")
        if not self._in_transaction:
            raise DatabaseError(
                f"{what} needs an open transaction: use `with store.transaction():`"
            )

    def _require_initialised(self):
        root = self._root()
        if "schema_version" not in root:
            raise DatabaseError(f"{self.uri}: not initialised; call initialise() first")
        return root

    # -- transactions ----------------------------------------------------------------
    @contextlib.contextmanager
    def transaction(self) -> Iterator[Store]:
        """One write transaction: committed when the block ends, aborted if it raises.

        Yields
        ------
        Store
            This store.

        Raises
        ------
        DatabaseError
            A read-only store, a nested transaction, or a failed commit (e.g. another
            ZEO client changed the same objects: retry).
        """
        if self._db is None:
            raise DatabaseError(f"{self.uri}: the store is closed")
        if self.read_only:
            raise DatabaseError(f"{self.uri}: opened read-only; writing needs read_only=False")
        if self._in_transaction:
            raise DatabaseError("a transaction is already open on this store")
        self._tm.begin()
        self._in_transaction = True
        try:
            yield self
        except BaseException:
            self._tm.abort()
            self._in_transaction = False
            raise
        try:
            self._tm.commit()
        except Exception as exc:
            self._tm.abort()
            raise DatabaseError(f"{self.uri}: commit failed, nothing was written: {exc}") from exc
        finally:
            self._in_transaction = False
        if "schema_version" in self._root():
            self._load_arrays()

    def refresh(self) -> None:
        """See what other clients committed since (reloads the in-memory arrays)."""
        if self._in_transaction:
            raise DatabaseError("refresh() inside an open transaction would discard it")
        self._tm.abort()
        self._tm.begin()
        self._check_schema()
        self._load_arrays()

    # -- building --------------------------------------------------------------------
    def initialise(
        self, config: dict, eigenspace: Eigenspace, quantizer: Quantizer, pose_space: Eigenspace
    ) -> None:
        """Write the schema version, build configuration, eigenspaces and quantizer.

        Parameters
        ----------
        config : dict
            The build configuration: string keys, plain values (numbers, strings,
            bools, None, lists, dicts).
        eigenspace : Eigenspace
            Fitted.
        quantizer : Quantizer
            Fitted, with ``n_axes <= eigenspace.n_components_``.
        pose_space : Eigenspace
            Fitted on the frames of the silhouette sequences.
        """
        from BTrees.LOBTree import LOBTree
        from persistent.mapping import PersistentMapping

        self._require_writing("initialise()")
        root = self._root()
        if "schema_version" in root and not self._overwrite:
            raise DatabaseError(f"{self.uri}: already initialised")
        if not isinstance(config, dict):
            raise InvalidParameterError(f"config must be a dict, got {type(config).__name__}")
        config = _plain(config, "config")
        space_state = eigenspace.to_state()
        quant_state = quantizer.to_state()
        pose_state = pose_space.to_state()
        if quantizer.n_axes > eigenspace.n_components_:
            raise InvalidParameterError(
                f"the quantizer keys K={quantizer.n_axes} axes but the eigenspace has only "
                f"k={eigenspace.n_components_}"
            )
        root.clear()
        root["schema_version"] = SCHEMA_VERSION
        root["config"] = PersistentMapping(config)
        root["eigenspace"] = PersistentMapping(space_state)
        root["quantizer"] = PersistentMapping(quant_state)
        root["keys"] = LOBTree()
        root["entries"] = LOBTree()
        root["motions"] = LOBTree()
        root["columns"] = LOBTree()
        root["pose_space"] = PersistentMapping(pose_state)
        root["sequences"] = LOBTree()
        root["counters"] = PersistentMapping({"next_entry": 0, "next_motion": 0})
        self._overwrite = False

    def add_motion(self, label: str, source: str, bvh: str, metadata: dict | None = None) -> int:
        """Store one basic motion; returns its id.

        Parameters
        ----------
        label : str
            Its name ("walk", "pick up"), what a query reports.
        source : str
            Where it came from (file name, clip id).
        bvh : str
            The motion as BVH text, so it can be replayed from the database alone.
        metadata : dict, optional
            Plain values (frame rate, frame count, …).

        Returns
        -------
        int
            The motion id (0, 1, 2, … in order of addition).
        """
        from persistent.mapping import PersistentMapping

        self._require_writing("add_motion()")
        root = self._require_initialised()
        for name, value in (("label", label), ("source", source), ("bvh", bvh)):
            if not isinstance(value, str):
                raise InvalidParameterError(f"{name} must be a string, got {type(value).__name__}")
        if not label:
            raise InvalidParameterError("label must not be empty")
        record = {
            "label": label,
            "source": source,
            "bvh": bvh,
            "metadata": _plain(metadata or {}, "metadata"),
        }
        counters = root["counters"]
        motion_id = int(counters["next_motion"])
        root["motions"][motion_id] = PersistentMapping(record)
        counters["next_motion"] = motion_id + 1
        return motion_id

    def add_entries(
        self,
        motion_ids,
        points,
        keys,
        view_azimuth_deg,
        view_elevation_deg,
        start_frame,
        end_frame,
        labels=None,
        bodies=None,
    ) -> np.ndarray:
        """Store N entries (motion images' points) under their keys.

        Parameters
        ----------
        motion_ids : (N,) int
            Each entry's motion, from :meth:`add_motion`.
        points : (N, k) float
            Eigen-coordinates (stored as float32); ``k`` is the eigenspace's.
        keys : (N,) int
            B-tree keys; must equal the stored quantizer's keys of the points.
        view_azimuth_deg, view_elevation_deg : (N,) float
            The virtual camera's direction, degrees.
        start_frame, end_frame : (N,) int
            The time window of the motion image, frames of the motion,
            ``0 <= start_frame <= end_frame``.
        labels : sequence of N str, optional
            Each entry's label; default its motion's (a window outside a motion's
            action carries the filler's).
        bodies : (N,) int, optional
            The body each motion image was rendered on (an index into the build
            configuration's ``bodies``, >= 0); stored as the record's ``body``.

        Returns
        -------
        (N,) int64
            The new entry ids, consecutive.
        """
        from BTrees.LLBTree import LLTreeSet
        from persistent.mapping import PersistentMapping

        self._require_writing("add_entries()")
        root = self._require_initialised()
        k = int(root["eigenspace"]["components"]["shape"][0])
        pts = np.asarray(points)
        if pts.ndim != 2 or pts.shape[1] != k or not np.issubdtype(pts.dtype, np.number):
            raise InvalidParameterError(
                f"points must be (N, {k}) numbers, got {pts.dtype} {pts.shape}"
            )
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
        known = root["motions"]
        for m in np.unique(motions).tolist():
            if m not in known:
                raise InvalidParameterError(f"motion id {m} was never added (add_motion first)")
        if labels is None:
            labels = [known[m]["label"] for m in motions.tolist()]
        labels = list(labels)
        if len(labels) != n or not all(isinstance(x, str) and x for x in labels):
            raise InvalidParameterError(f"labels must be {n} non-empty strings")
        expected = self.quantizer().keys(pts) if n else keys
        wrong = np.flatnonzero(expected != keys)
        if wrong.size:
            raise InvalidParameterError(
                f"{wrong.size} of {n} keys differ from the stored quantizer's keys of their "
                f"points (first: entry {int(wrong[0])} has {int(keys[wrong[0]])}, expected "
                f"{int(expected[wrong[0]])})"
            )

        counters = root["counters"]
        first = int(counters["next_entry"])
        ids = np.arange(first, first + n, dtype=np.int64)
        point_bytes = pts.astype("<f4")
        root["entries"].update(
            {
                int(ids[i]): {
                    "motion": int(motions[i]),
                    "label": labels[i],
                    "view_azimuth_deg": float(azimuth[i]),
                    "view_elevation_deg": float(elevation[i]),
                    "start_frame": int(start[i]),
                    "end_frame": int(end[i]),
                    "key": int(keys[i]),
                    "point": point_bytes[i].tobytes(),
                    **({} if body is None else {"body": int(body[i])}),
                }
                for i in range(n)
            }
        )
        tree = root["keys"]
        order = np.argsort(keys, kind="stable")
        unique, starts = np.unique(keys[order], return_index=True)
        for key, group in zip(unique.tolist(), np.split(ids[order], starts[1:]), strict=True):
            bucket = tree.get(key)
            if bucket is None:
                bucket = tree[key] = LLTreeSet()
            bucket.update(group.tolist())

        columns = root["columns"]
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
        counters["next_entry"] = first + n
        return ids

    def add_sequences(
        self, motion_id: int, view_azimuth_deg, view_elevation_deg, sequences
    ) -> None:
        """Store the silhouette sequences of R renderings of one motion.

        Parameters
        ----------
        motion_id : int
            From :meth:`add_motion`.
        view_azimuth_deg, view_elevation_deg : (R,) float
            Each rendering's virtual camera, degrees.
        sequences : sequence of R (F_r, p + 1) float
            Each rendering's frames: coordinates in the stored pose eigenspace (``p``
            its axes) and the weighted rise
            (:func:`eigmotion.retrieval.sequences.pose_coordinates`), ``F_r >= 1``; kept as
            float16.
        """
        from persistent.mapping import PersistentMapping

        self._require_writing("add_sequences()")
        root = self._require_initialised()
        if int(motion_id) not in root["motions"]:
            raise InvalidParameterError(f"motion id {motion_id} was never added (add_motion first)")
        p = _frame_columns(root)
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
        record = root["sequences"].get(int(motion_id))
        if record is None:
            record = root["sequences"][int(motion_id)] = PersistentMapping(
                {"azimuth": b"", "elevation": b"", "lengths": b"", "frames": b""}
            )
        record["azimuth"] += azimuth.astype("<f8").tobytes()
        record["elevation"] += elevation.astype("<f8").tobytes()
        record["lengths"] += np.array([len(s) for s in sequences], dtype="<i8").tobytes()
        if sequences:
            record["frames"] += np.concatenate(sequences).astype("<f2").tobytes()

    # -- reading ---------------------------------------------------------------------
    @property
    def schema_version(self) -> int:
        return int(self._require_initialised()["schema_version"])

    @property
    def config(self) -> dict:
        """The build configuration (a plain copy)."""
        return _thaw(self._require_initialised()["config"])

    def eigenspace(self) -> Eigenspace:
        """The stored eigenspace, fitted."""
        return self._fitted(Eigenspace, "eigenspace", "eigenspace")

    def quantizer(self) -> Quantizer:
        """The stored key quantizer, fitted."""
        return self._fitted(Quantizer, "quantizer", "quantizer")

    def pose_space(self) -> Eigenspace:
        """The stored pose eigenspace of the silhouette sequences, fitted."""
        return self._fitted(Eigenspace, "pose_space", "pose eigenspace")

    def _fitted(self, cls, key: str, what: str):
        """``cls.from_state`` of the root's ``key``; DatabaseError naming ``what`` when
        the stored state is damaged."""
        root = self._require_initialised()
        try:
            return cls.from_state(dict(root[key]))
        except InvalidParameterError as exc:
            raise DatabaseError(f"{self.uri}: stored {what} is damaged: {exc}") from exc

    def sequences(self, motion_id: int) -> MotionSequences:
        """The silhouette sequences of one motion's renderings (none for a motion
        stored without them)."""
        root = self._require_initialised()
        p = _frame_columns(root)
        record = root["sequences"].get(int(motion_id))
        if record is None:
            if int(motion_id) not in root["motions"]:
                raise InvalidParameterError(f"{self.uri}: no motion with id {motion_id}")
            record = {"azimuth": b"", "elevation": b"", "lengths": b"", "frames": b""}
        lengths = np.frombuffer(record["lengths"], dtype="<i8").astype(np.int64)
        frames = np.frombuffer(record["frames"], dtype="<f2").astype(np.float32)
        if frames.size != int(lengths.sum()) * p:
            raise DatabaseError(f"{self.uri}: the sequences of motion {motion_id} are damaged")
        return MotionSequences(
            np.frombuffer(record["azimuth"], dtype="<f8").astype(np.float64),
            np.frombuffer(record["elevation"], dtype="<f8").astype(np.float64),
            lengths,
            frames.reshape(-1, p),
        )

    @property
    def n_entries(self) -> int:
        return int(self._require_initialised()["counters"]["next_entry"])

    @property
    def n_motions(self) -> int:
        return int(self._require_initialised()["counters"]["next_motion"])

    def motion_ids(self) -> np.ndarray:
        """(M,) int64: every motion id, ascending."""
        return np.fromiter(self._require_initialised()["motions"].keys(), dtype=np.int64)

    def motion(self, motion_id: int) -> dict:
        """A motion's record: ``label``, ``source``, ``bvh``, ``metadata`` (a copy)."""
        record = self._require_initialised()["motions"].get(int(motion_id))
        if record is None:
            raise InvalidParameterError(f"{self.uri}: no motion with id {motion_id}")
        return _thaw(record)

    def entry(self, entry_id: int) -> dict:
        """An entry's record (a copy); ``point`` is decoded to a (k,) float32 array."""
        record = self._require_initialised()["entries"].get(int(entry_id))
        if record is None:
            raise InvalidParameterError(f"{self.uri}: no entry with id {entry_id}")
        out = dict(record)
        out["point"] = np.frombuffer(record["point"], dtype="<f4").astype(np.float32)
        return out

    def ids_for_key(self, key: int) -> np.ndarray:
        """(n,) int64: the entry ids stored under one B-tree key (empty if none)."""
        bucket = self._require_initialised()["keys"].get(int(key))
        if bucket is None:
            return np.zeros(0, dtype=np.int64)
        return np.fromiter(bucket, dtype=np.int64)

    def key_range(self, min_key: int, max_key: int) -> Iterator[tuple[int, np.ndarray]]:
        """Occupied keys in ``min_key … max_key`` (inclusive), in order, with their ids.

        A B-tree range query; with :func:`eigmotion.retrieval.keys.prefix_range` it walks all
        bins under a key prefix.

        Yields
        ------
        (int, (n,) int64)
        """
        tree = self._require_initialised()["keys"]
        for key, bucket in tree.items(int(min_key), int(max_key)):
            yield int(key), np.fromiter(bucket, dtype=np.int64)

    def occupied_keys(self) -> np.ndarray:
        """(B,) int64: every key of the B-tree, ascending."""
        return np.fromiter(self._require_initialised()["keys"].keys(), dtype=np.int64)

    def arrays(self) -> StoreArrays:
        """The in-memory arrays (as of the last open, commit or :meth:`refresh`)."""
        if self._db is None:
            raise DatabaseError(f"{self.uri}: the store is closed")
        if self._arrays is None:
            self._load_arrays()
        return self._arrays

    def _load_arrays(self) -> None:
        root = self._require_initialised()
        k = int(root["eigenspace"]["components"]["shape"][0])
        parts = {"ids": [], "keys": [], "points": [], "motions": []}
        for chunk in root["columns"].values():
            for name in parts:
                parts[name].append(chunk[name])
        ids = np.frombuffer(b"".join(parts["ids"]), dtype="<i8").astype(np.int64)
        keys = np.frombuffer(b"".join(parts["keys"]), dtype="<i8").astype(np.int64)
        motions = np.frombuffer(b"".join(parts["motions"]), dtype="<i8").astype(np.int64)
        points = np.frombuffer(b"".join(parts["points"]), dtype="<f4").astype(np.float32)
        n = int(root["counters"]["next_entry"])
        if not (ids.size == keys.size == motions.size == n and points.size == n * k):
            raise DatabaseError(
                f"{self.uri}: packed columns hold {ids.size} entries, the counter says {n}"
            )
        self._arrays = StoreArrays(ids, keys, points.reshape(n, k), motions)

    def check(self) -> None:
        """Verify the database: B-tree invariants, and keys, records and columns agree.

        Raises
        ------
        DatabaseError
            Naming the first inconsistency.
        """
        root = self._require_initialised()
        try:
            root["keys"]._check()
            root["entries"]._check()
        except AssertionError as exc:
            raise DatabaseError(f"{self.uri}: B-tree damaged: {exc}") from exc
        self._load_arrays()
        arrays = self._arrays
        n = arrays.ids.size
        if not np.array_equal(arrays.ids, np.arange(n)):
            raise DatabaseError(f"{self.uri}: entry ids in the columns are not 0..{n - 1}")
        n_in_tree = 0
        for key, bucket in root["keys"].items():
            members = np.fromiter(bucket, dtype=np.int64)
            n_in_tree += members.size
            if members.size == 0 or np.any(members >= n) or np.any(arrays.keys[members] != key):
                raise DatabaseError(f"{self.uri}: B-tree bin {key} disagrees with the columns")
        if n_in_tree != n:
            raise DatabaseError(f"{self.uri}: the B-tree holds {n_in_tree} ids for {n} entries")
        for entry_id, record in root["entries"].items():
            point = np.frombuffer(record["point"], dtype="<f4")
            if (
                record["key"] != arrays.keys[entry_id]
                or record["motion"] != arrays.motions[entry_id]
                or not np.array_equal(point, arrays.points[entry_id])
            ):
                raise DatabaseError(f"{self.uri}: entry {entry_id} disagrees with the columns")
        if len(root["entries"]) != n:
            raise DatabaseError(f"{self.uri}: {len(root['entries'])} records for {n} entries")
        for motion_id in root["sequences"].keys():
            found = self.sequences(motion_id)
            if not (len(found.azimuth_deg) == len(found.elevation_deg) == len(found.lengths)):
                raise DatabaseError(f"{self.uri}: the sequences of motion {motion_id} are damaged")
