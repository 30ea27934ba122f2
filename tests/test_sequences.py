"""Silhouette sequences: frames, time warping, the pose eigenspace and the fused rank."""

from __future__ import annotations

import numpy as np
import pytest

from eigmotion.errors import InvalidParameterError, VideoError
from eigmotion.retrieval.motion_image import ClipMotionImages, MotionImageConfig
from eigmotion.retrieval.sequences import (
    LOWER_BODY_WEIGHT,
    PACE_FLOOR,
    PACE_SMOOTHING_PASSES,
    PACE_WEIGHT,
    POSE_COMPONENTS,
    RISE_WEIGHT,
    SEQUENCE_SIZE,
    SEQUENCE_WEIGHT,
    SPEED_BLOCK_FRAMES,
    VIEW_REACH_DEG,
    _banded_costs,
    _frame_distances,
    _lower_bounds,
    _warp,
    _warp_with_loop,
    fit_pose_space,
    fused_scores,
    nearest_sequence_distances,
    pace_factors,
    pose_coordinates,
    pose_speeds,
    sequence_distances,
    sequence_frames,
    view_reach,
    widen_frames,
)


def reference_warp(a: np.ndarray, b: np.ndarray, band: float = 1.0) -> float:
    """Dynamic time warping written out from its definition, for comparison: the path
    keeps within ``band · max(n, m)`` frames of the diagonal."""
    n, m = len(a), len(b)
    cost = np.full((n + 1, m + 1), np.inf)
    cost[0, 0] = 0.0
    for i in range(1, n + 1):
        diagonal = (i - 0.5) * m / n + 0.5
        for j in range(1, m + 1):
            if abs(j - diagonal) > band * max(n, m):
                continue
            step = min(cost[i - 1, j], cost[i, j - 1], cost[i - 1, j - 1])
            cost[i, j] = float(np.linalg.norm(a[i - 1] - b[j - 1])) + step
    return cost[n, m] / (n + m)


@pytest.mark.parametrize("band", [1.0, 0.3, 0.1])
def test_warping_equals_its_definition(band):
    rng = np.random.default_rng(0)
    query = rng.random((9, 6)).astype(np.float32)
    others = [rng.random((n, 6)).astype(np.float32) for n in (1, 4, 13, 9, 30)]
    lengths = np.array([len(o) for o in others])
    found = sequence_distances(query, np.concatenate(others), lengths, band=band)
    expected = [reference_warp(query.astype(np.float64), o.astype(float), band) for o in others]
    np.testing.assert_allclose(found, expected, rtol=1e-5)


def test_the_band_keeps_the_path_near_the_diagonal():
    # The same path after a long pause: a free path waits out the pause at no cost;
    # one that keeps near the diagonal must pay for leaving it.
    t = np.linspace(0.0, 1.0, 20)
    path = np.stack([np.sin(3 * t), np.cos(2 * t), t], axis=1).astype(np.float32)
    paused = np.concatenate([np.repeat(path[:1], 20, axis=0), path])
    free = sequence_distances(path, paused, np.array([40]), band=1.0)[0]
    banded = sequence_distances(path, paused, np.array([40]), band=0.1)[0]
    assert free == pytest.approx(0.0, abs=1e-3)
    assert banded > 0.05
    assert sequence_distances(path, paused, np.array([40]))[0] >= free
    with pytest.raises(InvalidParameterError, match="band"):
        sequence_distances(path, paused, np.array([40]), band=0.0)


def test_a_slower_performance_is_nearer_than_another_motion():
    # A pose path, the same path at half the pace, and the path backwards.
    t = np.linspace(0.0, 1.0, 12)
    path = np.stack([np.sin(3 * t), np.cos(2 * t), t], axis=1).astype(np.float32)
    slow = np.repeat(path, 2, axis=0)
    backwards = path[::-1].copy()
    found = sequence_distances(
        path, np.concatenate([path, slow, backwards]), np.array([12, 24, 12])
    )
    assert found[0] == pytest.approx(0.0, abs=1e-3)
    assert found[1] == pytest.approx(0.0, abs=1e-3)  # repeated frames cost nothing
    assert found[2] > 0.1


def test_warping_is_symmetric_and_orders_by_similarity():
    rng = np.random.default_rng(2)
    a = rng.random((15, 6)).astype(np.float32)
    near = a + 0.01 * rng.standard_normal(a.shape).astype(np.float32)
    far = rng.random((15, 6)).astype(np.float32)
    one = np.array([15])
    assert sequence_distances(a, far, one)[0] == pytest.approx(sequence_distances(far, a, one)[0])
    assert sequence_distances(a, near, one)[0] < sequence_distances(a, far, one)[0]


def test_warping_on_two_threads_gives_the_same_distances_to_the_bit():
    from concurrent.futures import ThreadPoolExecutor

    rng = np.random.default_rng(3)
    query = rng.random((20, 8)).astype(np.float32)
    lengths = rng.integers(1, 40, size=301)  # enough to be split over the threads
    frames = rng.random((int(lengths.sum()), 8)).astype(np.float32)
    with ThreadPoolExecutor(max_workers=1) as workers:
        both = sequence_distances(query, frames, lengths, workers=workers)
        one = sequence_distances(query, frames[: lengths[0]], lengths[:1], workers=workers)
    np.testing.assert_array_equal(both, sequence_distances(query, frames, lengths))
    np.testing.assert_array_equal(one, sequence_distances(query, frames[: lengths[0]], lengths[:1]))


def test_warping_equals_the_path_cost_by_hand():
    a = np.array([[0.0], [1.0]])
    b = np.array([[0.0], [2.0], [1.0]])
    # Best path (0,0) (1,1) (1,2): costs 0 + 1 + 0, over 2 + 3 frames.
    assert sequence_distances(a, b, np.array([3]))[0] == pytest.approx(1.0 / 5.0)


def test_sequence_frames_are_sampled_aligned_and_small():
    from eigmotion.synth.scene import stick_figure_masks

    config = MotionImageConfig()
    masks = stick_figure_masks(60, 120, 160, fps=30.0)  # 2 s at 30 fps
    images = ClipMotionImages(masks, config, clip_fps=30.0)
    frames = sequence_frames(images)
    # Sampled at the motion image's 15 frames/s, 16 × 16 pixels and the rise per frame.
    assert frames.shape == (30, SEQUENCE_SIZE**2 + 1) and frames.dtype == np.float32
    silhouettes, rise = frames[:, :-1], frames[:, -1]
    assert 0.0 <= silhouettes.min() and silhouettes.max() <= 1.0
    assert np.all(silhouettes.sum(axis=1) > 0)  # the person is in every frame
    np.testing.assert_array_equal(rise, images.rise())
    # The aligned silhouettes, the lower half (below the body centre) weighed less.
    aligned = images.aligned(SEQUENCE_SIZE)
    half = SEQUENCE_SIZE // 2
    square = silhouettes.reshape(aligned.shape)
    np.testing.assert_array_equal(square[:, :half], aligned[:, :half])
    np.testing.assert_allclose(square[:, half:], LOWER_BODY_WEIGHT * aligned[:, half:])
    assert aligned[:, half:].sum() > 0.2 * aligned.sum()  # the legs are there to weigh
    with pytest.raises(VideoError):
        sequence_frames(ClipMotionImages(np.zeros((10, 60, 40), dtype=bool), config, 30.0))


def _block_person(tops: list[int], bottoms: list[int], height_px: int = 120) -> np.ndarray:
    """(F, height_px, 60) bool: a 20 px wide block from row ``tops[f]`` to ``bottoms[f]``."""
    masks = np.zeros((len(tops), height_px, 60), dtype=bool)
    for f, (top, bottom) in enumerate(zip(tops, bottoms, strict=True)):
        masks[f, top:bottom, 20:40] = True
    return masks


def test_rise_follows_the_top_of_the_body_in_body_heights():
    config = MotionImageConfig()
    # 30 frames at 15 fps (every one sampled): 40 px tall, still, then 20 px up (a
    # jump), or its top 20 px down while the feet stay (a crouch).
    still = ClipMotionImages(_block_person([50] * 30, [90] * 30), config, 15.0)
    np.testing.assert_array_equal(still.rise(), np.zeros(30, dtype=np.float32))
    lift = [0] * 20 + [20] * 10
    jump = ClipMotionImages(
        _block_person([50 - d for d in lift], [90 - d for d in lift]), config, 15.0
    )
    rise = jump.rise()
    assert rise.shape == (30,) and rise.dtype == np.float32
    np.testing.assert_allclose(rise[:20], 0.0, atol=1e-6)
    # 20 px over a body height of 40 px less the trimmed sliver of mass.
    assert 0.5 <= rise[20:].min() and rise[20:].max() <= 0.6
    crouch = ClipMotionImages(_block_person([50] * 20 + [70] * 10, [90] * 30), config, 15.0)
    assert np.all(crouch.rise()[20:] < -0.2)  # the top sinks a quarter of the body height
    # Frames without a person are left out, as by ``aligned``.
    gap = _block_person([50] * 30, [90] * 30)
    gap[10:14] = False
    images = ClipMotionImages(gap, config, 15.0)
    assert images.rise().shape == (26,) == images.aligned(SEQUENCE_SIZE).shape[:1]


def test_pose_space_keeps_its_axes_or_every_axis_there_is():
    rng = np.random.default_rng(1)
    many = rng.random((500, SEQUENCE_SIZE**2 + 1)).astype(np.float32)
    assert fit_pose_space(many).n_components_ == POSE_COMPONENTS
    few = rng.random((6, SEQUENCE_SIZE**2 + 1)).astype(np.float32)
    assert fit_pose_space(few).n_components_ == 5  # six frames span five directions


def test_pose_coordinates_are_the_silhouettes_projection_and_the_weighted_rise():
    rng = np.random.default_rng(3)
    frames = rng.random((200, SEQUENCE_SIZE**2 + 1)).astype(np.float32)
    space = fit_pose_space(frames)
    # The rise does not enter the eigenspace: the same fit without it.
    np.testing.assert_allclose(
        space.components_, fit_pose_space(frames[:, :-1].copy()).components_, atol=1e-6
    )
    coordinates = pose_coordinates(space, frames[:7])
    assert coordinates.shape == (7, POSE_COMPONENTS + 1) and coordinates.dtype == np.float32
    np.testing.assert_allclose(coordinates[:, :-1], space.transform(frames[:7, :-1]), atol=1e-5)
    np.testing.assert_allclose(coordinates[:, -1], RISE_WEIGHT * frames[:7, -1], rtol=1e-6)


def test_view_reach_wraps_around_the_circle():
    reach = VIEW_REACH_DEG
    azimuths = np.array([0.0, reach, reach + 1.0, 360.0 - reach - 1.0, 360.0 - reach, 180.0])
    np.testing.assert_array_equal(view_reach(azimuths, 0.0), [1, 1, 0, 0, 1, 0])
    np.testing.assert_array_equal(view_reach(azimuths, 350.0), [1, 0, 0, 1, 1, 0])


def test_fused_scores_weigh_both_distances_by_their_smallest():
    image = np.array([1.0, 1.2, 2.0])
    sequence = np.array([0.9, 0.3, np.inf])
    scores = fused_scores(image, sequence)
    np.testing.assert_allclose(scores[:2], [1.0 + SEQUENCE_WEIGHT * 3.0, 1.2 + SEQUENCE_WEIGHT])
    assert scores[2] == np.inf
    assert np.argmin(scores) == 1  # much nearer in sequence, a little farther in image
    # without any sequence distance the motion image's order stands
    unknown = fused_scores(image, np.full(3, np.inf))
    np.testing.assert_array_equal(np.argsort(unknown, kind="stable"), [0, 1, 2])
    assert np.all(np.isfinite(fused_scores(np.array([0.0, 1.0]), np.array([0.0, 1.0]))[1:]))


def reference_speed(frames: np.ndarray) -> float:
    """The pose speed of one sequence, written out frame by frame."""
    x = frames.astype(np.float64)
    for _ in range(PACE_SMOOTHING_PASSES):
        smoothed = x.copy()
        for i in range(1, len(x) - 1):
            smoothed[i] = 0.25 * x[i - 1] + 0.5 * x[i] + 0.25 * x[i + 1]
        x = smoothed
    steps = [np.linalg.norm(x[i + 1] - x[i]) for i in range(len(x) - 1)]
    return float(np.mean(steps)) if steps else 0.0


def test_pose_speeds_equal_their_definition_sequence_by_sequence():
    rng = np.random.default_rng(3)
    sequences = [rng.normal(size=(n, 5)) for n in (1, 2, 3, 7, 30)]
    found = pose_speeds(np.concatenate(sequences), np.array([len(s) for s in sequences]))
    np.testing.assert_allclose(found, [reference_speed(s) for s in sequences], rtol=1e-12)
    assert found[0] == 0.0  # one frame: no step


def test_pose_speeds_of_many_sequences_are_each_ones_own_to_the_bit():
    # Enough frames for several blocks (SPEED_BLOCK_FRAMES), sequences across their
    # edges included: each speed is the one of its sequence taken alone.
    rng = np.random.default_rng(4)
    lengths = rng.integers(1, 300, size=60)
    frames = rng.normal(size=(int(lengths.sum()), 7)).astype(np.float32)
    assert lengths.sum() > 5 * SPEED_BLOCK_FRAMES
    found = pose_speeds(frames, lengths)
    starts = np.concatenate([[0], np.cumsum(lengths)])
    pairs = zip(starts[:-1], starts[1:], strict=True)
    alone = [pose_speeds(frames[a:b], [b - a])[0] for a, b in pairs]
    np.testing.assert_array_equal(found, alone)
    np.testing.assert_array_equal(pose_speeds(frames[:0], []), np.empty(0))


def test_pose_speed_doubles_with_the_pace_and_jitter_is_smoothed_away():
    t = np.arange(60) / 15.0

    def path(hz):
        return np.stack([np.sin(2 * np.pi * hz * t), np.cos(2 * np.pi * hz * t)], axis=1)

    slow, fast = pose_speeds(np.concatenate([path(0.5), path(1.0)]), np.array([60, 60]))
    # twice the pace, less what the filter takes off the faster one: each pass keeps
    # cos²(π f / 15 Hz) of a frequency f
    kept = (np.cos(np.pi * 1.0 / 15.0) / np.cos(np.pi * 0.5 / 15.0)) ** (2 * PACE_SMOOTHING_PASSES)
    assert fast / slow == pytest.approx(2.0 * kept, rel=0.01)
    # frame-to-frame jitter of a still pose: the steps between the raw frames are
    # about 0.14 long on average, the smoothed ones much shorter
    still = 0.1 * np.random.default_rng(0).normal(size=(60, 2))
    raw = float(np.mean(np.linalg.norm(np.diff(still, axis=0), axis=1)))
    assert pose_speeds(still, np.array([60]))[0] < 0.5 * raw


def test_pace_factors_grow_with_the_ratio_of_pose_speeds_from_one():
    speeds = np.array([0.5, 1.0, 2.0, 0.0])
    factors = pace_factors(1.0, speeds)
    assert factors[1] == 1.0  # the same pace costs nothing
    assert np.all(factors >= 1.0)
    expected = 1.0 + PACE_WEIGHT * abs(np.log((1.0 + PACE_FLOOR) / (2.0 + PACE_FLOOR)))
    assert factors[2] == pytest.approx(expected)
    assert factors[3] > factors[0] > factors[1]  # the farther the pace, the dearer
    # speeds under the floor, mostly the jitter of a still body, count for little
    assert pace_factors(0.05, np.array([0.0]))[0] < 1.0 + 0.15 * PACE_WEIGHT


def _random_costs(seed: int, band: float, count: int = 40, dims: int = 6):
    """(query, frames, lengths, starts, banded frame distances) of random sequences."""
    rng = np.random.default_rng(seed)
    query = rng.standard_normal((17, dims)).astype(np.float32)
    lengths = rng.integers(1, 50, size=count)
    frames = rng.standard_normal((int(lengths.sum()), dims)).astype(np.float32)
    starts = np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64)
    cost = _banded_costs(_frame_distances(query, frames, starts, None), starts, band)
    return query, frames, lengths, starts, cost


@pytest.mark.parametrize("band", [1.0, 0.3, 0.05])
def test_the_compiled_and_the_numpy_warping_give_the_same_distances_to_the_bit(band):
    _, _, lengths, _, cost = _random_costs(5, band)
    compiled, vectorised = np.empty(len(lengths)), np.empty(len(lengths))
    _warp_with_loop(cost, lengths, compiled)
    _warp(cost, lengths, vectorised)
    assert np.isfinite(vectorised).any()
    np.testing.assert_array_equal(vectorised, compiled)


@pytest.mark.parametrize("band", [1.0, 0.3, 0.1, 0.02])
@pytest.mark.parametrize("seed", range(4))
def test_the_lower_bounds_are_never_above_the_warping_distance_to_the_bit(band, seed):
    query, frames, lengths, _, cost = _random_costs(seed, band, count=200, dims=3 + seed)
    bounds = _lower_bounds(cost, lengths)
    distances = sequence_distances(query, frames, lengths, band=band)
    assert np.all(bounds <= distances)  # inf where no path keeps to the band: inf <= inf
    assert np.array_equal(np.isinf(bounds), np.isinf(distances))
    finite = np.isfinite(distances)
    assert finite.any()
    # close enough to rule renderings out: most within a factor 2 of the distance
    assert np.median(bounds[finite] / distances[finite]) > 0.5


def _renderings_of_motions(seed: int, n_owners: int, per_owner: int):
    """A query and ``per_owner`` noisy, retimed renderings of each of ``n_owners``
    random pose paths (one of them the query's), with random pace factors."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.0, 30)
    paths = [
        np.stack([np.sin((2 + k) * t + k), np.cos((1 + k) * t), t * k], axis=1)
        for k in range(n_owners)
    ]
    query = (paths[1] + 0.05 * rng.standard_normal(paths[1].shape)).astype(np.float32)
    sequences, owners = [], []
    for owner, path in enumerate(paths):
        for _ in range(per_owner):
            taken = np.sort(rng.integers(0, len(path), size=int(rng.integers(15, 45))))
            noise = rng.uniform(0.01, 0.5) * rng.standard_normal((len(taken), 3))
            sequences.append((path[taken] + noise).astype(np.float32))
            owners.append(owner)
    lengths = np.array([len(s) for s in sequences])
    factors = 1.0 + rng.uniform(0.0, 0.5, size=len(lengths))
    return query, np.concatenate(sequences), lengths, np.array(owners), factors


@pytest.mark.parametrize("seed", range(3))
def test_the_nearest_per_owner_is_the_plain_minimum_to_the_bit(seed, monkeypatch):
    from concurrent.futures import ThreadPoolExecutor

    import eigmotion.retrieval.sequences as sequences

    query, frames, lengths, owners, factors = _renderings_of_motions(seed, 6, 40)
    plain = np.full(7, np.inf)  # the last owner has no renderings: inf
    np.minimum.at(plain, owners, sequence_distances(query, frames, lengths) * factors)
    warped = []
    original = sequences._warp_some

    def counted(cost, lengths, which, workers):
        warped.append(len(which))
        return original(cost, lengths, which, workers)

    monkeypatch.setattr(sequences, "_warp_some", counted)
    nearest = nearest_sequence_distances(query, frames, lengths, owners, factors, 7)
    np.testing.assert_array_equal(nearest, plain)
    assert sum(warped) < len(lengths)  # the bounds ruled some renderings out
    with ThreadPoolExecutor(max_workers=1) as workers:
        threaded = nearest_sequence_distances(
            query, frames, lengths, owners, factors, 7, workers=workers
        )
    np.testing.assert_array_equal(threaded, plain)
    assert np.all(np.isinf(nearest_sequence_distances(query, frames[:0], [], [], [], 3)))


def test_widened_frames_equal_numpy_s_conversion_to_the_bit():
    """Every finite float16, written into float32 rows at any offset of a larger array."""
    halves = np.arange(65536, dtype=np.uint16).view(np.float16)
    finite = halves[np.isfinite(halves)][:63_000].reshape(-1, 63)  # (1000, 63)
    out = np.full((1003, 63), np.nan, np.float32)
    for at in (0, 1, 3):
        widen_frames(finite, out[at : at + len(finite)])
        assert out[at : at + len(finite)].tobytes() == finite.astype(np.float32).tobytes()
    widen_frames(finite[:0], out[:0])  # nothing to convert
