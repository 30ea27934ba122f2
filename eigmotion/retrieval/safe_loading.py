"""What a database may make Python build when it is read: an allow-list.

Unpickling runs whatever a pickle names, so a database file (or a ZEO server) would
otherwise have to be trusted like a program.  A database of this package holds only
plain data (numbers, strings, bytes, tuples, dicts) in ZODB's own containers
(:mod:`eigmotion.retrieval.schema`), so :func:`allowed_class` — the ``class_factory``
every ``ZODB.DB`` here is opened with — resolves those containers and refuses any
other name before it is imported or called; :func:`check_index_file` refuses a
FileStorage ``.index`` (which ZODB unpickles with no such hook) that names any Python
object at all.
"""

from __future__ import annotations

import io
import pickle
from pathlib import Path

from BTrees.LLBTree import LLBTree, LLBucket, LLSet, LLTreeSet
from BTrees.LOBTree import LOBTree, LOBucket
from persistent.list import PersistentList
from persistent.mapping import PersistentMapping

from eigmotion.errors import DatabaseError

#: (module, name) → class: everything a stored object may be.
ALLOWED_CLASSES = {
    ("persistent.mapping", "PersistentMapping"): PersistentMapping,
    ("ZODB.PersistentMapping", "PersistentMapping"): PersistentMapping,
    ("persistent.list", "PersistentList"): PersistentList,
    ("BTrees.LOBTree", "LOBTree"): LOBTree,
    ("BTrees.LOBTree", "LOBucket"): LOBucket,
    ("BTrees.LLBTree", "LLBTree"): LLBTree,
    ("BTrees.LLBTree", "LLBucket"): LLBucket,
    ("BTrees.LLBTree", "LLTreeSet"): LLTreeSet,
    ("BTrees.LLBTree", "LLSet"): LLSet,
}

#: Longest module or name quoted in a refusal.
_QUOTED_CHARS = 60


class RefusedObjectError(DatabaseError):
    """A stored object names a Python global outside :data:`ALLOWED_CLASSES`."""


def _quoted(module: str, name: str) -> str:
    text = f"{module}.{name}"
    return text if len(text) <= _QUOTED_CHARS else text[:_QUOTED_CHARS] + "…"


def allowed_class(connection, module: str, name: str):
    """The ``class_factory`` of ``ZODB.DB``: a class of :data:`ALLOWED_CLASSES`.

    Raises
    ------
    RefusedObjectError
        Any other global (a function such as ``os.system``, a class of some other
        package): it is neither imported nor called.
    """
    found = ALLOWED_CLASSES.get((module, name))
    if found is None:
        raise RefusedObjectError(
            f"it holds an object of {_quoted(module, name)!r}, which an eigmotion database "
            "never stores; refused unread (it could run code)"
        )
    return found


class _PlainDataUnpickler(pickle.Unpickler):
    def find_class(self, module: str, name: str):
        raise RefusedObjectError(
            f"names {_quoted(module, name)!r}, which a FileStorage index never holds; "
            "refused unread (it could run code)"
        )


def check_index_file(path: str | Path) -> bool:
    """Whether the FileStorage index ``path`` can be read as plain data.

    ZODB reads ``DB.fs.index`` with an unrestricted unpickler before anything else,
    so it is read here first with one that builds nothing but plain data.

    Returns
    -------
    bool
        True when it reads whole; False when it is missing or damaged (ZODB then
        ignores it and scans the data file).

    Raises
    ------
    DatabaseError
        It names a Python object (a crafted file): opening would run code.
    """
    try:
        data = Path(path).read_bytes()
    except FileNotFoundError:
        return False
    except OSError as exc:
        raise DatabaseError(f"{path}: cannot read: {exc.strerror or exc}") from exc
    unpickler = _PlainDataUnpickler(io.BytesIO(data))
    try:
        while unpickler.load() is not None:
            pass
    except RefusedObjectError as exc:
        raise DatabaseError(f"{path}: {exc}") from None
    except Exception:
        return False
    return True
