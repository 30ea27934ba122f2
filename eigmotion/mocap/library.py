"""The library of basic motions: a TOML manifest of labelled, trimmed motion clips.

The bundled manifest is ``database/motions/library.toml``; each ``[[motion]]`` table
names one basic motion::

    [[motion]]
    name = "pick_up_02_06_a"           # unique, letters, digits, "_" and "-"
    label = "pick_up"                  # one of LABELS (or DISTRACTOR_LABELS)
    source = ["cmu/amc/02_06.amc", "cmu/asf/02.asf"]   # or "authored/x.bvh"
    frame_range = [30, 235]            # [start, stop): 0-based frames of the source
    performer = "cmu_02"
    variation = "first repetition"
    licence = "CMU mocap: free for research and commercial use"
    attribution = "mocap.cs.cmu.edu, NSF EIA-0196217"
    role = "basic"                     # optional: "basic" (default) or "distractor"
    mirror = true                      # optional: also its mirror image (default false)
    action = [0.2, 1.4]                # optional: the seconds that show the action
    filler = "walk"                    # optional, with action: "walk" or "run" around it

Paths are relative to the manifest's folder.  ``frame_range`` counts the frames of
the file as read (frame 0 is the first frame of an AMC file, whatever number the file
gives it) and is half-open, as :meth:`eigmotion.mocap.motion.Motion.trim`; without it the
whole file is used.  Motions with ``role = "distractor"`` are real motions that are
*not* basic motions: they are left out of the default library and serve to test that
unknown motions are rejected.

``mirror = true`` adds the entry's mirror image (:func:`eigmotion.mocap.mirror.mirror_motion`:
left and right swapped, a left-handed wave from a right-handed one) to the library as a
motion of its own, named ``<name>_mirror``, with the same label, performer, role and
source.  :func:`load_library` makes it, right after the original, so everything that
takes the library (the build, the benchmarks, ``eigmotion show``) sees it as any other
motion.

``action = [start_s, stop_s]`` marks the part of the motion that shows its labelled
action, in seconds from the first frame of ``frame_range`` (``0 <= start_s < stop_s``,
``stop_s`` at most the motion's duration); without it the whole motion shows the
action.  ``filler`` names what the person does before and after it: ``"walk"`` or
``"run"`` (:data:`FILLER_LABELS`), as on the way into a walking turn or a running
jump.  The build labels the sliding windows mostly outside the action with the filler,
or leaves them out when there is no filler (standing before an action is not the
action); see :func:`eigmotion.retrieval.library_views.window_labels`.  A mirror image keeps both.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import re
import tomllib
from dataclasses import dataclass
from pathlib import Path

from eigmotion import resources
from eigmotion.errors import InvalidParameterError
from eigmotion.mocap.amc import read_amc
from eigmotion.mocap.bvh import read_bvh
from eigmotion.mocap.mirror import mirror_motion
from eigmotion.mocap.motion import Motion

#: The basic-motion labels: the patent's six examples, then those of the CMU clips.
LABELS = (
    "lift",
    "pick_up",
    "sit_down",
    "cover_head",
    "walk",
    "fall_down",
    "run",
    "jump",
    "wave",
    "kick",
    "punch",
    "turn",
)

#: Labels of distractor motions (not basic motions; kept to test rejection).
DISTRACTOR_LABELS = ("duck", "block")

#: Labels that carry a person to or from an action rather than being one (the walking
#: into a turn, the run-up of a jump): the values ``filler`` may take, and the answers a
#: query gives up for an action shown by windows of the clip (see
#: :meth:`eigmotion.retrieval.database.MotionDatabase.query_masks`).
FILLER_LABELS = frozenset({"walk", "run"})

#: Roles a manifest entry may have.
ROLES = ("basic", "distractor")

#: Appended to a motion's name to name its mirror image.
MIRROR_SUFFIX = "_mirror"

#: The bundled manifest (in the source tree, next to the motion files it lists).
DEFAULT_MANIFEST = resources.library_manifest()

_NAME = re.compile(r"[A-Za-z0-9_-]+")
_TEXT_FIELDS = ("performer", "variation", "licence", "attribution")
_KNOWN_FIELDS = {
    "name",
    "label",
    "source",
    "frame_range",
    "role",
    "mirror",
    "action",
    "filler",
    *_TEXT_FIELDS,
}


@dataclass(frozen=True)
class ManifestEntry:
    """One ``[[motion]]`` table of a manifest, checked, motion not loaded.

    Attributes
    ----------
    name, label : str
    source : tuple of Path
        Absolute paths: ``(bvh,)`` or ``(amc, asf)``.
    frame_range : (int, int) or None
        ``[start, stop)`` in the source's frames, or ``None`` for the whole file.
    performer, variation, licence, attribution : str
    role : str
        ``"basic"`` or ``"distractor"``.
    mirror : bool
        The library also holds the motion's mirror image, named ``name + MIRROR_SUFFIX``.
    action : (float, float) or None
        ``[start, stop)`` seconds of the trimmed motion that show the labelled action;
        ``None``: all of it.
    filler : str or None
        Label of the parts before and after ``action`` (one of :data:`FILLER_LABELS`),
        or ``None`` when they show nothing to label.
    """

    name: str
    label: str
    source: tuple[Path, ...]
    frame_range: tuple[int, int] | None
    performer: str
    variation: str
    licence: str
    attribution: str
    role: str
    mirror: bool = False
    action: tuple[float, float] | None = None
    filler: str | None = None


@dataclass(frozen=True, eq=False)
class LibraryMotion:
    """A basic motion of the library, loaded and trimmed.

    Attributes
    ----------
    name : str
        Unique name in the library.
    label : str
        What the motion is (one of :data:`LABELS`, or :data:`DISTRACTOR_LABELS`).
    motion : Motion
        The trimmed motion, named ``name``, on the source file's own skeleton.
    source : tuple of Path
        The file(s) it was read from.
    performer, variation, licence, attribution : str
    role : str
        ``"basic"`` or ``"distractor"``.
    frame_range : (int, int) or None
        The frames of the source that were kept.
    mirror_of : str or None
        For a mirror image, the name of the motion it mirrors; ``None`` otherwise.
    action : (float, float) or None
        ``[start, stop)`` seconds of ``motion`` that show the labelled action;
        ``None``: all of it.
    filler : str or None
        Label of the parts before and after ``action`` (one of :data:`FILLER_LABELS`),
        or ``None`` when they show nothing to label.
    """

    name: str
    label: str
    motion: Motion
    source: tuple[Path, ...]
    performer: str
    variation: str
    licence: str
    role: str
    attribution: str = ""
    frame_range: tuple[int, int] | None = None
    mirror_of: str | None = None
    action: tuple[float, float] | None = None
    filler: str | None = None


def read_manifest(manifest: str | Path | None = None) -> list[ManifestEntry]:
    """Read and check a library manifest without loading any motion.

    Parameters
    ----------
    manifest : str or Path, optional
        A ``library.toml``; default :data:`DEFAULT_MANIFEST`.

    Returns
    -------
    list of ManifestEntry
        In file order.

    Raises
    ------
    InvalidParameterError
        The manifest is missing or not valid TOML, or an entry lacks a field, has a
        field of the wrong type, an unknown label or role, a duplicate name (mirror
        names included), a source that is neither one ``.bvh`` nor an ``.amc``
        with its ``.asf``, an ``action`` that is not ``[start_s, stop_s]`` with
        ``0 <= start_s < stop_s``, or a ``filler`` that is not one of
        :data:`FILLER_LABELS`, has no ``action`` or equals the label.
    """
    path = Path(DEFAULT_MANIFEST if manifest is None else manifest)
    if not path.is_file():
        raise InvalidParameterError(f"motion library manifest not found: {path}")
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except ValueError as exc:  # a decode error, bad UTF-8, a number too long
        raise InvalidParameterError(f"{path}: not a valid TOML manifest: {exc}") from None
    tables = data.get("motion", [])
    if not isinstance(tables, list) or not tables:
        raise InvalidParameterError(f"{path}: expected one or more [[motion]] tables")
    entries = []
    seen: set[str] = set()
    for i, table in enumerate(tables, start=1):
        entry = _entry(table, path, i)
        for name in _names(entry):
            if name in seen:
                raise InvalidParameterError(f"{path}: motion #{i}: duplicate name {name!r}")
            seen.add(name)
        entries.append(entry)
    return entries


def _names(entry: ManifestEntry) -> list[str]:
    """The entry's name, then its mirror image's when it has one."""
    return [entry.name, entry.name + MIRROR_SUFFIX] if entry.mirror else [entry.name]


def _entry(table: dict, path: Path, index: int) -> ManifestEntry:
    where = f"{path}: motion #{index}"
    if not isinstance(table, dict):
        raise InvalidParameterError(f"{where}: expected a table")
    if isinstance(table.get("name"), str):
        where += f" ({table['name']})"
    unknown = sorted(set(table) - _KNOWN_FIELDS)
    if unknown:
        raise InvalidParameterError(
            f"{where}: unknown field(s) {unknown}; known: {sorted(_KNOWN_FIELDS)}"
        )
    fields = {}
    for key in ("name", "label", *_TEXT_FIELDS):
        value = table.get(key)
        if not isinstance(value, str) or not value.strip():
            raise InvalidParameterError(f"{where}: field {key!r} must be a non-empty string")
        fields[key] = value
    if not _NAME.fullmatch(fields["name"]):
        raise InvalidParameterError(
            f"{where}: name {fields['name']!r} may hold only letters, digits, '_' and '-'"
        )
    mirror = table.get("mirror", False)
    if not isinstance(mirror, bool):
        raise InvalidParameterError(f"{where}: mirror must be true or false, got {mirror!r}")
    role = table.get("role", "basic")
    if role not in ROLES:
        raise InvalidParameterError(f"{where}: role must be one of {list(ROLES)}, got {role!r}")
    allowed = LABELS if role == "basic" else DISTRACTOR_LABELS
    if fields["label"] not in allowed:
        raise InvalidParameterError(
            f"{where}: label {fields['label']!r} is not a known {role} label; "
            f"known: {', '.join(allowed)}"
        )
    action = _action(table.get("action"), where)
    return ManifestEntry(
        name=fields["name"],
        label=fields["label"],
        source=_source(table.get("source"), path.parent, where),
        frame_range=_frame_range(table.get("frame_range"), where),
        performer=fields["performer"],
        variation=fields["variation"],
        licence=fields["licence"],
        attribution=fields["attribution"],
        role=role,
        mirror=mirror,
        action=action,
        filler=_filler(table.get("filler"), action, fields["label"], where),
    )


def _source(value, base: Path, where: str) -> tuple[Path, ...]:
    items = [value] if isinstance(value, str) else value
    if not isinstance(items, list) or not all(isinstance(s, str) and s for s in items):
        raise InvalidParameterError(
            f"{where}: source must be a path or a list of paths, got {value!r}"
        )
    suffixes = sorted(Path(s).suffix.lower() for s in items)
    if suffixes not in ([".bvh"], [".amc", ".asf"]):
        raise InvalidParameterError(
            f"{where}: source must be one .bvh file or an .amc file with its .asf, got {items}"
        )
    paths = sorted((base / s for s in items), key=lambda p: p.suffix.lower())
    return tuple(p.resolve() for p in paths)


def _frame_range(value, where: str) -> tuple[int, int] | None:
    if value is None:
        return None
    ok = (
        isinstance(value, list)
        and len(value) == 2
        and all(isinstance(v, int) and not isinstance(v, bool) for v in value)
        and 0 <= value[0] < value[1]
    )
    if not ok:
        raise InvalidParameterError(
            f"{where}: frame_range must be [start, stop] with 0 <= start < stop, got {value!r}"
        )
    return int(value[0]), int(value[1])


def _action(value, where: str) -> tuple[float, float] | None:
    if value is None:
        return None
    ok = (
        isinstance(value, list)
        and len(value) == 2
        and all(isinstance(v, int | float) and not isinstance(v, bool) for v in value)
        and all(math.isfinite(v) for v in value)
        and 0 <= value[0] < value[1]
    )
    if not ok:
        raise InvalidParameterError(
            f"{where}: action must be [start_s, stop_s] seconds with 0 <= start_s < stop_s, "
            f"got {value!r}"
        )
    return float(value[0]), float(value[1])


def _filler(value, action: tuple[float, float] | None, label: str, where: str) -> str | None:
    if value is None:
        return None
    known = ", ".join(sorted(FILLER_LABELS))
    if value not in FILLER_LABELS:
        raise InvalidParameterError(f"{where}: filler must be one of {known}, got {value!r}")
    if action is None:
        raise InvalidParameterError(
            f"{where}: filler {value!r} needs an action = [start_s, stop_s] to lie around"
        )
    if value == label:
        raise InvalidParameterError(f"{where}: filler {value!r} is the motion's own label")
    return value


def load_entry(entry: ManifestEntry) -> LibraryMotion:
    """Read one manifest entry's motion and trim it.

    Parameters
    ----------
    entry : ManifestEntry
        From :func:`read_manifest`.

    Returns
    -------
    LibraryMotion
        The motion itself (its mirror image, if any: :func:`mirror_image`).

    Raises
    ------
    InvalidParameterError
        A source file is missing, ``frame_range`` runs past the end of the file, or
        ``action`` past the end of the trimmed motion.
    MotionFormatError
        A source file cannot be parsed.
    """
    return _load_entry(entry, None)


def _load_entry(entry: ManifestEntry, cache: dict | None) -> LibraryMotion:
    """:func:`load_entry`, reusing motions already read into ``cache`` (source → Motion)."""
    for p in entry.source:
        if not p.is_file():
            raise InvalidParameterError(f"library motion {entry.name!r}: file not found: {p}")
    if cache is not None and entry.source in cache:
        # Several clips cut from one long file read it once.
        motion = cache[entry.source]
    else:
        motion = _read_motion_file(*entry.source)
        if cache is not None:
            cache[entry.source] = motion
    if entry.frame_range is not None:
        start, stop = entry.frame_range
        if stop > motion.n_frames:
            raise InvalidParameterError(
                f"library motion {entry.name!r}: frame_range [{start}, {stop}] runs past the "
                f"end of {entry.source[0]} ({motion.n_frames} frames)"
            )
        motion = motion.trim(start, stop)
    if entry.action is not None and entry.action[1] > motion.duration_s:
        raise InvalidParameterError(
            f"library motion {entry.name!r}: action [{entry.action[0]:g}, "
            f"{entry.action[1]:g}] s runs past the end of the motion "
            f"({motion.duration_s:.3f} s)"
        )
    return LibraryMotion(
        name=entry.name,
        label=entry.label,
        motion=motion.replace(name=entry.name),
        source=entry.source,
        performer=entry.performer,
        variation=entry.variation,
        licence=entry.licence,
        role=entry.role,
        attribution=entry.attribution,
        frame_range=entry.frame_range,
        action=entry.action,
        filler=entry.filler,
    )


def mirror_image(item: LibraryMotion) -> LibraryMotion:
    """A library motion's mirror image, as the library holds it.

    Parameters
    ----------
    item : LibraryMotion

    Returns
    -------
    LibraryMotion
        Named ``item.name + MIRROR_SUFFIX``, its motion :func:`mirror_motion
        <eigmotion.mocap.mirror.mirror_motion>`, the variation marked as mirrored,
        ``mirror_of = item.name``; label, performer, role, source, action span,
        filler and the rest as ``item``'s.
    """
    name = item.name + MIRROR_SUFFIX
    return dataclasses.replace(
        item,
        name=name,
        motion=mirror_motion(item.motion).replace(name=name),
        variation=f"{item.variation} (mirror image: left and right swapped)",
        mirror_of=item.name,
    )


def load_library(
    manifest: str | Path | None = None, include_distractors: bool = False
) -> list[LibraryMotion]:
    """Load every motion of a library manifest.

    Parameters
    ----------
    manifest : str or Path, optional
        Default :data:`DEFAULT_MANIFEST`.
    include_distractors : bool
        Also load the entries with ``role = "distractor"``.

    Returns
    -------
    list of LibraryMotion
        In manifest order, each entry with ``mirror = true`` followed by its mirror
        image (:func:`mirror_image`).
    """
    cache: dict = {}
    out = []
    for entry in read_manifest(manifest):
        if include_distractors or entry.role != "distractor":
            item = _load_entry(entry, cache)
            out += [item, mirror_image(item)] if entry.mirror else [item]
    return out


def motion_names(manifest: str | Path | None = None, include_distractors: bool = True) -> list[str]:
    """Names of the motions in a manifest, mirror images included, in library order."""
    return [
        name
        for e in read_manifest(manifest)
        if include_distractors or e.role != "distractor"
        for name in _names(e)
    ]


def find_motion(
    name_or_path: str | Path,
    asf: str | Path | None = None,
    manifest: str | Path | None = None,
) -> Motion:
    """A motion by library name, or read from a ``.bvh`` / ``.amc`` file.

    Parameters
    ----------
    name_or_path : str or Path
        A name from the manifest (distractors and mirror images included), or a path
        to a ``.bvh`` file or an ``.amc`` file.
    asf : str or Path, optional
        The ``.asf`` skeleton of an ``.amc`` file (required for one).
    manifest : str or Path, optional
        Default :data:`DEFAULT_MANIFEST`.

    Returns
    -------
    Motion
        A library motion comes trimmed and named after its entry; a file as read.

    Raises
    ------
    InvalidParameterError
        An unknown name (the message suggests the closest known ones), a missing file, an
        ``.amc`` without ``asf``, or an unsupported extension.
    """
    text = str(name_or_path)
    suffix = Path(text).suffix.lower()
    if suffix in (".bvh", ".amc"):
        path = Path(text)
        if not path.is_file():
            raise InvalidParameterError(f"motion file not found: {path}")
        if suffix == ".amc":
            if asf is None:
                raise InvalidParameterError(
                    f"{path}: an .amc motion needs its skeleton: pass the .asf file (asf=...)"
                )
            if not Path(asf).is_file():
                raise InvalidParameterError(f"skeleton file not found: {asf}")
            return _read_motion_file(path, Path(asf))
        return _read_motion_file(path)
    if suffix:
        raise InvalidParameterError(
            f"{text}: unsupported motion file type {suffix!r}; expected .bvh or .amc "
            "(with --asf), or a library motion name"
        )
    entries = {name: e for e in read_manifest(manifest) for name in _names(e)}
    if text not in entries:
        raise InvalidParameterError(_unknown_name_message(text, entries))
    item = load_entry(entries[text])
    return (item if text == item.name else mirror_image(item)).motion


def _unknown_name_message(name: str, entries: dict[str, ManifestEntry]) -> str:
    """The error for a name the library lacks: the closest names, at most five.

    Basic motions and distractors are not mixed: distractors are suggested (as such)
    only when one is closer than every basic motion.
    """
    basic = [n for n, e in entries.items() if e.role != "distractor"]
    distractors = [n for n, e in entries.items() if e.role == "distractor"]
    message = f"no motion named {name!r} in the library"
    close = difflib.get_close_matches(name, basic, n=5, cutoff=0.6)
    close_distractors = difflib.get_close_matches(name, distractors, n=5, cutoff=0.6)

    def similarity(names: list[str]) -> float:
        return difflib.SequenceMatcher(None, name, names[0]).ratio() if names else 0.0

    if close_distractors and similarity(close_distractors) > similarity(close):
        return f"{message}; did you mean the distractor {', '.join(close_distractors)}?"
    if close:
        return f"{message}; did you mean {', '.join(close)}?"
    labels = sorted({entries[n].label for n in basic})
    return (
        f"{message} ({len(basic)} basic motions, named after their label: "
        f"{', '.join(labels)}; all of them: `eigmotion list --library`)"
    )


def _read_motion_file(path: Path, asf: Path | None = None) -> Motion:
    """Read a ``.bvh`` file, or an ``.amc`` file with its ``.asf``."""
    if path.suffix.lower() == ".amc":
        return read_amc(path, asf)
    return read_bvh(path)
