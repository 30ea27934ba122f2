"""Joint names of other skeletons → the canonical joints.

Every motion is mapped onto :data:`eigmotion.mocap.canonical.CANONICAL_JOINTS` (the CMU
BVH names of the MakeHuman ``cmu_mb`` rig) before it drives the avatar.  Skeletons
from different sources name their joints in different *families*, and one name
can mean different joints in different families (``Spine`` is the canonical
``Spine`` in CMU BVH files but the lowest spine joint, canonical ``LowerBack``, in
Mixamo-style rigs), so the family is detected from the whole set of names first.

Families (:data:`FAMILIES`), each a table source name → canonical name, or ``None``
for a known joint that is deliberately ignored (fingers, face, ``_end`` nubs):

``cmu_bvh``
    The canonical names themselves and the variants of public CMU BVH conversions
    (``LeftHandIndex1`` → ``LeftHandFinger1``).
``cmu_asf``
    CMU ASF bone names (``root``, ``lfemur``, ``ltibia`` …), as read by
    :func:`eigmotion.mocap.amc.read_amc`.
``exporter``
    Common exporter naming (Mixamo, MotionBuilder): ``Hips Spine Spine1 Spine2 Neck
    Head LeftShoulder LeftArm LeftForeArm LeftHand LeftUpLeg LeftLeg LeftFoot
    LeftToeBase`` …
``tospine``
    ``Hips ToSpine Spine Spine1 Neck Head …`` (limbs as ``exporter``).
``unity``
    ``Hips Spine Chest UpperChest Neck Head Shoulder_L UpperArm_L LowerArm_L Hand_L
    UpperLeg_L LowerLeg_L Foot_L Toes_L`` …

Matching ignores case and a namespace prefix (``mixamorig:Hips``, ``Armature|Hips``,
``mixamorig_Hips``).  A user mapping overrides or extends any family, from Python
(``mapping={"pelvis": "Hips", "jaw": None}``) or from a TOML file with a
``[joints]`` table (:func:`load_joint_map`, the CLI's ``--joint-map``).

:func:`mirror_partners` pairs each joint with its namesake on the other side of the
body, for mirror images.
"""

from __future__ import annotations

import re
import tomllib
from collections.abc import Iterable, Mapping
from pathlib import Path

from eigmotion.errors import InvalidParameterError, SkeletonMappingError
from eigmotion.mocap.canonical import CANONICAL_JOINTS
from eigmotion.mocap.motion import Skeleton

_SIDES = (("Left", "L", "l", "_L"), ("Right", "R", "r", "_R"))


def _sided(template: dict[str, str | None]) -> dict[str, str | None]:
    """Expand ``{side}``/``{S}``/``{s}``/``{_S}`` templates for the left and right sides."""
    out: dict[str, str | None] = {}
    for key, value in template.items():
        for side, short, lower, suffix in _SIDES:
            fill = {"side": side, "S": short, "s": lower, "_S": suffix}
            out[key.format(**fill)] = None if value is None else value.format(**fill)
    return out


_CMU_BVH = {
    "Hips": "Hips",
    "LowerBack": "LowerBack",
    "Spine": "Spine",
    "Spine1": "Spine1",
    "Neck": "Neck",
    "Neck1": "Neck1",
    "Head": "Head",
    **_sided(
        {
            "{S}HipJoint": "{S}HipJoint",
            "{side}UpLeg": "{side}UpLeg",
            "{side}Leg": "{side}Leg",
            "{side}Foot": "{side}Foot",
            "{side}ToeBase": "{side}ToeBase",
            "{side}Shoulder": "{side}Shoulder",
            "{side}Arm": "{side}Arm",
            "{side}ForeArm": "{side}ForeArm",
            "{side}Hand": "{side}Hand",
            "{side}FingerBase": "{side}FingerBase",
            "{side}HandFinger1": "{side}HandFinger1",
            "{side}HandIndex1": "{side}HandFinger1",
            "{S}Thumb": "{S}Thumb",
            "{side}HandThumb1": "{S}Thumb",
        }
    ),
}

_CMU_ASF = {
    "root": "Hips",
    "lowerback": "LowerBack",
    "upperback": "Spine",
    "thorax": "Spine1",
    "lowerneck": "Neck",
    "upperneck": "Neck1",
    "head": "Head",
    **_sided(
        {
            "{s}hipjoint": "{S}HipJoint",
            "{s}femur": "{side}UpLeg",
            "{s}tibia": "{side}Leg",
            "{s}foot": "{side}Foot",
            "{s}toes": "{side}ToeBase",
            "{s}clavicle": "{side}Shoulder",
            "{s}humerus": "{side}Arm",
            "{s}radius": "{side}ForeArm",
            "{s}wrist": "{side}Hand",
            "{s}hand": "{side}FingerBase",
            "{s}fingers": "{side}HandFinger1",
            "{s}thumb": "{S}Thumb",
        }
    ),
}

_LIMBS = _sided(
    {
        "{side}UpLeg": "{side}UpLeg",
        "{side}Leg": "{side}Leg",
        "{side}Foot": "{side}Foot",
        "{side}ToeBase": "{side}ToeBase",
        "{side}Shoulder": "{side}Shoulder",
        "{side}Arm": "{side}Arm",
        "{side}ForeArm": "{side}ForeArm",
        "{side}Hand": "{side}Hand",
    }
)

_EXPORTER = {
    "Hips": "Hips",
    "Spine": "LowerBack",
    "Spine1": "Spine",
    "Spine2": "Spine1",
    "Neck": "Neck",
    "Neck1": "Neck1",
    "Head": "Head",
    **_LIMBS,
}

_TOSPINE = {
    "Hips": "Hips",
    "ToSpine": "LowerBack",
    "Spine": "Spine",
    "Spine1": "Spine1",
    "Neck": "Neck",
    "Head": "Head",
    **_LIMBS,
}

_UNITY = {
    "Hips": "Hips",
    "Spine": "LowerBack",
    "Chest": "Spine",
    "UpperChest": "Spine1",
    "Neck": "Neck",
    "Head": "Head",
    **_sided(
        {
            "UpperLeg{_S}": "{side}UpLeg",
            "LowerLeg{_S}": "{side}Leg",
            "Foot{_S}": "{side}Foot",
            "Toes{_S}": "{side}ToeBase",
            "Shoulder{_S}": "{side}Shoulder",
            "UpperArm{_S}": "{side}Arm",
            "LowerArm{_S}": "{side}ForeArm",
            "Hand{_S}": "{side}Hand",
        }
    ),
}

#: Family name → (source name → canonical name or ``None`` for ignored joints).
FAMILIES: dict[str, dict[str, str | None]] = {
    "cmu_bvh": _CMU_BVH,
    "cmu_asf": _CMU_ASF,
    "exporter": _EXPORTER,
    "tospine": _TOSPINE,
    "unity": _UNITY,
}

#: Names that only one family uses; they settle ties between families.
_SIGNATURES: dict[str, frozenset[str]] = {
    "cmu_bvh": frozenset(
        n.casefold() for n in ("LowerBack", "LHipJoint", "RHipJoint", "Neck1", "LThumb")
    ),
    "cmu_asf": frozenset(("root", "lfemur", "rfemur", "thorax", "lhumerus", "rhumerus")),
    "exporter": frozenset(("spine2",)),
    "tospine": frozenset(("tospine",)),
    "unity": frozenset(("chest", "upperchest", "upperleg_l", "upperarm_l")),
}

#: Joints every family knows and ignores: fingers, face, toe tips, end nubs, twist
#: and roll helpers.  Matched on the normalised name.
_IGNORED = re.compile(
    r"thumb|index|middle|ring\d|pinky|little|finger|carpal"
    r"|eye|jaw|tongue|teeth|brow|eyelid|cheek|nose|headtop|head_top|headend"
    r"|_end$|nub$|twist|roll|toe_?tip",
    re.IGNORECASE,
)

_NAMESPACE = re.compile(r"^(?:.*[:|]|mixamorig\d*_)", re.IGNORECASE)


def normalise_name(name: str) -> str:
    """Strip a namespace prefix (``mixamorig:``, ``Armature|``, ``mixamorig_``) and casefold.

    Parameters
    ----------
    name : str

    Returns
    -------
    str
    """
    return _NAMESPACE.sub("", name.strip()).casefold()


def _family_table(family: str) -> dict[str, str | None]:
    return {normalise_name(k): v for k, v in FAMILIES[family].items()}


def _lookup(table: dict[str, str | None], family: str, key: str) -> tuple[bool, str | None]:
    """(known, canonical name or None) for a normalised name in a family."""
    if key in table:
        return True, table[key]
    if family != "cmu_asf" and _IGNORED.search(key):
        return True, None
    if family == "cmu_asf" and key.endswith("_end"):
        return True, None
    return False, None


def detect_family(names: Iterable[str]) -> str:
    """The naming family of a skeleton, from all of its joint names.

    Parameters
    ----------
    names : iterable of str
        The skeleton's joint names.

    Returns
    -------
    str
        A key of :data:`FAMILIES`, among those that know the hips: the family that
        leaves the fewest names unknown (neither mapped nor ignored); ties go to the
        one that maps more names, then to the one with more family-specific names,
        then to the first in :data:`FAMILIES`.

    Raises
    ------
    SkeletonMappingError
        No family recognises the hips joint.
    """
    names = list(names)
    keys = [normalise_name(n) for n in names]
    best: tuple[int, int, int, int] | None = None
    best_family = None
    for rank, family in enumerate(FAMILIES):
        table = _family_table(family)
        looked_up = [_lookup(table, family, k) for k in keys]
        mapped = [target for _, target in looked_up]
        if "Hips" not in mapped:
            continue
        score = (
            -sum(not known for known, _ in looked_up),
            sum(m is not None for m in mapped),
            sum(k in _SIGNATURES[family] for k in keys),
            -rank,
        )
        if best is None or score > best:
            best, best_family = score, family
    if best_family is None:
        shown = ", ".join(names[:12])
        raise SkeletonMappingError(
            "cannot tell which naming family these joints use (no family recognises the "
            f"hips among: {shown} …); {_HOW_TO_MAP}"
        )
    return best_family


_HOW_TO_MAP = (
    "pass a joint map from source name to canonical name (or None to ignore it): in "
    "Python mapping={'pelvis': 'Hips', 'jaw': None, ...}, on the command line "
    '--joint-map FILE.toml with a [joints] table (pelvis = "Hips", jaw = "")'
)


def canonical_joint_map(
    skeleton: Skeleton, mapping: Mapping[str, str | None] | None = None
) -> dict[str, int]:
    """Which source joint plays each canonical joint.

    Parameters
    ----------
    skeleton : Skeleton
        The source skeleton.
    mapping : dict of str to (str or None), optional
        Source joint name → canonical joint name, or ``None`` to ignore that joint;
        overrides and extends the detected family's table.

    Returns
    -------
    dict of str to int
        Canonical joint name → source joint index, in canonical order.  Canonical
        joints the source lacks are absent; ``"Hips"`` is always present.

    Raises
    ------
    SkeletonMappingError
        Source joints that nothing maps (listed, with how to pass a mapping), two
        source joints on one canonical joint, no hips, or a mapping target that is
        not a canonical joint.
    """
    targets = _source_targets(skeleton.names, mapping)
    out: dict[str, int] = {}
    for index, target in enumerate(targets):
        if target is None:
            continue
        if target in out:
            raise SkeletonMappingError(
                f"joints {skeleton.names[out[target]]!r} and {skeleton.names[index]!r} both "
                f"map to canonical {target!r}; {_HOW_TO_MAP}"
            )
        out[target] = index
    if "Hips" not in out:
        raise SkeletonMappingError(f"no source joint maps to canonical 'Hips'; {_HOW_TO_MAP}")
    return {name: out[name] for name in CANONICAL_JOINTS if name in out}


def canonical_names(
    skeleton: Skeleton, mapping: Mapping[str, str | None] | None = None
) -> tuple[str, ...]:
    """The canonical name of every source joint, when the mapping is one-to-one.

    Parameters
    ----------
    skeleton : Skeleton
    mapping : dict of str to (str or None), optional
        As in :func:`canonical_joint_map`.

    Returns
    -------
    tuple of str
        One canonical name per source joint, in the source's joint order; use it
        with :meth:`Skeleton.renamed`.

    Raises
    ------
    SkeletonMappingError
        Some source joint is ignored or unmapped, or two map to one canonical joint.
    """
    joint_map = canonical_joint_map(skeleton, mapping)
    names = {index: name for name, index in joint_map.items()}
    dropped = [skeleton.names[i] for i in range(skeleton.n_joints) if i not in names]
    if dropped:
        raise SkeletonMappingError(
            f"cannot rename to canonical names one-to-one: joints {', '.join(dropped)} have "
            "no canonical counterpart (they are ignored by the naming family or the map)"
        )
    return tuple(names[i] for i in range(skeleton.n_joints))


def _source_targets(
    names: tuple[str, ...], mapping: Mapping[str, str | None] | None
) -> list[str | None]:
    mapping = dict(mapping or {})
    for source, target in mapping.items():
        if target is not None and target not in CANONICAL_JOINTS:
            raise SkeletonMappingError(
                f"the joint map sends {source!r} to {target!r}, which is not a canonical "
                f"joint; canonical joints are: {', '.join(CANONICAL_JOINTS)}"
            )
    by_key = {normalise_name(k): v for k, v in mapping.items()}
    try:
        family = detect_family(names)
        table = _family_table(family)
    except SkeletonMappingError:
        if not mapping:
            raise
        family, table = "", {}
    targets: list[str | None] = []
    unmapped = []
    for name in names:
        if name in mapping or normalise_name(name) in by_key:
            targets.append(mapping[name] if name in mapping else by_key[normalise_name(name)])
            continue
        known, target = _lookup(table, family, normalise_name(name)) if family else (False, None)
        if not known:
            unmapped.append(name)
        targets.append(target)
    if unmapped:
        found = (
            f"joints not known to the {family!r} naming family"
            if family
            else "joints not in the joint map (and no naming family fits this skeleton)"
        )
        raise SkeletonMappingError(f"{found}: {', '.join(unmapped)}; {_HOW_TO_MAP}")
    return targets


#: Ways a joint name says its side: (pattern, left, right), the pattern holding ``{}``
#: where the side is: ``LeftArm``, ``left_arm``; ``LHipJoint``, ``L_arm``; CMU ASF
#: ``lfemur``; ``Hand_L``, ``upperarm_l``, ``arm.L``.  Matched on the bare name (no
#: namespace); the first rule whose swapped name is in the skeleton decides.
_SIDE_RULES = (
    ("{}", "Left", "Right"),
    ("{}", "left", "right"),
    ("{}", "LEFT", "RIGHT"),
    ("^{}(?=[A-Z_.])", "L", "R"),
    ("^{}(?=[a-z])", "l", "r"),
    ("(?<=[_.]){}$", "L", "R"),
    ("(?<=[_.]){}$", "l", "r"),
)


def _swapped_sides(bare: str) -> list[str]:
    """Names ``bare`` could have on the other side, most likely first."""
    out = []
    for pattern, left, right in _SIDE_RULES:
        for this, other in ((left, right), (right, left)):
            swapped = re.sub(pattern.format(this), other, bare)
            if swapped != bare:
                out.append(swapped)
    return out


def mirror_partners(skeleton: Skeleton) -> tuple[int, ...]:
    """The joint on the other side of the body for every joint, by name.

    ``LeftArm`` ↔ ``RightArm``, ``LHipJoint`` ↔ ``RHipJoint``, CMU ASF ``lfemur`` ↔
    ``rfemur``, ``Hand_L`` ↔ ``Hand_R`` (a namespace prefix is kept); a joint whose
    name says no side, or whose other side the skeleton lacks, is its own partner.

    Parameters
    ----------
    skeleton : Skeleton

    Returns
    -------
    tuple of int
        Partner index per joint; applying it twice gives every joint back.

    Raises
    ------
    InvalidParameterError
        No joint has a partner, two joints claim one partner, or partners hang from
        parents that are not partners (the two sides are built differently).
    """
    names = skeleton.names
    index = {name: i for i, name in enumerate(names)}
    partners = list(range(len(names)))
    for i, name in enumerate(names):
        bare = _NAMESPACE.sub("", name)
        prefix = name[: len(name) - len(bare)]
        for other in _swapped_sides(bare):
            if prefix + other in index:
                partners[i] = index[prefix + other]
                break
    if all(p == i for i, p in enumerate(partners)):
        raise InvalidParameterError(
            f"cannot mirror: no joint name says its side (Left/Right, L/R, l/r) among "
            f"{', '.join(names[:12])} …"
        )
    for i, p in enumerate(partners):
        if partners[p] != i:
            raise InvalidParameterError(
                f"cannot mirror: {names[i]!r} pairs with {names[p]!r}, which pairs with "
                f"{names[partners[p]]!r}"
            )
        parent = int(skeleton.parents[i])
        other_parent = int(skeleton.parents[p])
        if (parent < 0) != (other_parent < 0) or (parent >= 0 and partners[parent] != other_parent):
            raise InvalidParameterError(
                f"cannot mirror: {names[i]!r} and its partner {names[p]!r} hang from "
                "parents that are not partners"
            )
    return tuple(partners)


def load_joint_map(path: str | Path) -> dict[str, str | None]:
    """Read a joint map from a TOML file.

    The file holds one ``[joints]`` table, source joint name = canonical joint name;
    an empty string (or ``false``) ignores the joint::

        [joints]
        pelvis = "Hips"
        spine_01 = "LowerBack"
        jaw = ""

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    dict of str to (str or None)
        Ready for the ``mapping`` argument of :func:`canonical_joint_map`.

    Raises
    ------
    InvalidParameterError
        Not TOML, no ``[joints]`` table, or a value that is not a canonical joint name.
    FileNotFoundError
    """
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except ValueError as exc:  # a decode error, bad UTF-8, a number too long
        raise InvalidParameterError(f"{path}: not a valid TOML joint map: {exc}") from None
    joints = data.get("joints")
    if not isinstance(joints, dict):
        raise InvalidParameterError(
            f"{path}: a joint map needs a [joints] table (source name = canonical name)"
        )
    out: dict[str, str | None] = {}
    for source, target in joints.items():
        if target == "" or target is False:
            out[source] = None
        elif isinstance(target, str) and target in CANONICAL_JOINTS:
            out[source] = target
        else:
            raise InvalidParameterError(
                f'{path}: [joints] {source} = {target!r} is not a canonical joint name (or "" '
                f"to ignore it); canonical joints are: {', '.join(CANONICAL_JOINTS)}"
            )
    return out
