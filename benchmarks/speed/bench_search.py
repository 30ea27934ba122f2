"""Exact search through the key tree against brute force, KDTree and FAISS.

Run from the repository root::

    python benchmarks/speed/bench_search.py                 # 10^3 … 10^6 entries, k = 32
    python benchmarks/speed/bench_search.py --sizes 1000 100000 --dims 24
    python benchmarks/speed/bench_search.py --store 100000  # database build / open times
    python benchmarks/speed/bench_search.py --eigenspace 1000 16384 50   # vs sklearn PCA
    python benchmarks/speed/bench_search.py --real DB.fs    # points of a real database

For each database size it builds every index over the same points and answers the same
queries, and prints one Markdown table: build time, search time per query (all queries
in one call, and one query per call), the ratio against numpy brute force, the entries
examined, and how many answers equal the exact ones.  Then two smaller tables: the
queries of motions that are not in the database, and the key settings (equal-width vs
quantile sections, and the patent's plain exact-key lookup).

Times are CPU seconds of this process (``time.process_time``) with every library held
to one thread, so that a busy shared machine changes them little.  FAISS
(``pip install faiss-cpu``, the ``bench`` extra) is optional: its rows are skipped with
a note when it is missing.

With ``--real DB`` the points are a real database's motion-image points instead (see
:func:`real_sets`): the database's own entries, and a set of at least 10^6 entries
resampled from them; the queries are real motion-image points of renderings the set
does not hold.  Beside the trees, the row "…, cutoff at the true nearest distance"
searches the default tree with each query's own nearest distance as its cutoff, one
query per call in both columns: the cost of certifying an answer already known, the
least any visiting order of the tree's boxes can take.

Otherwise points are drawn like motion-image points: per-axis spread decaying like an
eigenvalue spectrum (std ∝ 1/√axis), in clusters of 500 entries (one per motion and
view), each cluster a smooth random walk (the time window sliding along the motion)
plus noise.  Known-motion queries are entries plus fresh noise of 1.5 times the
entries' own; unknown-motion queries come from clusters that are not in the database.
"""

from __future__ import annotations

import os

for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import argparse  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from eigmotion.retrieval.brute_force import BruteForceIndex  # noqa: E402
from eigmotion.retrieval.keys import Quantizer  # noqa: E402
from eigmotion.retrieval.neighbours import NearestEntries  # noqa: E402
from eigmotion.retrieval.search import TreeIndex  # noqa: E402

CLUSTER = 500


def motion_like(n: int, n_dims: int, rng: np.random.Generator) -> np.ndarray:
    """(n, n_dims) float32 points in clusters of ``CLUSTER`` (see the module docstring)."""
    scale = (1.0 / np.sqrt(np.arange(1, n_dims + 1))).astype(np.float32)
    groups = max(1, -(-n // CLUSTER))
    out = np.empty((groups * CLUSTER, n_dims), dtype=np.float32)
    for first in range(0, groups, 200):  # 200 clusters at a time bounds memory
        count = min(200, groups - first)
        centres = rng.standard_normal((count, 1, n_dims), dtype=np.float32) * scale
        walk = rng.standard_normal((count, CLUSTER, n_dims), dtype=np.float32) * (0.03 * scale)
        walk = np.cumsum(walk, axis=1) + centres
        walk += rng.standard_normal(walk.shape, dtype=np.float32) * (0.02 * scale)
        out[first * CLUSTER : (first + count) * CLUSTER] = walk.reshape(-1, n_dims)
    return out[:n]


def known_queries(points: np.ndarray, n: int, rng) -> np.ndarray:
    scale = 1.0 / np.sqrt(np.arange(1, points.shape[1] + 1))
    noise = 0.03 * scale * rng.standard_normal((n, points.shape[1]))
    return (points[rng.integers(0, len(points), n)] + noise).astype(np.float32)


def unknown_queries(n: int, n_dims: int, rng) -> np.ndarray:
    return motion_like(n * CLUSTER, n_dims, rng)[
        rng.integers(0, CLUSTER, n) + CLUSTER * np.arange(n)
    ]


def cpu(fn, *args):
    start = time.process_time()
    out = fn(*args)
    return out, time.process_time() - start


class Method:
    """One index: how to build it and how to search it (ids (Q,), examined (Q,))."""

    name = ""

    build_s = 0.0

    def build(self, points, ids):
        raise NotImplementedError

    def search(self, queries):
        raise NotImplementedError


class Brute(Method):
    def __init__(self, max_distance=np.inf):
        self.max_distance = max_distance
        self.name = "numpy brute force" + cutoff_note(max_distance)

    def build(self, points, ids):
        self.index = BruteForceIndex.from_arrays(points, ids)

    def search(self, queries):
        r = self.index.search(queries, max_distance=self.max_distance)
        return r.ids[:, 0], r.examined


def cutoff_note(max_distance) -> str:
    return "" if np.isinf(max_distance) else f", max_distance={max_distance:.3g}"


class Tree(Method):
    """The key tree; ``walk``: through the tree for every batch (``TreeIndex.walk``),
    else as ``TreeIndex.search`` chooses (large batches over small sets scanned);
    ``nodes``: the node tree walked nearest bound first instead of the flat search
    through its cells (``TreeIndex.cell_entries = 0``)."""

    def __init__(
        self, n_axes=4, n_sections=8, method="quantile", leaf_size=16, max_distance=np.inf,
        walk=False, nodes=False,
    ):  # fmt: skip
        self.params = (n_axes, n_sections, method, leaf_size)
        self.max_distance = max_distance
        self.walk = walk
        self.nodes = nodes
        self.name = (
            f"tree R={n_sections} K={n_axes} {method}"
            + (", walk" if walk else "")
            + (", node walk" if nodes else "")
            + cutoff_note(max_distance)
        )

    def build(self, points, ids):
        n_axes, n_sections, method, leaf_size = self.params
        quantizer = Quantizer(n_axes, n_sections, method).fit(points)
        keys = quantizer.keys(points)
        self.index = TreeIndex.from_arrays(keys, points, ids, quantizer, leaf_size)
        if self.nodes:
            self.index.cell_entries = 0
        self.depth = self.index.depth  # builds the tree now (a set it would scan: later)

    def search(self, queries) -> tuple[np.ndarray, np.ndarray]:
        find = self.index.walk if self.walk else self.index.search
        r: NearestEntries = find(queries, max_distance=self.max_distance)
        return r.ids[:, 0], r.examined


class KnownCutoff(Method):
    """A built tree searched with each query's own nearest distance as its cutoff, as
    if known beforehand: what remains is what certifying that answer costs — every box
    whose bound does not exceed it opened, every entry in them screened — the least an
    exact search through these boxes can do, however well it orders its visits."""

    def __init__(self, tree: Tree):
        self.tree = tree
        self.name = f"{tree.name}, cutoff at the true nearest distance"
        self.nearest: dict[bytes, float] = {}

    def build(self, points, ids):
        pass  # the tree's, built before

    def know(self, queries, distances) -> None:
        """Each query's nearest distance, as brute force gives it."""
        rows = np.ascontiguousarray(queries, np.float32)
        self.nearest = {q.tobytes(): float(d) for q, d in zip(rows, distances, strict=True)}

    def search(self, queries):
        ids, examined = [], []
        for q in np.ascontiguousarray(queries, np.float32):
            # just above the distance, so that the nearest entry itself is kept
            cutoff = self.nearest[q.tobytes()] * (1 + 1e-6)
            r = self.tree.index.walk(q[None], max_distance=cutoff)
            ids.append(r.ids[0, 0])
            examined.append(r.examined[0])
        return np.array(ids), np.array(examined)


class KeyLookup(Method):
    """The patent's query: nearest entry among those under the query's own key."""

    def __init__(self, n_axes, n_sections):
        self.params = (n_axes, n_sections)
        self.name = f"exact-key lookup R={n_sections} K={n_axes}"

    def build(self, points, ids):
        n_axes, n_sections = self.params
        self.quantizer = Quantizer(n_axes, n_sections).fit(points)
        keys = self.quantizer.keys(points)
        order = np.argsort(keys, kind="stable")
        self.keys, self.points, self.ids = keys[order], points[order], ids[order]

    def search(self, queries):
        keys = self.quantizer.keys(queries)
        lo = np.searchsorted(self.keys, keys, side="left")
        hi = np.searchsorted(self.keys, keys, side="right")
        found = np.full(len(queries), -1)
        for i, (a, b) in enumerate(zip(lo, hi, strict=True)):
            if b > a:
                d = ((self.points[a:b] - queries[i]) ** 2).sum(axis=1)
                found[i] = self.ids[a + int(np.argmin(d))]
        return found, hi - lo


class SkKDTree(Method):
    name = "sklearn KDTree"

    def build(self, points, ids):
        from sklearn.neighbors import KDTree

        self.index, self.ids = KDTree(points, leaf_size=40), ids

    def search(self, queries):
        _, found = self.index.query(queries, k=1)
        return self.ids[found[:, 0]], np.full(len(queries), -1)


class FaissFlat(Method):
    name = "FAISS IndexFlatL2"

    def build(self, points, ids):
        import faiss

        self.index, self.ids = faiss.IndexFlatL2(points.shape[1]), ids
        self.index.add(points)

    def search(self, queries):
        _, found = self.index.search(np.ascontiguousarray(queries, dtype=np.float32), 1)
        return self.ids[found[:, 0]], np.full(len(queries), len(self.ids))


class FaissHNSW(Method):
    name = "FAISS HNSW (M=32, ef=64)"

    def build(self, points, ids):
        import faiss

        self.index, self.ids = faiss.IndexHNSWFlat(points.shape[1], 32), ids
        self.index.hnsw.efConstruction = 64
        self.index.add(points)
        self.index.hnsw.efSearch = 64

    def search(self, queries):
        _, found = self.index.search(np.ascontiguousarray(queries, dtype=np.float32), 1)
        return self.ids[found[:, 0]], np.full(len(queries), -1)


def have_faiss() -> bool:
    try:
        import faiss

        faiss.omp_set_num_threads(1)
    except ImportError:
        return False
    return True


def measure(method: Method, points, ids, queries, reference, n_single: int, build=True) -> dict:
    build_s = cpu(method.build, points, ids)[1] if build else method.build_s
    (found, examined), batch_s = cpu(method.search, queries)
    single_s = 0.0
    for q in queries[:n_single]:
        _, t = cpu(method.search, q[None, :])
        single_s += t
    return {
        "build_s": build_s,
        "batch_us": 1e6 * batch_s / len(queries),
        "single_us": 1e6 * single_s / max(n_single, 1),
        "examined": float(np.mean(examined)) if np.all(examined >= 0) else None,
        "exact": float(np.mean(found == reference)),
    }


def fmt_row(n, name, row, base) -> str:
    examined = (
        "—"
        if row["examined"] is None
        else f"{row['examined']:.0f} ({100 * row['examined'] / n:.3g}%)"
    )
    return (
        f"| {n:,} | {name} | {row['build_s']:.2f} | {row['batch_us']:.0f} | "
        f"{base['batch_us'] / row['batch_us']:.1f}× | {row['single_us']:.0f} | "
        f"{base['single_us'] / row['single_us']:.1f}× | {examined} | {100 * row['exact']:.1f}% |"
    )


HEADER = (
    "| entries | method | build s | µs/query (batch) | vs brute | µs/query (single) | "
    "vs brute | examined (mean) | exact |\n|---:|---|---:|---:|---:|---:|---:|---:|---:|"
)


def bench_store(n: int, n_dims: int, rng) -> None:
    """Wall time to build, open and check a FileStorage database of ``n`` entries."""
    import tempfile
    from pathlib import Path

    from eigmotion.retrieval.eigenspace import Eigenspace
    from eigmotion.retrieval.store import Store

    images = rng.standard_normal((200, 4096)).astype(np.float32)
    images /= np.linalg.norm(images, axis=1, keepdims=True)
    space = Eigenspace(n_components=n_dims).fit(images)
    points = motion_like(n, n_dims, rng)
    quantizer = Quantizer(4, 8).fit(points)
    keys = quantizer.keys(points)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "db.fs"
        start = time.perf_counter()
        with Store.create(path) as store, store.transaction():
            store.initialise({"n_dims": n_dims}, space, quantizer, space)
            motion = store.add_motion("walk", "walk.bvh", "HIERARCHY\n" * 1000)
            zeros = np.zeros(n)
            store.add_entries(np.full(n, motion), points, keys, zeros, zeros, zeros.astype(int),
                              np.ones(n, dtype=int))  # fmt: skip
        build_s = time.perf_counter() - start
        size_mb = path.stat().st_size / 1e6
        start = time.perf_counter()
        store = Store.open(path)
        open_s = time.perf_counter() - start
        start = time.perf_counter()
        TreeIndex.from_store(store)
        tree_s = time.perf_counter() - start
        start = time.perf_counter()
        store.check()
        check_s = time.perf_counter() - start
        store.close()
    print(
        "| entries | build + commit | file | open (arrays in memory) | TreeIndex.from_store "
        "| check() |\n|---:|---:|---:|---:|---:|---:|"
    )
    print(
        f"| {n:,} | {build_s:.1f} s | {size_mb:.0f} MB | {open_s:.2f} s | {tree_s:.2f} s "
        f"| {check_s:.1f} s |"
    )


def bench_eigenspace(n_rows: int, n_features: int, k: int, rng) -> None:
    """The Gram-matrix eigenspace against scikit-learn's PCA solvers (CPU time)."""
    from sklearn.decomposition import PCA

    from eigmotion.retrieval.eigenspace import Eigenspace

    basis = rng.standard_normal((60, n_features))
    weights = rng.standard_normal((n_rows, 60)) / np.arange(1, 61)
    x = (weights @ basis + 0.05 * rng.standard_normal((n_rows, n_features))).astype(np.float32)
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    ours, ours_s = cpu(Eigenspace(n_components=k).fit, x)
    mine = ours.components_.astype(np.float64)
    print(
        f"| method (P={n_rows}, D={n_features}, k={k}) | CPU s | min cos | max eigenvalue "
        "rel. error |\n|---|---:|---:|---:|"
    )
    print(f"| Eigenspace (Gram matrix) | {ours_s:.2f} | — | — |")
    for solver in ("full", "randomized"):
        pca, pca_s = cpu(PCA(n_components=k, svd_solver=solver, random_state=0).fit, x)
        cos = np.sum(pca.components_ * mine, axis=1)  # signed: same sign convention
        eig = pca.explained_variance_ * (n_rows - 1)
        err = np.max(np.abs(eig - ours.eigenvalues_) / ours.eigenvalues_)
        print(f"| PCA(svd_solver={solver!r}) | {pca_s:.2f} | {cos.min():.7f} | {err:.1e} |")


def load_real(uri: str) -> tuple[np.ndarray, dict, np.ndarray]:
    """A database's entry points (N, k) float32; per entry, its motion, body (build and
    clothing, ``body``), view azimuth and elevation (degrees) and window (frames); and
    which bodies count as one person's ((B, B) bool, ``BuildConfig.alike_bodies``)."""
    from eigmotion.retrieval.library_views import BuildConfig
    from eigmotion.retrieval.store import Store

    fields = ("motion", "body", "view_azimuth_deg", "view_elevation_deg", "start_frame",
              "end_frame")  # fmt: skip
    with Store.open(uri) as store:
        arrays = store.arrays()
        rows = [store.entry(int(i)) for i in arrays.ids]
        alike = BuildConfig.from_dict(store.config["build"]).alike_bodies()
    meta = {f: np.array([row.get(f, 0) for row in rows]) for f in fields}
    return np.array(arrays.points, dtype=np.float32), meta, alike


def interpolate_renderings(points, meta, rows: np.ndarray, target: int, rng) -> np.ndarray:
    """(≥ target, k) float32: the entries ``rows`` and, inside every cell between an
    entry, the next window of the same rendering (same motion, clothing, elevation,
    azimuth and window length; the entry itself when it is the last) and the same two
    windows seen from the next azimuth, points at random positions ``(u, v)`` in
    [0, 1)², bilinear between the four corners: windows between the database's window
    steps seen from views between its views.  No point is repeated."""

    def cell_key(r, azimuth, start):
        return (meta["motion"][r], meta["body"][r], meta["view_elevation_deg"][r],
                meta["end_frame"][r] - meta["start_frame"][r], azimuth % 360.0, start)  # fmt: skip

    azimuths = np.unique(meta["view_azimuth_deg"][rows])
    next_azimuth = dict(zip(azimuths, np.roll(azimuths, -1), strict=True))
    where, starts = {}, {}
    for r in rows:
        az, start = meta["view_azimuth_deg"][r], meta["start_frame"][r]
        where[cell_key(r, az, start)] = r
        starts.setdefault(cell_key(r, az, None), []).append(start)
    following = {
        chain: dict(zip(sorted(v), sorted(v)[1:], strict=False)) for chain, v in starts.items()
    }
    corners = np.empty((rows.size, 4), dtype=np.int64)
    for j, r in enumerate(rows):
        az, start = meta["view_azimuth_deg"][r], meta["start_frame"][r]
        later = following[cell_key(r, az, None)].get(start, start)
        turned = where.get(cell_key(r, next_azimuth[az], start), r)
        r10 = where.get(cell_key(r, az, later), r)
        r11 = where.get(cell_key(r, next_azimuth[az], later), r10 if turned == r else turned)
        corners[j] = (r, r10, turned, r11)
    per = -(-(target - rows.size) // rows.size)
    out = [points[rows]]
    for lo in range(0, rows.size, 4096):  # bounds memory
        c = points[corners[lo : lo + 4096]][:, None]  # (m, 1, 4, k)
        u = rng.random((c.shape[0], per, 1), dtype=np.float32)
        v = rng.random((c.shape[0], per, 1), dtype=np.float32)
        mix = (1 - u) * (1 - v) * c[:, :, 0] + u * (1 - v) * c[:, :, 1]
        mix += (1 - u) * v * c[:, :, 2] + u * v * c[:, :, 3]
        out.append(mix.reshape(-1, points.shape[1]))
    return np.concatenate(out).astype(np.float32)


def real_sets(uri: str, target: int, n_queries: int, rng):
    """The sets of ``--real``: ``(base, resampled, known, unknown)`` float32 points.

    * Held out: a tenth of the motions (chosen by the seed), every rendering of them
      — their entries are the **unknown-motion** queries; and of the other motions
      every entry on the build's last body (``body``) — these are the **known-motion**
      queries: the same motions and views rendered on another person, real
      motion-image points that no entry equals.
    * ``base``: every other entry of the database, but those on bodies of the last
      body's build or clothing (``BuildConfig.alike_bodies``, as the "unknown"
      threshold's calibration leaves them out).
    * ``resampled``: ``base`` and bilinear points between its neighbouring windows and
      views (:func:`interpolate_renderings`) up to ``target`` entries.
    """
    points, meta, alike = load_real(uri)
    motions = np.unique(meta["motion"])
    held = rng.choice(motions, max(1, motions.size // 10), replace=False)
    unknown = np.isin(meta["motion"], held)
    last = meta["body"].max()
    known = ~unknown & (meta["body"] == last)
    if not known.any() or last == 0:
        raise SystemExit(f"{uri}: one body only, no known-motion queries to hold out")
    base = ~unknown & ~alike[last][meta["body"]]
    resampled = interpolate_renderings(points, meta, np.flatnonzero(base), target, rng)

    def pick(mask):
        return points[rng.choice(np.flatnonzero(mask), min(n_queries, mask.sum()), replace=False)]

    return points[base], resampled, pick(known), pick(unknown)


def bench_real(uri: str, target: int, n_queries: int, n_single: int, faiss_ok: bool, rng):
    """Tables of the sets of :func:`real_sets`, known- and unknown-motion queries."""
    base, resampled, known, unknown = real_sets(uri, target, n_queries, rng)
    print(
        f"Real motion-image points of {uri} (k = {base.shape[1]}): {len(base):,} entries "
        f"of the database, {len(resampled):,} resampled from them; {len(known)} known-motion "
        f"and {len(unknown)} unknown-motion queries, {n_single} of each timed one by one; "
        "CPU time, one thread.\n"
    )
    for points in (base, resampled):
        n, ids = len(points), np.arange(len(points))
        trees = [Tree(4, 8), Tree(4, 8, walk=True), Tree(10, 4, walk=True),
                 Tree(10, 4, walk=True, nodes=True)]  # fmt: skip
        known_cutoff = KnownCutoff(trees[2])
        methods = [Brute(), *trees, known_cutoff, SkKDTree()] + (
            [FaissFlat(), FaissHNSW()] if faiss_ok else []
        )
        for method in methods:
            method.build_s = cpu(method.build, points, ids)[1]
        for kind, queries in (("known", known), ("unknown", unknown)):
            print(f"{kind}-motion queries, {n:,} entries:\n\n{HEADER}")
            reference = methods[0].index.search(queries)
            known_cutoff.know(queries, reference.distances[:, 0])
            base_row = None
            for method in methods:
                row = measure(method, points, ids, queries, reference.ids[:, 0], n_single, False)
                base_row = base_row or row
                print(fmt_row(n, method.name, row, base_row), flush=True)
            for tree in trees:
                same = tree.index.walk(queries)
                assert np.array_equal(same.ids, reference.ids), "tree differs from brute force"
                assert np.array_equal(same.distances, reference.distances)
            print()


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1000, 10_000, 100_000, 1_000_000])
    parser.add_argument("--dims", type=int, default=32, help="eigen-coordinates k")
    parser.add_argument("--queries", type=int, default=1000)
    parser.add_argument("--single", type=int, default=50, help="queries timed one by one")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--store", type=int, metavar="N", help="instead: time a FileStorage database of N entries"
    )
    parser.add_argument(
        "--eigenspace",
        type=int,
        nargs=3,
        metavar=("P", "D", "K"),
        help="instead: time the eigenspace fit against scikit-learn PCA",
    )
    parser.add_argument("--real", metavar="DB", help="instead: points of this database (read only)")
    parser.add_argument(
        "--real-size", type=int, default=1_000_000, help="entries resampled from --real's"
    )
    args = parser.parse_args(argv)
    rng = np.random.default_rng(args.seed)
    if args.store:
        bench_store(args.store, args.dims, rng)
        return 0
    if args.eigenspace:
        bench_eigenspace(*args.eigenspace, rng)
        return 0
    faiss_ok = have_faiss()
    # The tree's walk is compiled on first use (and numba loaded, which decides how
    # small sets are searched): walk once before timing.
    warm = Tree(walk=True)
    points = motion_like(CLUSTER, args.dims, np.random.default_rng(args.seed))
    warm.build(points, np.arange(CLUSTER))
    warm.search(points[:2])
    warm.index.cell_entries = 0
    warm.search(points[:2])

    if args.real:
        bench_real(args.real, args.real_size, args.queries, args.single, faiss_ok, rng)
        return 0
    print(
        f"k = {args.dims} eigen-coordinates, {args.queries} known-motion queries per size, "
        f"{args.single} timed one by one; CPU time, one thread.\n"
    )
    print(HEADER)
    last = None
    for n in args.sizes:
        points = motion_like(n, args.dims, rng)
        ids = np.arange(n)
        queries = known_queries(points, args.queries, rng)
        brute = Brute()
        brute.build(points, ids)
        reference, _ = brute.search(queries)
        methods = [brute, Tree(), Tree(nodes=True), SkKDTree()]
        if faiss_ok:
            methods += [FaissFlat(), FaissHNSW()]
        rows = {}
        for method in methods:
            rows[method.name] = measure(method, points, ids, queries, reference, args.single)
            print(fmt_row(n, method.name, rows[method.name], rows[brute.name]), flush=True)
        distances = brute.index.search(queries).distances[:, 0]
        last = (n, points, ids, rows[brute.name], distances)
    if not faiss_ok:
        print("\nFAISS rows skipped: faiss is not importable (pip install faiss-cpu).")

    n, points, ids, base, known_distances = last
    # The patent's threshold: a query farther than it from every entry is "unknown".
    # Here twice the 99th percentile of known-motion queries' nearest distances.
    cutoff = 2.0 * float(np.percentile(known_distances, 99))
    print(f"\nQueries of motions not in the database, {n:,} entries:\n")
    print(HEADER)
    queries = unknown_queries(min(args.queries, 200), args.dims, rng)
    for max_distance in (np.inf, cutoff):
        brute = Brute(max_distance)
        brute.build(points, ids)
        reference, _ = brute.search(queries)
        rows = {}
        for method in (brute, Tree(max_distance=max_distance),
                       Tree(max_distance=max_distance, nodes=True)):  # fmt: skip
            single = min(args.single, 20)
            rows[method.name] = measure(method, points, ids, queries, reference, single)
            print(fmt_row(n, method.name, rows[method.name], rows[brute.name]), flush=True)
    print(
        f"(with max_distance, {100 * np.mean(reference < 0):.0f}% of these queries are "
        'answered "unknown": no entry that near)'
    )

    n_keys = min(100_000, max(args.sizes))
    print(f"\nKey settings, {n_keys:,} entries (known-motion queries):\n")
    print(HEADER)
    points, ids = motion_like(n_keys, args.dims, rng), np.arange(n_keys)
    queries = known_queries(points, args.queries, rng)
    brute = Brute()
    brute.build(points, ids)
    reference, _ = brute.search(queries)
    base = measure(brute, points, ids, queries, reference, args.single)
    methods = [
        Tree(4, 8, "quantile"),
        Tree(4, 8, "equal"),
        Tree(2, 16, "quantile"),
        Tree(2, 16, "equal"),
        Tree(8, 4, "quantile"),
        Tree(8, 4, "equal"),
        KeyLookup(4, 4),
        KeyLookup(4, 8),
        KeyLookup(2, 16),
    ]
    for method in methods:
        row = measure(method, points, ids, queries, reference, args.single)
        print(fmt_row(n_keys, method.name, row, base), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
