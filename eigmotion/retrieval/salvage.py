"""A damaged database file, read record by record: what is intact, and a copy of it.

ZODB reads a ``FileStorage`` file transaction by transaction, and a transaction
damaged anywhere (its end cut off, a header overwritten) hides every object it wrote.
:func:`scan_file` reads the file's data records one by one instead, keeping the
newest whole record of every object, and steps over damage by finding the next record
of the same transaction; :func:`inspect_database` then reads the eigmotion database
those records hold (through the same class allow-list as any open,
:mod:`eigmotion.retrieval.safe_loading`) and tells which motions are intact: the
motion's record, its silhouette sequences and every one of its entries readable.
:func:`repair_database` copies those motions into a new file; the damaged file is
only ever read.
"""

from __future__ import annotations

import os
import struct
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import ZODB
from ZODB.Connection import TransactionMetaData
from ZODB.FileStorage.FileStorage import packed_version
from ZODB.MappingStorage import MappingStorage
from ZODB.utils import z64

from eigmotion.errors import DatabaseError, EigmotionError
from eigmotion.retrieval.safe_loading import allowed_class, check_index_file
from eigmotion.retrieval.schema import SCHEMA_VERSION
from eigmotion.retrieval.storage import parse_uri, replacing
from eigmotion.retrieval.store import Store

_TRANS_HDR = struct.Struct(">8sQcHHH")  # tid, length, status, user, description, extension
_DATA_HDR = struct.Struct(">8s8sQQHQ")  # oid, tid, previous, transaction, version, length


@dataclass
class FileScan:
    """The data records of a ``FileStorage`` file, read one by one.

    Attributes
    ----------
    size : int
        Bytes in the file.
    whole_end : int
        Where the whole transactions end (``size`` for an undamaged file): ZODB reads
        the database as of there.
    records : dict
        oid (8 bytes) → the newest whole pickle of that object.
    damaged : list of (int, int)
        Byte ranges that could not be read as records.
    transactions : int
        Transaction headers read.
    """

    size: int
    whole_end: int
    records: dict = field(default_factory=dict)
    damaged: list = field(default_factory=list)
    transactions: int = 0


def scan_file(path: str | os.PathLike) -> FileScan:
    """Read every data record of the ``FileStorage`` file ``path``.

    Raises
    ------
    DatabaseError
        Not a ``FileStorage`` file (empty, or another format).
    """
    data = Path(path).read_bytes()
    if len(data) == 0 or not data.startswith(packed_version):
        raise DatabaseError(f"{path}: not a ZODB FileStorage file; nothing can be read from it")
    scan = FileScan(len(data), len(packed_version))
    pos = len(packed_version)
    whole = True
    while pos + _TRANS_HDR.size <= len(data):
        tid, length, status, ul, dl, el = _TRANS_HDR.unpack_from(data, pos)
        end = pos + length
        header_ok = status in b" pu" and length >= _TRANS_HDR.size + ul + dl + el
        if not header_ok:
            scan.damaged.append((pos, len(data)))
            break
        scan.transactions += 1
        complete = end + 8 <= len(data) and struct.unpack_from(">Q", data, end)[0] == length
        if whole and complete and status != b"u":
            whole = _read_records(data, pos, pos + _TRANS_HDR.size + ul + dl + el, end, tid, scan)
            scan.whole_end = end + 8 if whole else scan.whole_end
        elif status != b"u":
            whole = False
            _read_records(data, pos, pos + _TRANS_HDR.size + ul + dl + el, end, tid, scan)
        if not complete:
            break
        pos = end + 8
    if pos < len(data) and pos + _TRANS_HDR.size > len(data):
        scan.damaged.append((pos, len(data)))
    return scan


def _read_records(data: bytes, tpos: int, pos: int, tend: int, tid: bytes, scan) -> bool:
    """Read the data records of the transaction at ``tpos`` (records from ``pos`` to
    ``tend``, or to the end of the file when that is cut short) into ``scan``;
    False when some of it was damaged."""
    stop = min(tend, len(data))
    whole = True
    while pos + _DATA_HDR.size <= stop:
        oid, rtid, _prev, tloc, vlen, plen = _DATA_HDR.unpack_from(data, pos)
        start = pos + _DATA_HDR.size
        if rtid != tid or tloc != tpos or vlen or start + plen > stop:
            whole = False
            found = _next_record(data, pos + 1, stop, tid, tpos)
            scan.damaged.append((pos, found))
            pos = found
            continue
        if plen:  # 0: a back pointer (undo), no data of its own
            scan.records[oid] = data[start : start + plen]
        pos = start + (plen or 8)
    if pos < stop:
        scan.damaged.append((pos, stop))
    return whole and pos == tend


def _next_record(data: bytes, pos: int, stop: int, tid: bytes, tpos: int) -> int:
    """Where the next data record of the transaction ``tid`` at ``tpos`` starts after
    ``pos`` (its header repeats both), or ``stop``."""
    tloc = struct.pack(">Q", tpos)
    while True:
        at = data.find(tid, pos + 8, stop)
        if at < 0:
            return stop
        start = at - 8
        if data[at + 16 : at + 24] == tloc and start >= pos:
            return start
        pos = at - 7


@dataclass
class DatabaseInspection:
    """What :func:`inspect_database` found.

    Attributes
    ----------
    readable : str or None
        None when the database opens as a query would open it and its B-tree, records
        and columns agree (:meth:`Store.check`); else why not.
    scan : FileScan
    index : str
        The state of the ``.index`` file: ``"whole"``, ``"missing"`` or ``"damaged"``.
    problem : str or None
        Why nothing can be recovered (its eigenspace or configuration unreadable).
    n_motions, n_entries : int
        What the database's counters say it holds (-1 when unreadable).
    intact : list of int
        Motion ids whose record, sequences and every entry are readable.
    damaged_motions : list of int
        The others.
    n_intact_entries : int
        Entries of the intact motions.
    """

    readable: str | None
    scan: FileScan
    index: str
    problem: str | None = None
    n_motions: int = -1
    n_entries: int = -1
    intact: list = field(default_factory=list)
    damaged_motions: list = field(default_factory=list)
    n_intact_entries: int = 0
    store: Store | None = None


def _records_store(path: str, records: dict) -> Store | None:
    """A read-only :class:`Store` over salvaged records (None without a root)."""
    if z64 not in records:
        return None
    storage = MappingStorage()
    meta = TransactionMetaData()
    storage.tpc_begin(meta)
    for oid, pickle in records.items():
        storage.store(oid, z64, pickle, "", meta)
    storage.tpc_vote(meta)
    storage.tpc_finish(meta)
    return Store(str(path), ZODB.DB(storage, class_factory=allowed_class), True)


def _attempt(read: Callable):
    """``(value, None)`` or ``(None, why)`` for a read of damaged data."""
    try:
        return read(), None
    except EigmotionError as exc:
        return None, str(exc)
    except Exception as exc:  # a missing or damaged object
        return None, f"{type(exc).__name__}: {' '.join(str(exc).split())[:120]}"


def inspect_database(uri: str | os.PathLike) -> DatabaseInspection:
    """Read a database file as far as it can be read (never writing to it).

    Returns
    -------
    DatabaseInspection
        With ``store`` open over the salvaged records (close it), or None.

    Raises
    ------
    DatabaseError
        A ``zeo://`` or ``memory://`` URI, no such file, or not a FileStorage file.
    """
    text = os.fspath(uri)
    scheme, path = parse_uri(text)
    if scheme != "file":
        raise DatabaseError(f"{text}: only a database file can be checked and repaired")
    if not Path(path).is_file():
        raise DatabaseError(f"{text}: no such database file")
    index_path = Path(f"{path}.index")
    index = "missing" if not index_path.exists() else "whole"
    if index == "whole" and not check_index_file(index_path):
        index = "damaged"

    def opened():
        with Store.open(text, read_only=True) as store:
            store.check()  # the B-tree, the records and the columns agree

    _, readable = _attempt(opened)
    found = DatabaseInspection(readable, scan_file(path), index)
    store, why = _attempt(lambda: _records_store(path, found.scan.records))
    if store is None:
        found.problem = f"its root object is unreadable ({why})" if why else "its root is lost"
        return found
    found.store = store
    root = store._conn.root
    version, why = _attempt(lambda: root()["schema_version"])
    if why or version != SCHEMA_VERSION:
        found.problem = why or f"schema version {version!r}, this eigmotion reads {SCHEMA_VERSION}"
        return found
    for what, read in (
        ("configuration", lambda: store.config),
        ("eigenspace", store.eigenspace),
        ("key quantizer", store.quantizer),
        ("pose eigenspace", store.pose_space),
    ):
        _, why = _attempt(read)
        if why:
            found.problem = f"its {what} is unreadable ({why})"
            return found
    counters, why = _attempt(lambda: dict(root()["counters"]))
    if why:
        found.problem = f"its counters are unreadable ({why})"
        return found
    found.n_motions, found.n_entries = int(counters["next_motion"]), int(counters["next_entry"])
    owners, _ = _attempt(lambda: store.arrays().motions)
    entries_of: dict[int, int] = {}
    lost_entries = 0
    for entry_id in range(found.n_entries):
        entry, why = _attempt(lambda entry_id=entry_id: store.entry(entry_id))
        if entry is not None:
            entries_of[entry["motion"]] = entries_of.get(entry["motion"], 0) + 1
        elif owners is not None:
            entries_of[int(owners[entry_id])] = -(10**12)  # a lost entry: never intact
        else:
            lost_entries += 1
    for motion_id in range(found.n_motions):
        ok = entries_of.get(motion_id, 0) > 0 and not lost_entries
        ok = ok and _attempt(lambda m=motion_id: store.motion(m))[1] is None
        ok = ok and _attempt(lambda m=motion_id: store.sequences(m))[1] is None
        (found.intact if ok else found.damaged_motions).append(motion_id)
        found.n_intact_entries += entries_of.get(motion_id, 0) if ok else 0
    return found


def report_lines(found: DatabaseInspection, uri: str) -> list[str]:
    """What ``eigmotion check`` prints about ``found``, one fact a line."""
    scan = found.scan
    lines = [
        f"{uri}: {scan.size} bytes, {scan.transactions} transactions; "
        + ("readable" if found.readable is None else f"NOT readable: {found.readable}")
    ]
    if scan.whole_end != scan.size:
        lines.append(
            f"damaged at its end: bytes {scan.whole_end}..{scan.size} are not whole "
            "transactions (ZODB reads the database as it was before them)"
        )
    for start, stop in scan.damaged[:5]:
        lines.append(f"unreadable bytes {start}..{stop}")
    if len(scan.damaged) > 5:
        lines.append(f"… and {len(scan.damaged) - 5} more unreadable ranges")
    lines.append(f"index {uri}.index: {found.index}")
    if found.problem:
        lines.append(f"nothing can be recovered: {found.problem}")
        return lines
    lines.append(
        f"{len(found.intact)} of {found.n_motions} motions intact, with "
        f"{found.n_intact_entries} of {found.n_entries} entries"
    )
    if found.damaged_motions:
        shown = ", ".join(str(m) for m in found.damaged_motions[:20])
        more = "…" if len(found.damaged_motions) > 20 else ""
        lines.append(f"damaged motions (ids): {shown}{more}")
    return lines


def repair_database(found: DatabaseInspection, out: str | os.PathLike) -> int:
    """Copy the intact motions of an inspected database into a new database ``out``
    (motion and entry ids renumbered from 0, the B-tree and packed columns made again
    from the entries); returns how many motions were copied.

    Raises
    ------
    DatabaseError
        Nothing can be recovered, or ``out`` exists.
    """
    if found.problem or found.store is None:
        raise DatabaseError(f"nothing can be recovered: {found.problem}")
    if parse_uri(os.fspath(out))[0] == "file" and Path(parse_uri(os.fspath(out))[1]).exists():
        raise DatabaseError(f"{out}: exists; the repaired copy goes to a new file")
    source = found.store
    with replacing(out) as target:
        new = Store.create(target)
        try:
            with new.transaction():
                new.initialise(
                    source.config, source.eigenspace(), source.quantizer(), source.pose_space()
                )
                _copy_motions(source, new, found.intact, found.n_entries)
        finally:
            new.close()
    return len(found.intact)


def _copy_motions(source: Store, new: Store, motion_ids: list, n_entries: int) -> None:
    renumbered = {}
    for motion_id in motion_ids:
        record = source.motion(motion_id)
        renumbered[motion_id] = new.add_motion(
            record["label"], record["source"], record["bvh"], record["metadata"]
        )
    rows = []
    for entry_id in range(n_entries):
        try:
            entry = source.entry(entry_id)
        except DatabaseError:
            continue
        if entry["motion"] in renumbered:
            rows.append(entry)
    if rows:
        new.add_entries(
            [renumbered[e["motion"]] for e in rows],
            np.stack([e["point"] for e in rows]),
            np.array([e["key"] for e in rows], dtype=np.int64),
            [e["view_azimuth_deg"] for e in rows],
            [e["view_elevation_deg"] for e in rows],
            np.array([e["start_frame"] for e in rows], dtype=np.int64),
            np.array([e["end_frame"] for e in rows], dtype=np.int64),
            [e["label"] for e in rows],
            np.array([e["body"] for e in rows]) if all("body" in e for e in rows) else None,
        )
    for motion_id in motion_ids:
        stored = source.sequences(motion_id)
        bounds = np.cumsum(stored.lengths)[:-1]
        new.add_sequences(
            renumbered[motion_id],
            stored.azimuth_deg,
            stored.elevation_deg,
            np.split(stored.frames, bounds) if len(stored.lengths) else [],
        )
