"""The ZODB store: round trips on real files, memory and a real ZEO server."""

from __future__ import annotations

import numpy as np
import pytest

import eigmotion.retrieval.schema as schema_module
import eigmotion.retrieval.storage as storage_module
from eigmotion.errors import DatabaseError, InvalidParameterError
from eigmotion.retrieval.brute_force import brute_force
from eigmotion.retrieval.eigenspace import Eigenspace
from eigmotion.retrieval.keys import Quantizer, prefix_range
from eigmotion.retrieval.schema import SCHEMA_VERSION
from eigmotion.retrieval.search import TreeIndex
from eigmotion.retrieval.sequences import pose_coordinates, pose_speeds
from eigmotion.retrieval.storage import parse_uri
from eigmotion.retrieval.store import Store

BVH_TEXT = "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n}\nMOTION\nFrames: 0\nFrame Time: 0.1\n"


@pytest.fixture(scope="module")
def fitted():
    """A fitted eigenspace (k = 6) and quantizer (K = 3, R = 4), 120 points, and a pose
    eigenspace (p = 5) of 256-pixel frames."""
    rng = np.random.default_rng(11)
    images = rng.standard_normal((120, 300)).astype(np.float32)
    images /= np.linalg.norm(images, axis=1, keepdims=True)
    space = Eigenspace(n_components=6).fit(images)
    points = space.transform(images)
    quantizer = Quantizer(3, 4).fit(points)
    pose = Eigenspace(n_components=5).fit(rng.random((200, 256)).astype(np.float32))
    return space, quantizer, points, pose


def fill(store: Store, fitted, n_motions: int = 2) -> np.ndarray:
    """Initialise and add ``n_motions`` motions sharing the fixture's points."""
    space, quantizer, points, pose = fitted
    store.initialise({"fps": 30, "views": [0.0, 45.0], "name": "test"}, space, quantizer, pose)
    per = len(points) // n_motions
    ids = []
    for m in range(n_motions):
        motion = store.add_motion(f"motion {m}", f"clip_{m}.amc", BVH_TEXT, {"frames": 10 + m})
        part = points[m * per : (m + 1) * per]
        ids.append(
            store.add_entries(
                np.full(per, motion),
                part,
                quantizer.keys(part),
                np.linspace(0, 315, per),
                np.full(per, 15.0),
                np.arange(per),
                np.arange(per) + 8,
            )
        )
    store.add_sequences(0, [0.0, 30.0], [0.0, 20.0], sequences_of(pose))
    return np.concatenate(ids)


def sequences_of(pose: Eigenspace) -> list[np.ndarray]:
    """Two renderings' sequences (7 and 3 frames): pose coordinates and rise."""
    rng = np.random.default_rng(5)
    return [pose_coordinates(pose, rng.random((n, 257)).astype(np.float32)) for n in (7, 3)]


def assert_holds(store: Store, fitted, n_motions: int = 2):
    space, quantizer, points, pose = fitted
    store.check()
    assert store.schema_version == SCHEMA_VERSION
    np.testing.assert_array_equal(store.pose_space().components_, pose.components_)
    found = store.sequences(0)
    np.testing.assert_array_equal(found.azimuth_deg, [0.0, 30.0])
    np.testing.assert_array_equal(found.elevation_deg, [0.0, 20.0])
    np.testing.assert_array_equal(found.lengths, [7, 3])
    assert found.frames.dtype == np.float32 and found.frames.shape == (10, 6)
    np.testing.assert_allclose(
        found.frames, np.concatenate(sequences_of(pose)), rtol=2e-3, atol=2e-3
    )
    # each rendering's pose speed, measured on its frames as stored, to the bit
    np.testing.assert_array_equal(found.speeds, pose_speeds(found.frames, found.lengths))
    assert store.sequences(1).lengths.size == 0  # stored without sequences
    assert store.config == {"fps": 30, "views": [0.0, 45.0], "name": "test"}
    assert store.n_motions == n_motions and store.n_entries == len(points)
    np.testing.assert_array_equal(store.eigenspace().components_, space.components_)
    np.testing.assert_array_equal(store.quantizer().edges_, quantizer.edges_)
    arrays = store.arrays()
    np.testing.assert_array_equal(arrays.ids, np.arange(len(points)))
    np.testing.assert_array_equal(arrays.points, points)
    np.testing.assert_array_equal(arrays.keys, quantizer.keys(points))
    assert arrays.points.dtype == np.float32 and arrays.keys.dtype == np.int64
    motion = store.motion(1)
    assert motion == {
        "label": "motion 1",
        "source": "clip_1.amc",
        "bvh": BVH_TEXT,
        "metadata": {"frames": 11},
    }
    entry = store.entry(61)
    assert entry["motion"] == 1 and entry["label"] == "motion 1"
    assert entry["start_frame"] == 1 and entry["end_frame"] == 9
    assert entry["view_elevation_deg"] == 15.0
    np.testing.assert_array_equal(entry["point"], points[61])
    # The B-tree: every key's ids, and range queries over a key prefix.
    keys = arrays.keys
    np.testing.assert_array_equal(store.occupied_keys(), np.unique(keys))
    some = int(keys[5])
    np.testing.assert_array_equal(store.ids_for_key(some), np.flatnonzero(keys == some))
    low, high = prefix_range(some // 16, 4, 3, 1)
    walked = dict(store.key_range(low, high))
    assert sorted(walked) == sorted(set(keys[(keys >= low) & (keys <= high)].tolist()))


def test_file_round_trip(tmp_path, fitted):
    path = tmp_path / "motions.fs"
    with Store.create(path) as store:
        with store.transaction():
            fill(store, fitted)
        assert_holds(store, fitted)
    with Store.open(path) as store:  # read-only by default
        assert store.read_only
        assert_holds(store, fitted)
    with Store.open(f"file://{path}") as store:
        assert_holds(store, fitted)


def test_memory_round_trip(fitted):
    with Store.create("memory://") as store:
        with store.transaction():
            ids = fill(store, fitted)
        np.testing.assert_array_equal(ids, np.arange(len(fitted[2])))
        assert_holds(store, fitted)
    with pytest.raises(DatabaseError, match="memory://"):
        Store.open("memory://")


def test_index_appends_across_column_chunks(tmp_path, fitted, monkeypatch):
    monkeypatch.setattr(schema_module, "CHUNK_ENTRIES", 7)
    space, quantizer, points, pose = fitted
    path = tmp_path / "db.fs"
    with Store.create(path) as store, store.transaction():
        fill(store, fitted)
    with Store.open(path, read_only=False) as store:
        with store.transaction():
            motion = store.add_motion("extra", "new.bvh", BVH_TEXT)
            new = store.add_entries(
                [motion] * 5, points[:5], quantizer.keys(points[:5]), [0] * 5, [0] * 5,
                [0] * 5, [3] * 5,
            )  # fmt: skip
        np.testing.assert_array_equal(new, np.arange(120, 125))
        store.check()
    with Store.open(path) as store:
        arrays = store.arrays()
        assert store.n_entries == 125 and store.n_motions == 3
        np.testing.assert_array_equal(arrays.points[120:], points[:5])
        np.testing.assert_array_equal(arrays.motions[120:], [2] * 5)
        assert store.motion(2)["metadata"] == {}
        # The tree built from the store answers like brute force over its arrays.
        tree = TreeIndex.from_store(store, leaf_size=4)
        queries = points[::10] + 0.01
        found = tree.search(queries, top_k=3)
        reference = brute_force(arrays.points, arrays.ids, queries, 3)
        np.testing.assert_array_equal(found.ids, reference.ids)
        np.testing.assert_array_equal(found.distances, reference.distances)


def test_abort_leaves_nothing_behind(tmp_path, fitted):
    path = tmp_path / "db.fs"
    store = Store.create(path)
    with pytest.raises(RuntimeError, match="half way"), store.transaction():
        fill(store, fitted)
        raise RuntimeError("half way")
    store.close()
    with pytest.raises(DatabaseError, match="no schema_version"):
        Store.open(path)

    with Store.create(path, overwrite=True) as store, store.transaction():
        fill(store, fitted)
    with Store.open(path, read_only=False) as store:
        with pytest.raises(InvalidParameterError, match="never added"), store.transaction():
            store.add_motion("doomed", "x", BVH_TEXT)
            store.add_entries([99], fitted[2][:1], [0], [0], [0], [0], [0])
        assert store.n_motions == 2 and store.n_entries == 120
    with Store.open(path) as store:
        assert_holds(store, fitted)


def test_only_plain_data_is_pickled(tmp_path, fitted):
    from ZODB.FileStorage import FileIterator

    path = tmp_path / "db.fs"
    with Store.create(path) as store, store.transaction():
        fill(store, fitted)
    modules = set()
    for txn in FileIterator(str(path)):
        for record in txn:
            modules.update(
                word for word in (b"eigmotion", b"numpy") if record.data and word in record.data
            )
    assert modules == set()


def test_schema_mismatch_and_missing_files(tmp_path, fitted):
    import ZODB
    from ZODB.FileStorage import FileStorage

    missing = tmp_path / "nowhere.fs"
    with pytest.raises(DatabaseError, match="nowhere.fs"):
        Store.open(missing)
    assert not missing.exists()  # not silently created
    with pytest.raises(DatabaseError, match="does not exist"):
        Store.create(tmp_path / "no_dir" / "db.fs")

    path = tmp_path / "old.fs"
    with Store.create(path) as store, store.transaction():
        fill(store, fitted)
    with pytest.raises(DatabaseError, match="exists"):
        Store.create(path)
    db = ZODB.DB(FileStorage(str(path)))
    with db.transaction() as conn:
        conn.root()["schema_version"] = SCHEMA_VERSION + 1
    db.close()
    with pytest.raises(DatabaseError, match=f"version {SCHEMA_VERSION + 1}"):
        Store.open(path)

    garbage = tmp_path / "garbage.fs"
    garbage.write_bytes(b"not a database at all")
    with pytest.raises(DatabaseError, match="garbage.fs"):
        Store.open(garbage)


def test_read_only_and_transaction_rules(tmp_path, fitted):
    path = tmp_path / "db.fs"
    with Store.create(path) as store:
        with pytest.raises(DatabaseError, match="open transaction"):
            store.add_motion("a", "b", BVH_TEXT)
        with store.transaction():
            fill(store, fitted)
            with pytest.raises(DatabaseError, match="already open"), store.transaction():
                pass
    with Store.open(path) as store:
        with pytest.raises(DatabaseError, match="read-only"), store.transaction():
            pass
        with pytest.raises(InvalidParameterError, match="no entry"):
            store.entry(10_000)
    store.close()
    with pytest.raises(DatabaseError, match="closed"):
        store.arrays()


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"keys": "shuffled"}, "differ from the stored quantizer"),
        ({"points": "wide"}, r"\(N, 6\)"),
        ({"end_frame": -1}, "time window"),
        ({"view_azimuth_deg": np.nan}, "view_azimuth_deg"),
        ({"bodies": -1}, "bodies must be >= 0"),
        ({"bodies": 0.5}, "bodies must be integers"),
    ],
)
def test_add_entries_validates(fitted, change, match):
    space, quantizer, points, pose = fitted
    args = {
        "motion_ids": [0] * 4,
        "points": points[:4],
        "keys": quantizer.keys(points[:4]),
        "view_azimuth_deg": [0.0] * 4,
        "view_elevation_deg": [0.0] * 4,
        "start_frame": [0] * 4,
        "end_frame": [5] * 4,
    }
    for name, value in change.items():
        if value == "shuffled":
            args[name] = args[name][::-1] + 1
        elif value == "wide":
            args[name] = np.zeros((4, 7))
        else:
            args[name] = np.full(4, value)
    with Store.create("memory://") as store, store.transaction():
        store.initialise({}, space, quantizer, pose)
        store.add_motion("m", "s", BVH_TEXT)
        with pytest.raises(InvalidParameterError, match=match):
            store.add_entries(**args)


@pytest.mark.parametrize(
    ("config", "match"),
    [({"a": np.zeros(3)}, "ndarray"), ({"a": float("nan")}, "finite"), ({1: 2}, "not a string")],
)
def test_config_must_be_plain(fitted, config, match):
    space, quantizer, _, pose = fitted
    with Store.create("memory://") as store, store.transaction():
        with pytest.raises(InvalidParameterError, match=match):
            store.initialise(config, space, quantizer, pose)


def test_numpy_scalars_are_stored_as_plain_numbers(fitted):
    space, quantizer, _, pose = fitted
    with Store.create("memory://") as store:
        with store.transaction():
            store.initialise({"k": np.int64(6), "ratio": np.float32(0.5)}, space, quantizer, pose)
        assert store.config == {"k": 6, "ratio": 0.5}
        assert type(store.config["k"]) is int


@pytest.mark.parametrize(
    ("uri", "parsed"),
    [
        ("db/motions.fs", ("file", "db/motions.fs")),
        ("file:///tmp/a%20b.fs", ("file", "/tmp/a b.fs")),
        ("memory://", ("memory", "")),
        ("memory://tests", ("memory", "")),
        ("zeo://127.0.0.1:8100", ("zeo", "127.0.0.1:8100")),
    ],
)
def test_parse_uri(uri, parsed):
    assert parse_uri(uri) == parsed


@pytest.mark.parametrize(("uri", "match"), [("zeo://host", "port"), ("s3://x/y", "unknown")])
def test_parse_uri_errors(uri, match):
    with pytest.raises(DatabaseError, match=match):
        parse_uri(uri)


def test_zeo_clients_see_each_others_commits(tmp_path, fitted):
    import ZEO

    space, quantizer, points, pose = fitted
    address, stop = ZEO.server(path=str(tmp_path / "shared.fs"), port=0)
    uri = f"zeo://{address[0]}:{address[1]}"
    try:
        writer = Store.create(uri)
        with writer.transaction():
            fill(writer, fitted)
        reader = Store.open(uri)
        assert_holds(reader, fitted)
        with writer.transaction():
            motion = writer.add_motion("late", "late.bvh", BVH_TEXT)
            writer.add_entries(
                [motion] * 3, points[:3], quantizer.keys(points[:3]), [0] * 3, [0] * 3,
                [0] * 3, [2] * 3,
            )  # fmt: skip
        assert reader.n_entries == 120  # until it looks again
        reader.refresh()
        assert reader.n_entries == 123 and reader.arrays().points.shape == (123, 6)
        assert reader.motion(motion)["label"] == "late"
        reader.check()
        reader.close()
        writer.close()
        with pytest.raises(DatabaseError, match="already holds"):
            Store.create(uri)
    finally:
        stop()


def test_zeo_without_server(monkeypatch):
    import socket

    monkeypatch.setattr(storage_module, "ZEO_WAIT_S", 0.5)
    with socket.socket() as probe:  # a port nobody listens on
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    with pytest.raises(DatabaseError, match="no ZEO server"):
        Store.open(f"zeo://127.0.0.1:{port}")


@pytest.mark.parametrize(
    ("motion_id", "azimuth", "frames", "match"),
    [
        (7, [0.0], [np.zeros((3, 6))], "never added"),
        (0, [0.0, 1.0], [np.zeros((3, 6))], "shape"),
        (0, [0.0], [np.zeros((3, 5))], r"\(F >= 1, 6\)"),
        (0, [0.0], [np.zeros((0, 6))], r"\(F >= 1, 6\)"),
        (0, [0.0], [np.full((3, 6), np.nan)], "NaN"),
        (0, [0.0], [np.full((3, 6), 1e6)], "float16"),
        (0, [np.inf], [np.zeros((3, 6))], "infinity"),
    ],
)
def test_bad_sequences_are_refused_and_nothing_is_stored(fitted, motion_id, azimuth, frames, match):
    space, quantizer, _, pose = fitted
    with Store.create("memory://") as store:
        with store.transaction():
            store.initialise({}, space, quantizer, pose)
            store.add_motion("m", "s", BVH_TEXT)
            with pytest.raises(InvalidParameterError, match=match):
                store.add_sequences(motion_id, azimuth, [0.0] * len(azimuth), frames)
        assert store.sequences(0).lengths.size == 0


@pytest.mark.parametrize(
    ("key", "read", "what"),
    [
        ("eigenspace", Store.eigenspace, "eigenspace"),
        ("quantizer", Store.quantizer, "quantizer"),
        ("pose_space", Store.pose_space, "pose eigenspace"),
    ],
)
def test_a_damaged_fitted_state_is_named(fitted, key, read, what):
    space, quantizer, _, pose = fitted
    with Store.create("memory://") as store:
        with store.transaction():
            store.initialise({}, space, quantizer, pose)
            state = store._root()[key]
            for name in [n for n in state if n != "components"]:
                del state[name]  # as a torn write would leave it
        with pytest.raises(DatabaseError, match=f"stored {what} is damaged"):
            read(store)


@pytest.mark.parametrize(
    "speeds", [b"", np.array([0.1, np.nan]).tobytes(), np.array([-1.0, 0.2]).tobytes()]
)
def test_damaged_pose_speeds_are_named(fitted, speeds):
    with Store.create("memory://") as store, store.transaction():
        fill(store, fitted)
        store._root()["sequences"][0]["speeds"] = speeds  # two renderings stored
        with pytest.raises(DatabaseError, match="sequences of motion 0 are damaged"):
            store.sequences(0)
        del store._root()["sequences"][0]["speeds"]  # as written before speeds were kept
        assert store.sequences(0).speeds is None


def test_an_entry_keeps_the_body_it_was_rendered_on(fitted):
    space, quantizer, points, pose = fitted
    with Store.create("memory://") as store, store.transaction():
        store.initialise({}, space, quantizer, pose)
        motion = store.add_motion("m", "s", BVH_TEXT)
        part = points[:3]
        args = (np.full(3, motion), part, quantizer.keys(part), [0.0] * 3, [0.0] * 3, [0] * 3)
        with_bodies = store.add_entries(*args, [5] * 3, ["m"] * 3, [2, 0, 1])
        without = store.add_entries(*args, [5] * 3)
        assert [store.entry(i)["body"] for i in with_bodies] == [2, 0, 1]
        assert all("body" not in store.entry(i) for i in without)
        store.check()
