"""The motion database on disk: ZODB + BTrees, behind one class.

This is the only module that reads and writes a database's objects (ZODB itself is
opened in :mod:`eigmotion.retrieval.storage`, by URI: a path or ``file://``,
``memory://``, ``zeo://host:port``).  The layout of the root, plain data only, is
described in :mod:`eigmotion.retrieval.schema`.

Writes happen inside :meth:`Store.transaction` (one ``transaction.TransactionManager``
per store): a whole build or a whole index is one transaction, committed at the end
of the ``with`` block and aborted if anything in it raises, so a failed build leaves
nothing half-written.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import transaction
from BTrees.LLBTree import LLTreeSet
from BTrees.LOBTree import LOBTree
from persistent.mapping import PersistentMapping

from eigmotion.errors import DatabaseError, EigmotionError, InvalidParameterError
from eigmotion.retrieval.eigenspace import Eigenspace
from eigmotion.retrieval.keys import Quantizer
from eigmotion.retrieval.safe_loading import RefusedObjectError
from eigmotion.retrieval.schema import (
    SCHEMA_VERSION,
    MotionSequences,
    StoreArrays,
    append_to_columns,
    checked_sequences,
    entry_columns,
    frame_columns,
    plain_copy,
    thawed,
    unpack_columns,
    unpack_sequences,
)
from eigmotion.retrieval.sequences import pose_speeds
from eigmotion.retrieval.storage import (
    close_writable_file_storage,
    open_zodb,
    parse_uri,
    remove_file_storage,
)


@contextlib.contextmanager
def damage_named(uri: str, what: str = "it") -> Iterator[None]:
    """Turn a failure to read stored objects (damaged bytes, a missing object or
    table, an unreadable pickle) into one DatabaseError naming the database and
    ``what`` was being read; errors of this package pass as they are."""
    try:
        yield
    except RefusedObjectError as exc:
        raise DatabaseError(f"{uri}: {exc}") from None
    except EigmotionError:
        raise
    except Exception as exc:
        cause = exc
        while cause is not None and not isinstance(cause, RefusedObjectError):
            cause = cause.__cause__ or cause.__context__
        if cause is not None:  # ZODB wraps what its unpickler raised
            raise DatabaseError(f"{uri}: {cause}") from None
        text = " ".join(str(exc).split())[:160] or type(exc).__name__
        hint = f"; 'eigmotion check {uri}' tells more" if parse_uri(uri)[0] == "file" else ""
        raise DatabaseError(
            f"{uri}: damaged: reading {what} failed ({type(exc).__name__}: {text}){hint}"
        ) from exc


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
        self.uri = uri
        self.read_only = read_only
        self._db = db
        self._tm = transaction.TransactionManager()
        self._conn = db.open(transaction_manager=self._tm)
        self._in_transaction = False
        self._overwrite = False
        self._arrays: StoreArrays | None = None
        self._index_existed = True
        self._committed = False

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
                remove_file_storage(path)
        store = cls(text, open_zodb(scheme, target, text, read_only=False), False)
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
        if scheme == "file" and not read_only:
            # verified read-only first: a file that cannot be read is never opened for
            # writing (which takes its lock and may write its index)
            cls.open(uri, read_only=True).close()
        index_existed = scheme == "file" and Path(f"{target}.index").exists()
        store = cls(text, open_zodb(scheme, target, text, read_only), read_only)
        store._index_existed = index_existed
        try:
            with damage_named(text, "its root"):
                store._check_schema()
                store._load_arrays()
        except DatabaseError as exc:
            damage = getattr(store._db.storage, "eigmotion_damage", None)
            store.close()
            if damage:
                raise DatabaseError(f"{text}: {damage}") from exc
            raise
        except BaseException:
            store.close()
            raise
        return store

    def close(self) -> None:
        """Abort any open transaction and close the connection and the database."""
        if self._db is None:
            return
        with contextlib.suppress(Exception):
            self._tm.abort()
        self._conn.close()
        file_path = parse_uri(self.uri)[1] if parse_uri(self.uri)[0] == "file" else None
        if not self.read_only and file_path:
            close_writable_file_storage(self._db.storage)
        self._db.close()
        self._db = None
        if file_path and not self.read_only and not self._committed and not self._index_existed:
            # opened for writing, nothing written: leave no index ZODB made on opening
            with contextlib.suppress(OSError):
                os.unlink(f"{file_path}.index")

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
        self._committed = True
        self._arrays = None  # read again on first use

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
        self._require_writing("initialise()")
        root = self._root()
        if "schema_version" in root and not self._overwrite:
            raise DatabaseError(f"{self.uri}: already initialised")
        if not isinstance(config, dict):
            raise InvalidParameterError(f"config must be a dict, got {type(config).__name__}")
        config = plain_copy(config, "config")
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
            "metadata": plain_copy(metadata or {}, "metadata"),
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
        columns: bool = True,
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
        columns : bool
            Also pack them onto the columns; False leaves that to
            :meth:`append_columns` (a build storing motion after motion, each in its
            own transaction, packs the columns once at the end).

        Returns
        -------
        (N,) int64
            The new entry ids, consecutive.
        """
        self._require_writing("add_entries()")
        root = self._require_initialised()
        k = int(root["eigenspace"]["components"]["shape"][0])
        checked = entry_columns(
            k, points, motion_ids, keys, view_azimuth_deg, view_elevation_deg, start_frame,
            end_frame, bodies,
        )  # fmt: skip
        pts, motions, keys, body = checked.points, checked.motions, checked.keys, checked.body
        n = pts.shape[0]
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
                    "view_azimuth_deg": float(checked.azimuth[i]),
                    "view_elevation_deg": float(checked.elevation[i]),
                    "start_frame": int(checked.start[i]),
                    "end_frame": int(checked.end[i]),
                    "key": int(keys[i]),
                    "point": point_bytes[i].tobytes(),
                    **({} if body is None else {"body": int(body[i])}),
                }
                for i in range(n)
            }
        )
        if n == 0:
            return ids
        tree = root["keys"]
        order = np.argsort(keys, kind="stable")
        unique, starts = np.unique(keys[order], return_index=True)
        for key, group in zip(unique.tolist(), np.split(ids[order], starts[1:]), strict=True):
            bucket = tree.get(key)
            if bucket is None:
                bucket = tree[key] = LLTreeSet()
            bucket.update(group.tolist())

        counters["next_entry"] = first + n
        if columns:
            self.append_columns(ids, keys, point_bytes, motions)
        return ids

    def append_columns(self, ids, keys, points, motions) -> None:
        """Pack entries stored with ``add_entries(..., columns=False)`` onto the columns.

        Parameters
        ----------
        ids : (N,) int
            The entries after the last one packed, in order.
        keys, motions : (N,) int
        points : (N, k) float32
            As given to :meth:`add_entries`.

        Raises
        ------
        InvalidParameterError
            ``ids`` are not the next entries to pack, or their keys or motions differ
            from the stored records'.
        """
        self._require_writing("append_columns()")
        root = self._require_initialised()
        ids = np.asarray(ids, dtype=np.int64)
        keys = np.asarray(keys, dtype=np.int64)
        motions = np.asarray(motions, dtype=np.int64)
        packed = sum(len(chunk["ids"]) for chunk in root["columns"].values()) // 8
        if not np.array_equal(ids, np.arange(packed, packed + len(ids))) or (
            packed + len(ids) > int(root["counters"]["next_entry"])
        ):
            raise InvalidParameterError(
                f"append_columns() takes the entries after the {packed} packed, in order"
            )
        if len(ids):
            first, last = root["entries"][int(ids[0])], root["entries"][int(ids[-1])]
            if (first["key"], first["motion"], last["key"], last["motion"]) != (
                keys[0],
                motions[0],
                keys[-1],
                motions[-1],
            ):
                raise InvalidParameterError("append_columns(): keys or motions differ")
        point_bytes = np.ascontiguousarray(points, dtype="<f4")
        append_to_columns(root["columns"], int(packed), ids, keys, point_bytes, motions)

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
            float16, and beside them each rendering's pose speed
            (:func:`eigmotion.retrieval.sequences.pose_speeds`) measured on them as kept.
        """
        self._require_writing("add_sequences()")
        root = self._require_initialised()
        if int(motion_id) not in root["motions"]:
            raise InvalidParameterError(f"motion id {motion_id} was never added (add_motion first)")
        azimuth, elevation, sequences = checked_sequences(
            frame_columns(root), view_azimuth_deg, view_elevation_deg, sequences
        )
        record = root["sequences"].get(int(motion_id))
        if record is None:
            record = root["sequences"][int(motion_id)] = PersistentMapping(
                {"azimuth": b"", "elevation": b"", "lengths": b"", "frames": b"", "speeds": b""}
            )
        lengths = np.array([len(s) for s in sequences], dtype="<i8")
        record["azimuth"] += azimuth.astype("<f8").tobytes()
        record["elevation"] += elevation.astype("<f8").tobytes()
        record["lengths"] += lengths.tobytes()
        if sequences:
            frames = np.concatenate(sequences).astype("<f2")
            record["frames"] += frames.tobytes()
            if "speeds" in record:  # a record written without them is left without
                # measured on the frames as stored, as a query would measure them
                speeds = pose_speeds(frames.astype(np.float32), lengths)
                record["speeds"] += speeds.astype("<f8").tobytes()

    # -- reading ---------------------------------------------------------------------
    @property
    def schema_version(self) -> int:
        return int(self._require_initialised()["schema_version"])

    @property
    def config(self) -> dict:
        """The build configuration (a plain copy)."""
        return thawed(self._require_initialised()["config"])

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

    def sequences(self, motion_id: int, dtype: type = np.float32) -> MotionSequences:
        """The silhouette sequences of one motion's renderings (none for a motion
        stored without them), their frames of ``dtype`` (float32 or float16)."""
        with damage_named(self.uri, f"the sequences of motion {motion_id}"):
            root = self._require_initialised()
            p = frame_columns(root)
            record = root["sequences"].get(int(motion_id))
            if record is None:
                if int(motion_id) not in root["motions"]:
                    raise InvalidParameterError(f"{self.uri}: no motion with id {motion_id}")
                record = {"azimuth": b"", "elevation": b"", "lengths": b"", "frames": b"",
                          "speeds": b""}  # fmt: skip
            return unpack_sequences(record, p, self.uri, motion_id, dtype)

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
        with damage_named(self.uri, f"motion {motion_id}"):
            record = self._require_initialised()["motions"].get(int(motion_id))
            if record is None:
                raise InvalidParameterError(f"{self.uri}: no motion with id {motion_id}")
            return thawed(record)

    def entry(self, entry_id: int) -> dict:
        """An entry's record (a copy); ``point`` is decoded to a (k,) float32 array."""
        with damage_named(self.uri, f"entry {entry_id}"):
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
        self._arrays = unpack_columns(self._require_initialised(), self.uri)

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
