"""Where a motion database lives: its URI, the ZODB storage behind it, its files.

A database is named by URI:

``path`` or ``file:///abs/path.fs``
    A ZODB ``FileStorage`` file (the default, :data:`DEFAULT_DB_PATH`).
``memory://``
    A ``MappingStorage`` in this process, for tests; it lives as long as the
    :class:`~eigmotion.retrieval.store.Store` that created it.
``zeo://host:port``
    A ZEO server's storage (``ZEO.ClientStorage``), shared by many processes.

:func:`open_zodb` opens the ``ZODB.DB`` of one (ZEO is imported only for a
``zeo://`` address); :func:`replacing` gives a build a side file that is moved over the
target only once the build succeeded.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from pathlib import Path
from urllib.parse import unquote, urlparse

import ZODB
from ZODB.FileStorage import FileStorage
from ZODB.FileStorage.FileStorage import packed_version
from ZODB.MappingStorage import MappingStorage

from eigmotion import resources
from eigmotion.errors import DatabaseError
from eigmotion.retrieval.safe_loading import allowed_class, check_index_file

#: Where ``eigmotion build`` with no options writes.
DEFAULT_DB_PATH = resources.default_database()

#: Seconds a ``zeo://`` open waits for the server.
ZEO_WAIT_S = 10.0

#: The files a ``FileStorage`` at ``path`` may have: ``path`` followed by each suffix.
FILE_SUFFIXES = ("", ".index", ".lock", ".tmp", ".old", ".index.index_tmp")

#: What to tell the owner of a damaged database file (formatted with ``path``).
RECOVERY_HINT = (
    "nothing was changed; 'eigmotion check {path}' tells more and "
    "'eigmotion repair {path} --out NEW.fs' copies every intact motion into a new file"
)


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
        try:
            port = parsed.port
        except ValueError:  # not a number, or beyond 65535
            port = -1
        if not parsed.hostname or port is None:
            raise DatabaseError(f"{text}: a ZEO address needs host and port (zeo://host:port)")
        if not 0 < port < 65536:
            raise DatabaseError(f"{text}: the port must be a number from 1 to 65535")
        return "zeo", f"{parsed.hostname}:{port}"
    raise DatabaseError(
        f"{text}: unknown database scheme {scheme!r}; use a path, file://, "
        "memory:// or zeo://host:port"
    )


#: Objects a connection keeps in memory between transactions.  A query reads few
#: objects (its columns); a build or an index writes each motion's entries in a
#: transaction of its own and would otherwise read the B-tree's buckets back from the
#: file for every motion (ZODB's default keeps 400).
READ_CACHE_OBJECTS = 400
WRITE_CACHE_OBJECTS = 1_000_000


def open_zodb(scheme: str, target: str, uri: str, read_only: bool) -> ZODB.DB:
    """The ``ZODB.DB`` of a :func:`parse_uri`'d database.

    Every object is read through :func:`~eigmotion.retrieval.safe_loading.allowed_class`,
    so a database can name no class but ZODB's own containers.  A file is first opened
    read-only and verified (:func:`verified_file_storage`), and opened for writing
    only when whole: ZODB itself would cut a damaged end off a file it opens for
    writing.

    Parameters
    ----------
    scheme, target : str
        As :func:`parse_uri` returns them.
    uri : str
        The URI itself, for messages.
    read_only : bool

    Raises
    ------
    DatabaseError
        The storage cannot be opened (a lock held elsewhere, a damaged, empty or
        foreign file, no permission) or no ZEO server answered within
        :data:`ZEO_WAIT_S`.
    """
    try:
        if scheme == "memory":
            storage = MappingStorage()
        elif scheme == "file" and not read_only and not Path(target).exists():
            storage = _writable_file_storage(target, uri)  # a new database
        elif scheme == "file":
            storage = verified_file_storage(target, uri, for_writing=not read_only)
            if not read_only:
                storage.close()
                storage = _writable_file_storage(target, uri)
        else:
            storage = _zeo_storage(target, uri, read_only)
    except DatabaseError:
        raise
    except Exception as exc:  # lock held elsewhere, permissions
        raise DatabaseError(f"{uri}: cannot open database: {_short(exc)}") from exc
    try:
        return ZODB.DB(
            storage,
            large_record_size=1 << 31,
            class_factory=allowed_class,
            cache_size=READ_CACHE_OBJECTS if read_only else WRITE_CACHE_OBJECTS,
        )
    except Exception as exc:
        storage.close()
        raise DatabaseError(f"{uri}: cannot open database: {_short(exc)}") from exc


def _short(exc: BaseException, limit: int = 200) -> str:
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text if len(text) <= limit else text[:limit] + "…"


def _zeo_storage(target: str, uri: str, read_only: bool):
    from ZEO.ClientStorage import ClientStorage
    from ZEO.Exceptions import ClientDisconnected

    host, port = target.rsplit(":", 1)
    try:
        return ClientStorage(
            (host, int(port)),
            read_only=read_only,
            wait_timeout=ZEO_WAIT_S,
            # a new transaction asks the server, so refresh() sees every
            # commit made before it was called
            server_sync=True,
        )
    except ClientDisconnected as exc:
        raise DatabaseError(f"{uri}: no ZEO server answered ({exc})") from exc


def check_target(uri: str | os.PathLike) -> None:
    """Before long work that ends by writing a database at ``uri``: DatabaseError
    unless a ``zeo://`` server answers, or a file's folder exists."""
    text = os.fspath(uri)
    scheme, target = parse_uri(text)
    if scheme == "zeo":
        _zeo_storage(target, text, read_only=True).close()
    elif scheme == "file" and not Path(target).parent.is_dir():
        raise DatabaseError(f"{target}: folder {Path(target).parent} does not exist")


def verified_file_storage(path: str, uri: str, for_writing: bool = False) -> FileStorage:
    """A ``FileStorage`` file opened read-only (no lock, nothing written), after checking
    that it is one and whole.

    Parameters
    ----------
    path : str
    uri : str
        For messages.
    for_writing : bool
        Also refuse a damaged ``.index`` (a writable open would rewrite it).

    Raises
    ------
    DatabaseError
        No such file, an empty file, not a FileStorage file, an index that names
        Python objects, or a file damaged at its end (the damaged tail is left as
        it is, with :data:`RECOVERY_HINT`).
    """
    file = Path(path)
    if not file.is_file():
        raise DatabaseError(f"{uri}: no such database file")
    with open(file, "rb") as f:
        magic = f.read(len(packed_version))
        size = f.seek(0, os.SEEK_END)
    if size == 0:
        raise DatabaseError(f"{uri}: an empty file, not an eigmotion database")
    if magic != packed_version:
        raise DatabaseError(f"{uri}: not an eigmotion database (not a ZODB FileStorage file)")
    index_whole = check_index_file(f"{path}.index")
    try:
        storage = FileStorage(path, read_only=True)
    except Exception as exc:
        raise DatabaseError(
            f"{uri}: damaged ({_short(exc)}); {RECOVERY_HINT.format(path=path)}"
        ) from exc
    damaged = None
    if storage._pos != size:
        damaged = (
            f"damaged at its end: bytes {storage._pos}..{size} are not a whole transaction "
            "(the database reads as it was before it)"
        )
    elif for_writing and Path(f"{path}.index").exists() and not index_whole:
        damaged = f"its index {path}.index is damaged"
    if damaged and for_writing:
        storage.close()
        raise DatabaseError(f"{uri}: {damaged}; {RECOVERY_HINT.format(path=path)}")
    #: read by Store.open to explain a database that cannot be read
    storage.eigmotion_damage = damaged and f"{damaged}; {RECOVERY_HINT.format(path=path)}"
    return storage


def _writable_file_storage(path: str, uri: str) -> FileStorage:
    """``FileStorage(path)`` for writing, its lock checked to be the file at
    ``path.lock`` (a lock file is removed when its database is closed,
    :func:`close_file_storage`; a lock taken on one just removed is no lock)."""
    storage = FileStorage(path)
    lock = storage._lock_file._fp
    try:
        same = os.fstat(lock.fileno()).st_ino == os.stat(f"{path}.lock").st_ino
    except OSError:
        same = False
    if not same:
        storage.close()
        raise DatabaseError(f"{uri}: another process is opening it for writing; try again")
    return storage


def close_writable_file_storage(storage: FileStorage) -> None:
    """Remove the ``.tmp`` and ``.lock`` files of a ``FileStorage`` open for writing,
    while its lock is still held (so no other writer can hold it), before it is
    closed: a database nobody has open leaves no lock file beside it."""
    name = storage._file_name
    for suffix in (".tmp", ".lock"):
        with contextlib.suppress(OSError):
            os.unlink(f"{name}{suffix}")


def remove_file_storage(path: str | os.PathLike) -> None:
    """Delete the files of a ``FileStorage`` at ``path`` (:data:`FILE_SUFFIXES`), those
    that exist."""
    for suffix in FILE_SUFFIXES:
        with contextlib.suppress(FileNotFoundError):
            Path(f"{path}{suffix}").unlink()


@contextlib.contextmanager
def replacing(uri: str | os.PathLike) -> Iterator[str]:
    """Yield where to write a new database; for files, a side file moved over the
    target only when the block succeeds (and removed when it fails).

    Raises
    ------
    DatabaseError
        The target file's folder does not exist.
    """
    text = os.fspath(uri)
    scheme, target = parse_uri(text)
    if scheme != "file":
        yield text
        return
    path = Path(target)
    if not path.parent.is_dir():
        raise DatabaseError(f"{path}: folder {path.parent} does not exist")
    side = path.with_name(path.name + ".building")
    remove_file_storage(side)
    try:
        yield str(side)
    except BaseException:
        remove_file_storage(side)
        raise
    for suffix in (".index", ".lock", ".tmp"):
        with contextlib.suppress(FileNotFoundError):
            Path(f"{path}{suffix}").unlink()
    os.replace(side, path)
    with contextlib.suppress(FileNotFoundError):
        os.replace(f"{side}.index", f"{path}.index")
    remove_file_storage(side)
