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
from ZODB.MappingStorage import MappingStorage

from eigmotion import resources
from eigmotion.errors import DatabaseError

#: Where ``eigmotion build`` with no options writes.
DEFAULT_DB_PATH = resources.default_database()

#: Seconds a ``zeo://`` open waits for the server.
ZEO_WAIT_S = 10.0

#: The files a ``FileStorage`` at ``path`` may have: ``path`` followed by each suffix.
FILE_SUFFIXES = ("", ".index", ".lock", ".tmp", ".old")


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


def open_zodb(scheme: str, target: str, uri: str, read_only: bool) -> ZODB.DB:
    """The ``ZODB.DB`` of a :func:`parse_uri`'d database.

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
        The storage cannot be opened (a lock held elsewhere, a damaged file, no
        permission) or no ZEO server answered within :data:`ZEO_WAIT_S`.
    """
    try:
        if scheme == "memory":
            storage = MappingStorage()
        elif scheme == "file":
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
