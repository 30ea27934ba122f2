"""Joint-name families → canonical joints."""

from __future__ import annotations

import numpy as np
import pytest

from eigmotion.errors import InvalidParameterError, SkeletonMappingError
from eigmotion.mocap.amc import asf_to_skeleton
from eigmotion.mocap.asf import read_asf
from eigmotion.mocap.canonical import CANONICAL_JOINTS, canonical_skeleton
from eigmotion.mocap.motion import Skeleton
from eigmotion.mocap.naming import (
    FAMILIES,
    canonical_joint_map,
    canonical_names,
    detect_family,
    load_joint_map,
    mirror_partners,
)


def _chain(names: list[str]) -> Skeleton:
    """A skeleton with these joint names (a simple chain; geometry is irrelevant)."""
    n = len(names)
    return Skeleton(tuple(names), np.arange(-1, n - 1), np.ones((n, 3)), ((),) * n)


def _limbs(fmt: str) -> list[str]:
    return [fmt.format(side=s) for s in ("Left", "Right")]


MIXAMO = ["Hips", "Spine", "Spine1", "Spine2", "Neck", "Head", "HeadTop_End"] + [
    f"{side}{part}"
    for side in ("Left", "Right")
    for part in (
        "Shoulder",
        "Arm",
        "ForeArm",
        "Hand",
        "HandThumb1",
        "HandThumb2",
        "HandIndex1",
        "HandIndex2",
        "HandMiddle1",
        "UpLeg",
        "Leg",
        "Foot",
        "ToeBase",
        "Toe_End",
    )
]
TOSPINE = ["Hips", "ToSpine", "Spine", "Spine1", "Neck", "Head"] + [
    f"{side}{part}"
    for side in ("Left", "Right")
    for part in ("Shoulder", "Arm", "ForeArm", "Hand", "UpLeg", "Leg", "Foot", "ToeBase")
]
UNITY = ["Hips", "Spine", "Chest", "UpperChest", "Neck", "Head", "LeftEye", "Jaw"] + [
    f"{part}_{s}"
    for s in ("L", "R")
    for part in (
        "Shoulder",
        "UpperArm",
        "LowerArm",
        "Hand",
        "UpperLeg",
        "LowerLeg",
        "Foot",
        "Toes",
        "Index1",
        "Thumb1",
    )
]
CMU_BVH_PUBLIC = list(CANONICAL_JOINTS)
CMU_BVH_PUBLIC[CMU_BVH_PUBLIC.index("LeftHandFinger1")] = "LeftHandIndex1"
CMU_BVH_PUBLIC[CMU_BVH_PUBLIC.index("RightHandFinger1")] = "RightHandIndex1"


@pytest.mark.parametrize(
    "names, family",
    [
        (list(CANONICAL_JOINTS), "cmu_bvh"),
        (CMU_BVH_PUBLIC, "cmu_bvh"),
        (MIXAMO, "exporter"),
        ([f"mixamorig:{n}" for n in MIXAMO], "exporter"),
        ([f"mixamorig_{n}" for n in MIXAMO], "exporter"),
        ([f"Armature|{n}" for n in MIXAMO + ["LeftForeArmTwist", "LeftArmRoll"]], "exporter"),
        (TOSPINE, "tospine"),
        (UNITY, "unity"),
    ],
    ids=[
        "canonical",
        "cmu-bvh",
        "mixamo",
        "mixamorig:",
        "mixamorig_",
        "armature-twist",
        "tospine",
        "unity",
    ],
)
def test_detect_family(names, family):
    assert detect_family(names) == family
    assert detect_family(iter(names)) == family


def test_cmu_asf_skeleton_maps_one_to_one(cmu_dir):
    sk = asf_to_skeleton(read_asf(cmu_dir / "asf" / "02.asf"))
    assert detect_family(sk.names) == "cmu_asf"
    names = canonical_names(sk)
    assert sorted(names) == sorted(CANONICAL_JOINTS)
    expected = {
        "root": "Hips",
        "lhipjoint": "LHipJoint",
        "lfemur": "LeftUpLeg",
        "ltibia": "LeftLeg",
        "lfoot": "LeftFoot",
        "ltoes": "LeftToeBase",
        "lowerback": "LowerBack",
        "upperback": "Spine",
        "thorax": "Spine1",
        "lowerneck": "Neck",
        "upperneck": "Neck1",
        "head": "Head",
        "lclavicle": "LeftShoulder",
        "lhumerus": "LeftArm",
        "lradius": "LeftForeArm",
        "lwrist": "LeftHand",
        "lhand": "LeftFingerBase",
        "lfingers": "LeftHandFinger1",
        "lthumb": "LThumb",
        "rfemur": "RightUpLeg",
        "rthumb": "RThumb",
        "rhand": "RightFingerBase",
    }
    for source, canonical in expected.items():
        assert names[sk.index(source)] == canonical
    # The CMU ASF hierarchy is the canonical one, joint for joint.
    renamed = sk.renamed(names)
    canon = canonical_skeleton()
    for j, name in enumerate(renamed.names[1:], start=1):
        assert renamed.names[renamed.parents[j]] == canon.names[canon.parents[canon.index(name)]]


def test_spine_means_different_joints_in_different_families():
    exporter = canonical_joint_map(_chain(MIXAMO))
    tospine = canonical_joint_map(_chain(TOSPINE))
    cmu = canonical_joint_map(canonical_skeleton())
    assert MIXAMO[exporter["LowerBack"]] == "Spine"
    assert MIXAMO[exporter["Spine"]] == "Spine1" and MIXAMO[exporter["Spine1"]] == "Spine2"
    assert TOSPINE[tospine["LowerBack"]] == "ToSpine" and TOSPINE[tospine["Spine"]] == "Spine"
    assert cmu["Spine"] == CANONICAL_JOINTS.index("Spine")


@pytest.mark.parametrize(
    "names, expected",
    [
        (
            MIXAMO,
            {
                "Hips": "Hips",
                "LeftArm": "LeftArm",
                "RightToeBase": "RightToeBase",
                "Neck": "Neck",
                "Head": "Head",
            },
        ),
        (
            UNITY,
            {
                "Spine": "Chest",
                "Spine1": "UpperChest",
                "LeftArm": "UpperArm_L",
                "RightForeArm": "LowerArm_R",
                "LeftUpLeg": "UpperLeg_L",
                "RightLeg": "LowerLeg_R",
                "LeftToeBase": "Toes_L",
                "LeftShoulder": "Shoulder_L",
            },
        ),
        (CMU_BVH_PUBLIC, {"LeftHandFinger1": "LeftHandIndex1", "LThumb": "LThumb"}),
    ],
    ids=["mixamo", "unity", "cmu-bvh"],
)
def test_family_tables(names, expected):
    got = canonical_joint_map(_chain(names))
    for canonical, source in expected.items():
        assert names[got[canonical]] == source
    assert list(got) == [n for n in CANONICAL_JOINTS if n in got]  # canonical order


def test_fingers_face_and_end_nubs_are_ignored_not_mapped():
    got = canonical_joint_map(_chain(MIXAMO))
    mapped = {MIXAMO[i] for i in got.values()}
    assert not mapped & {"HeadTop_End", "LeftHandThumb1", "RightHandIndex2", "LeftToe_End"}
    assert "LHipJoint" not in got and "Neck1" not in got  # absent, not an error
    assert "LeftEye" not in {UNITY[i] for i in canonical_joint_map(_chain(UNITY)).values()}


def test_unmapped_joints_are_listed_with_how_to_map():
    names = MIXAMO + ["Tail1", "Tail2"]
    with pytest.raises(SkeletonMappingError) as info:
        canonical_joint_map(_chain(names))
    message = str(info.value)
    assert "Tail1, Tail2" in message and "'exporter'" in message
    assert "mapping=" in message and "--joint-map" in message and "[joints]" in message
    assert isinstance(info.value, KeyError)
    got = canonical_joint_map(_chain(names), {"Tail1": None, "Tail2": None})
    assert got == canonical_joint_map(_chain(MIXAMO))


def test_user_mapping_overrides_and_extends():
    names = ["pelvis", "spine_01", "thigh_l", "calf_l", "jaw"]
    with pytest.raises(SkeletonMappingError, match="cannot tell which naming family"):
        canonical_joint_map(_chain(names))
    mapping = {
        "pelvis": "Hips",
        "spine_01": "LowerBack",
        "thigh_l": "LeftUpLeg",
        "calf_l": "LeftLeg",
        "jaw": None,
    }
    partial = {k: v for k, v in mapping.items() if k != "jaw"}
    with pytest.raises(SkeletonMappingError, match="not in the joint map.*: jaw;"):
        canonical_joint_map(_chain(names), partial)
    assert canonical_joint_map(_chain(names), mapping) == {
        "Hips": 0,
        "LeftUpLeg": 2,
        "LeftLeg": 3,
        "LowerBack": 1,
    }
    # Override inside a detected family: Mixamo's Spine2 as the canonical Spine.
    got = canonical_joint_map(_chain(MIXAMO), {"Spine2": "Spine", "Spine1": None})
    assert MIXAMO[got["Spine"]] == "Spine2" and "Spine1" not in got


@pytest.mark.parametrize(
    "mapping, message",
    [
        ({"Spine": "Chest"}, "not a canonical joint"),
        ({"Spine1": "LowerBack"}, "both map to canonical 'LowerBack'"),
        ({"Hips": None}, "no source joint maps to canonical 'Hips'"),
    ],
)
def test_bad_mappings_are_explained(mapping, message):
    with pytest.raises(SkeletonMappingError, match=message):
        canonical_joint_map(_chain(MIXAMO), mapping)


def test_no_hips_anywhere():
    with pytest.raises(SkeletonMappingError, match="hips"):
        detect_family(["a", "b", "c"])


def test_canonical_names_needs_one_to_one():
    with pytest.raises(SkeletonMappingError, match="HeadTop_End"):
        canonical_names(_chain(MIXAMO))
    assert canonical_names(canonical_skeleton()) == CANONICAL_JOINTS


def test_every_family_targets_canonical_joints():
    for table in FAMILIES.values():
        assert {v for v in table.values() if v is not None} <= set(CANONICAL_JOINTS)
        assert "Hips" in table.values()


def test_load_joint_map(tmp_path):
    path = tmp_path / "map.toml"
    path.write_text('[joints]\npelvis = "Hips"\n"mixamorig:Spine" = "LowerBack"\njaw = ""\n')
    assert load_joint_map(path) == {"pelvis": "Hips", "mixamorig:Spine": "LowerBack", "jaw": None}


@pytest.mark.parametrize(
    "text, message",
    [
        ('pelvis = "Hips"\n', r"\[joints\] table"),
        ('[joints]\npelvis = "Pelvis"\n', "not a canonical joint"),
        ("[joints]\npelvis = 3\n", "not a canonical joint"),
        ("[joints\n", "not a valid TOML"),
    ],
)
def test_load_joint_map_errors_name_the_file(tmp_path, text, message):
    path = tmp_path / "map.toml"
    path.write_text(text)
    with pytest.raises(InvalidParameterError, match=message) as info:
        load_joint_map(path)
    assert str(path) in str(info.value)


# -- left and right ------------------------------------------------------------------------


def _pairs(skeleton: Skeleton) -> set[tuple[str, str]]:
    partners = mirror_partners(skeleton)
    return {(skeleton.names[i], skeleton.names[p]) for i, p in enumerate(partners) if i < p}


def test_mirror_partners_of_the_canonical_skeleton():
    sk = canonical_skeleton()
    pairs = _pairs(sk)
    assert ("LeftArm", "RightArm") in pairs and ("LHipJoint", "RHipJoint") in pairs
    assert ("LThumb", "RThumb") in pairs and len(pairs) == 12
    partners = mirror_partners(sk)
    assert all(partners[p] == i for i, p in enumerate(partners))
    for centre in ("Hips", "LowerBack", "Spine", "Neck", "Head"):
        assert partners[sk.index(centre)] == sk.index(centre)


def test_mirror_partners_of_a_cmu_asf_skeleton(cmu_dir):
    sk = asf_to_skeleton(read_asf(cmu_dir / "asf" / "02.asf"))
    pairs = _pairs(sk)
    assert {("lfemur", "rfemur"), ("lhumerus", "rhumerus"), ("lhipjoint", "rhipjoint")} <= pairs
    # "root" and "lowerback" start with r and l but name no side.
    partners = mirror_partners(sk)
    assert partners[sk.index("root")] == sk.index("root")
    assert partners[sk.index("lowerback")] == sk.index("lowerback")


@pytest.mark.parametrize(
    ("left", "right"),
    [
        ("mixamorig:LeftUpLeg", "mixamorig:RightUpLeg"),
        ("UpperLeg_L", "UpperLeg_R"),
        ("thigh.l", "thigh.r"),
        ("left_thigh", "right_thigh"),
    ],
)
def test_mirror_partners_of_other_namings(left, right):
    names = ["Hips", left, right]
    sk = Skeleton(tuple(names), np.array([-1, 0, 0]), np.zeros((3, 3)), ((),) * 3)
    assert _pairs(sk) == {(left, right)}


def test_mirror_partners_errors():
    with pytest.raises(InvalidParameterError, match="no joint name says its side"):
        mirror_partners(_chain(["Hips", "Spine", "Head"]))
    # LeftArm hangs from Spine but RightArm from Head: the sides differ.
    sk = Skeleton(
        ("Hips", "Spine", "Head", "LeftArm", "RightArm"),
        np.array([-1, 0, 1, 1, 2]),
        np.zeros((5, 3)),
        ((),) * 5,
    )
    with pytest.raises(InvalidParameterError, match="parents that are not partners"):
        mirror_partners(sk)
