"""The library's views, the imaging half of a build: library × rig → silhouettes → motion images.

For every basic motion and every virtual camera of a rig, the motion drives the
avatar (low-poly copy, see :meth:`eigmotion.body.avatar.Avatar.decimated`), the rig is
re-aimed at the motion (:meth:`eigmotion.imaging.cameras.CameraRig.fitted`), the CPU
rasteriser renders one silhouette per frame, and :class:`eigmotion.retrieval.motion_image.
ClipMotionImages` turns the whole motion and each sliding window of it into one unit
vector (each as :func:`~eigmotion.retrieval.motion_image.motion_image` of its masks).  The
windows let part of a motion (a clip that starts mid-walk) still match.
Each image carries a label (:func:`window_labels`): the motion's own, except for a
sliding window that shows mostly what comes before or after the motion's action
(``LibraryMotion.action``), labelled with the motion's ``filler`` (the walking around
a walking turn) or, when it has none, left out (the standing before a jump).

The work is split over processes by (motion, view), or sent to a Dask distributed
cluster by (motion, body) (:func:`render_views` with ``scheduler``); the vectors then go to
:mod:`eigmotion.retrieval.build`, which fits the eigenspace and writes the store.
"""

from __future__ import annotations

import concurrent.futures
import os
import threading
import time
from collections.abc import Iterator, Sequence
from dataclasses import asdict, dataclass, field, fields
from functools import lru_cache
from numbers import Real
from typing import ClassVar

import numpy as np

from eigmotion.body.avatar import check_body_shape, load_default_avatar
from eigmotion.body.garments import dress, garment
from eigmotion.errors import ClusterError, InvalidParameterError, VideoError
from eigmotion.imaging.cameras import CameraRig
from eigmotion.imaging.silhouettes import render_masks
from eigmotion.limits import check_rendered_frames
from eigmotion.mocap.library import LibraryMotion
from eigmotion.retrieval.eigenspace import Eigenspace
from eigmotion.retrieval.motion_image import ClipMotionImages, MotionImageConfig
from eigmotion.retrieval.sequences import SEQUENCE_SIZE, sequence_frames
from eigmotion.validation import Interval, validate_params

#: Body shapes of the default build: (height in metres or None for the avatar's own,
#: girth factor).  Several shapes stand in for several people: the avatar's own build
#: first, then a slimmer and a stouter one (docs/database.md).
DEFAULT_BODY_SHAPES: tuple[tuple[float | None, float], ...] = (
    (None, 1.0),
    (None, 0.85),
    (None, 1.25),
)
#: Outfits of the default build: tuples of garment names (see
#: :mod:`eigmotion.body.garments`); ``()`` is the plain body.  Database garments only: the
#: benchmark's (:data:`eigmotion.body.garments.BENCHMARK_GARMENTS`) stay unseen.
DEFAULT_GARMENTS: tuple[tuple[str, ...], ...] = (
    (),
    ("short_skirt",),
    ("jacket", "wide_shorts"),
    ("cropped_trousers",),
)
#: A sliding window shows a motion's action (:attr:`LibraryMotion.action
#: <eigmotion.mocap.library.LibraryMotion.action>`) when the action fills at least this share
#: of the window, or of the action when that is shorter than a window: a window is
#: labelled by what takes most of it, and with the default windows (a step of a third
#: of a window) every action keeps a window of its own (the last window to start
#: before the action holds two thirds of a window of it, or all of it).
ACTION_SHARE = 0.5


@dataclass(frozen=True)
class BuildConfig:
    """How a database is built; stored with it so queries preprocess identically.

    Parameters
    ----------
    motion_image : MotionImageConfig
        Step 3 of the method, shared by build and query.
    render_fps : float
        Frames per second the motions are resampled to before rendering, > 0.
    window_s : float
        Length of the sliding windows, seconds (> 0).  A motion shorter than this
        gives only its whole-motion entry.
    window_step_s : float
        Stride between window starts, seconds (> 0).
    n_components : int or None
        Eigen-dimensions k; ``None`` picks k by ``explained_variance``.
    explained_variance : float
        Fraction of variance kept when ``n_components`` is ``None``, in (0, 1].
    key_axes : int
        K, the eigen-axes in a B-tree key.
    key_sections : int
        R, sections per axis.
    key_method : {"quantile", "equal"}
        Section boundaries (see :mod:`eigmotion.retrieval.keys`).
    low_poly_faces : int
        Triangles of the avatar copy used for silhouettes.
    body_shapes : tuple of (float or None, float)
        Body (height_m, girth) variations rendered for every motion and view.
    garments : tuple of tuple of str
        Outfits, each a tuple of garment names from
        :data:`eigmotion.body.garments.GARMENTS` (``()``: none); every body shape is
        rendered in every outfit (:attr:`bodies`).  Databases stored before garments
        existed read back with the default, the plain body.
    """

    motion_image: MotionImageConfig = field(default_factory=MotionImageConfig)
    render_fps: float = 30.0
    window_s: float = 1.5
    window_step_s: float = 0.5
    n_components: int | None = 40
    explained_variance: float = 0.95
    key_axes: int = 10
    key_sections: int = 4
    key_method: str = "quantile"
    low_poly_faces: int = 4000
    body_shapes: tuple[tuple[float | None, float], ...] = DEFAULT_BODY_SHAPES
    garments: tuple[tuple[str, ...], ...] = DEFAULT_GARMENTS

    #: The valid values of the scalar parameters (see :mod:`eigmotion.validation`);
    #: the eigenspace's are its own (:class:`~eigmotion.retrieval.eigenspace.Eigenspace`).
    #: The key's (``key_*``) are checked when the keys are made
    #: (:class:`~eigmotion.retrieval.keys.Quantizer`), the body shapes by
    #: :func:`~eigmotion.body.avatar.check_body_shape` and the garments by name.
    _parameter_constraints: ClassVar[dict] = {
        "render_fps": Interval(Real, 0.0, None, closed="neither", noun=""),
        "window_s": Interval(Real, 0.0, None, closed="neither", noun=""),
        "window_step_s": Interval(Real, 0.0, None, closed="neither", noun=""),
        "n_components": Eigenspace._parameter_constraints["n_components"],
        "explained_variance": Eigenspace._parameter_constraints["explained_variance"],
    }

    def __post_init__(self):
        validate_params(self, self._parameter_constraints)
        if not self.body_shapes:
            raise InvalidParameterError("body_shapes must hold at least one (height_m, girth)")
        shapes = tuple((None if h is None else float(h), float(g)) for h, g in self.body_shapes)
        for height, girth in shapes:
            check_body_shape(height, girth)
        object.__setattr__(self, "body_shapes", shapes)
        object.__setattr__(self, "garments", _outfits(self.garments))

    @property
    def bodies(self) -> tuple[tuple[tuple[float | None, float], tuple[str, ...]], ...]:
        """Every (body shape, outfit) rendered, shape by shape."""
        return tuple((shape, outfit) for shape in self.body_shapes for outfit in self.garments)

    def alike_bodies(self) -> np.ndarray:
        """(B, B) bool over :attr:`bodies`: which count as the same person's when the
        "unknown" threshold is calibrated (:func:`~eigmotion.retrieval.calibration.
        leave_one_motion_out_distances`): a body itself, the bodies in its outfit where
        there are several outfits, and the bodies of its shape where there are several
        shapes.  A new performance is then compared with bodies unlike its own in both
        build and clothes, as a query's person is."""
        n_outfits = len(self.garments)
        index = np.arange(len(self.bodies))
        shape, outfit = index // n_outfits, index % n_outfits
        alike = np.eye(len(index), dtype=bool)
        if len(self.body_shapes) > 1:
            alike |= shape[:, None] == shape[None, :]
        if n_outfits > 1:
            alike |= outfit[:, None] == outfit[None, :]
        return alike

    def to_dict(self) -> dict:
        """Plain values only, for the store."""
        out = asdict(self)
        out["motion_image"] = self.motion_image.to_dict()
        out["body_shapes"] = [[-1.0 if h is None else h, g] for h, g in self.body_shapes]
        out["garments"] = [list(outfit) for outfit in self.garments]
        if self.n_components is None:
            out["n_components"] = 0
        return out

    @classmethod
    def from_dict(cls, data: dict) -> BuildConfig:
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise InvalidParameterError(f"build config: unknown key(s) {unknown}")
        data = dict(data)
        if "motion_image" in data:
            data["motion_image"] = MotionImageConfig.from_dict(dict(data["motion_image"]))
        if "body_shapes" in data:
            data["body_shapes"] = tuple((None if h < 0 else h, g) for h, g in data["body_shapes"])
        data.setdefault("garments", ((),))  # stored before garments existed: the plain body
        if data.get("n_components") == 0:
            data["n_components"] = None
        return cls(**data)


@dataclass(frozen=True)
class ViewImages:
    """The motion images of one (motion, body shape, view).

    Attributes
    ----------
    motion_index : int
        Position of the motion in the list given to :func:`render_views`.
    view_index : int
        Camera index in the rig.
    shape_index : int
        Index into ``BuildConfig.bodies`` (body shape and outfit).
    windows : (W, 2) int64
        ``[start, stop)`` frames of each image in the motion's own frames; the first
        row is the whole motion.
    vectors : (W, D) float32
        Unit motion-image vectors, one per window.
    labels : tuple of W str
        Each image's label (:func:`window_labels`); the whole motion's is the motion's.
    sequence : (F, SEQUENCE_SIZE**2 + 1) float32
        The whole motion's aligned silhouettes and the rise of the body
        (:func:`~eigmotion.retrieval.sequences.sequence_frames`).
    """

    motion_index: int
    view_index: int
    shape_index: int
    windows: np.ndarray
    vectors: np.ndarray
    labels: tuple[str, ...]
    sequence: np.ndarray


def window_bounds(n_frames: int, fps: float, window_s: float, step_s: float) -> np.ndarray:
    """``[start, stop)`` frame windows: the whole clip, then sliding windows.

    Parameters
    ----------
    n_frames : int
    fps : float
        Frame rate of the frames counted, frames per second.
    window_s, step_s : float
        Window length and stride, seconds.

    Returns
    -------
    (W, 2) int64
        First row ``[0, n_frames)``; then windows of ``round(window_s * fps)`` frames
        every ``round(step_s * fps)`` frames, the last one ending at the clip's end.
        Clips no longer than 1.25 windows give the whole-clip row only.
    """
    length = max(2, int(round(window_s * fps)))
    step = max(1, int(round(step_s * fps)))
    rows = [(0, n_frames)]
    if n_frames > 1.25 * length:
        starts = list(range(0, n_frames - length + 1, step))
        if starts[-1] + length < n_frames:
            starts.append(n_frames - length)
        rows += [(s, s + length) for s in starts]
    return np.asarray(rows, dtype=np.int64)


def window_labels(item: LibraryMotion, windows_s: np.ndarray) -> list[str | None]:
    """The label of each window of a library motion, by how much of its action it shows.

    Parameters
    ----------
    item : LibraryMotion
    windows_s : (W, 2) float
        ``[start, stop)`` of each window, seconds of ``item.motion``.

    Returns
    -------
    list of (str or None)
        ``item.label`` for a window that shows the action — every window when
        ``item.action`` is ``None``; otherwise the action must fill
        :data:`ACTION_SHARE` of the window, or of the action when that is shorter (so
        the whole motion always shows it).  Any other window gets ``item.filler``, or
        ``None`` — left out of the database — when the motion has no filler.
    """
    windows_s = np.asarray(windows_s, dtype=np.float64).reshape(-1, 2)
    if item.action is None:
        return [item.label] * len(windows_s)
    start, stop = item.action
    overlap = np.minimum(windows_s[:, 1], stop) - np.maximum(windows_s[:, 0], start)
    needed = ACTION_SHARE * np.minimum(windows_s[:, 1] - windows_s[:, 0], stop - start)
    return [
        item.label if o >= n - 1e-9 else item.filler for o, n in zip(overlap, needed, strict=True)
    ]


def _outfits(garments) -> tuple[tuple[str, ...], ...]:
    """``BuildConfig.garments`` as a tuple of tuples of known garment names."""
    if isinstance(garments, str) or not garments:
        raise InvalidParameterError(
            f"garments must hold at least one outfit (a tuple of garment names, () for "
            f"none), got {garments!r}"
        )
    outfits = []
    for outfit in garments:
        if isinstance(outfit, str):
            raise InvalidParameterError(
                f"each outfit in garments is a tuple of garment names, got {outfit!r}; "
                f"write ({outfit!r},)"
            )
        names = tuple(garment(name).name for name in outfit)
        if len(set(names)) < len(names):
            raise InvalidParameterError(f"outfit {names} names a garment twice")
        outfits.append(names)
    return tuple(outfits)


@lru_cache(maxsize=32)
def _body(shape: tuple[float | None, float], garments: tuple[str, ...], low_poly_faces: int):
    avatar = load_default_avatar()
    height, girth = shape
    if height is not None or girth != 1.0:
        avatar = avatar.with_shape(height_m=height, girth=girth)
    return dress(avatar, garments).decimated(low_poly_faces)


def pose_for_views(motion, body, rig: CameraRig, render_fps: float):
    """A motion on a body, and the rig aimed at it: what every view of it is rendered from.

    Parameters
    ----------
    motion : Motion
    body : Avatar
    rig : CameraRig
    render_fps : float
        Frames per second the motion is resampled to.

    Returns
    -------
    vertices : (F, V, 3) float32
        The skinned body per frame, metres.
    fitted : CameraRig
        The rig re-aimed so that the whole motion stays in every camera's frame.
    """
    return _pose_resampled(_resampled(motion, render_fps), body, rig)


def _resampled(motion, render_fps: float):
    """``motion`` at ``render_fps``, its size checked against :mod:`eigmotion.limits` first."""
    end_s = (motion.n_frames - 1) * motion.frame_time_s
    name = f"motion {motion.name!r}" if motion.name else "the motion"
    check_rendered_frames(int(min(end_s * render_fps, 2**62)) + 1, f"{name} at {render_fps:g} fps")
    return motion.resample(render_fps)


def _pose_resampled(motion, body, rig: CameraRig):
    """:func:`pose_for_views` of a motion resampled already."""
    # Lazy: retargeting loads scipy.spatial (~0.14 s), which a query never needs.
    from eigmotion.body.retarget import animate_avatar

    _, vertices = animate_avatar(body, motion)
    return vertices, rig.fitted(hull_points(vertices))


def build_body(
    shape: tuple[float | None, float], low_poly_faces: int, garments: tuple[str, ...] = ()
):
    """The (cached) low-poly avatar of one body shape ``(height_m or None, girth)``,
    wearing ``garments`` (names from :data:`eigmotion.body.garments.GARMENTS`)."""
    return _body(shape, tuple(garments), low_poly_faces)


@lru_cache(maxsize=2)
def _posed(motion_index: int, shape_index: int):
    """:func:`pose_for_views` cached per worker process (the views of one motion share it)."""
    rig, config = _WORKER_STATE["rig"], _WORKER_STATE["config"]
    shape, garments = config.bodies[shape_index]
    body = _body(shape, garments, config.low_poly_faces)
    vertices, fitted = _pose_resampled(_worker_resampled(motion_index), body, rig)
    return vertices, body.faces, fitted


@lru_cache(maxsize=2)
def _worker_resampled(motion_index: int):
    """A library motion at the build's rendering rate, cached per worker process (its
    bodies share it)."""
    library, config = _WORKER_STATE["library"], _WORKER_STATE["config"]
    return _resampled(library[motion_index].motion, config.render_fps)


def hull_points(vertices: np.ndarray) -> np.ndarray:
    """The corners of the convex hull of every vertex over a clip.

    A camera sees all of a body's frames exactly when it sees these (the image of a
    convex hull is the convex hull of the image), so fitting a camera to them is as
    exact as fitting it to every vertex, and much cheaper.

    Parameters
    ----------
    vertices : (F, V, 3) float

    Returns
    -------
    (H, 3) float64
    """
    from scipy.spatial import ConvexHull, QhullError

    points = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    try:
        return points[ConvexHull(points).vertices]
    except QhullError:  # flat or degenerate: keep them all
        return points


_WORKER_STATE: dict = {}


def _exit_with_parent() -> None:
    """End this worker process when the process that started it dies (even by
    SIGKILL, which gives the pool no chance to stop its workers)."""
    parent = os.getppid()

    def watch():
        while True:
            time.sleep(0.5)
            if os.getppid() != parent:
                os._exit(1)

    threading.Thread(target=watch, daemon=True, name="exit-with-parent").start()


def _init_worker(library: Sequence[LibraryMotion], rig: CameraRig, config: BuildConfig):
    _exit_with_parent()
    # Each process renders with one core; BLAS threads would only fight each other.
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    _WORKER_STATE.update(library=library, rig=rig, config=config)
    _posed.cache_clear()
    _worker_resampled.cache_clear()


def _render_task(task: tuple[int, int, int]) -> ViewImages:
    motion_index, shape_index, view_index = task
    library, config = _WORKER_STATE["library"], _WORKER_STATE["config"]
    vertices, faces, fitted = _posed(motion_index, shape_index)
    masks = render_masks(vertices, faces, fitted[view_index])
    indices = (motion_index, view_index, shape_index)
    return view_images(library[motion_index], masks, config, indices)


def view_images(
    item: LibraryMotion,
    masks: np.ndarray,
    config: BuildConfig,
    indices: tuple[int, int, int] = (0, 0, 0),
) -> ViewImages:
    """The motion images of one rendered view of a library motion.

    Parameters
    ----------
    item : LibraryMotion
    masks : (F, H, W) bool
        The silhouettes of ``item.motion`` resampled to ``config.render_fps``.
    config : BuildConfig
    indices : (int, int, int)
        ``(motion_index, view_index, shape_index)`` to file the images under.

    Returns
    -------
    ViewImages
        The whole motion and every sliding window that shows something (a window
        labelled ``None`` by :func:`window_labels`, or where nothing moves, is left
        out), windows in ``item.motion``'s own frames; and the whole motion's
        silhouette sequence.
    """
    windows = window_bounds(len(masks), config.render_fps, config.window_s, config.window_step_s)
    images = ClipMotionImages(masks, config.motion_image, clip_fps=config.render_fps)
    vectors, kept, labels = [], [], []
    for (start, stop), label in zip(
        windows, window_labels(item, windows / config.render_fps), strict=True
    ):
        if label is None:
            continue  # standing before or after the action: not the action
        try:
            vectors.append(images.window(start, stop))
            kept.append((start, stop))
            labels.append(label)
        except VideoError:
            continue  # a window where nothing moves (a held pose) carries no motion image
    motion = item.motion
    to_source = motion.fps / config.render_fps
    source_windows = np.round(np.asarray(kept, dtype=np.float64) * to_source).astype(np.int64)
    source_windows = np.minimum(source_windows, motion.n_frames)
    dims = config.motion_image.n_dims
    return ViewImages(
        *indices,
        source_windows.reshape(-1, 2),
        np.asarray(vectors, dtype=np.float32).reshape(-1, dims),
        tuple(labels),
        _whole_sequence(images),
    )


def _whole_sequence(images: ClipMotionImages) -> np.ndarray:
    """(F, SEQUENCE_SIZE**2 + 1) float32: the rendering's silhouette sequence, no frames when
    the person is missing from too many of them."""
    try:
        return sequence_frames(images)
    except VideoError:
        return np.zeros((0, SEQUENCE_SIZE**2 + 1), dtype=np.float32)


def render_views(
    library: Sequence[LibraryMotion],
    rig: CameraRig,
    config: BuildConfig,
    workers: int | None = None,
    progress: bool = True,
    scheduler: str | None = None,
) -> Iterator[ViewImages]:
    """Motion images of every (motion, body shape, view), computed in parallel.

    Parameters
    ----------
    library : sequence of LibraryMotion
    rig : CameraRig
        Virtual cameras (with azimuth and elevation).
    config : BuildConfig
    workers : int, optional
        Processes; default the number of CPU cores.  ``1`` runs in this process.
        Ignored with ``scheduler``.
    progress : bool
        A progress bar on stderr.
    scheduler : str, optional
        The address of a Dask distributed scheduler (``tcp://host:8786``): the views are
        rendered by its workers (:func:`connect_cluster`), which need only eigmotion
        installed; the images are the same, bit for bit, as a local rendering's.

    Yields
    ------
    ViewImages
        In (motion, shape, view) order.

    Raises
    ------
    ClusterError
        When ``scheduler`` is given and cannot be reached, has no worker, or Dask is not
        installed; raised before anything is rendered.
    """
    tasks = [
        (m, s, v)
        for m in range(len(library))
        for s in range(len(config.bodies))
        for v in range(len(rig))
    ]
    from tqdm import tqdm  # here: a query, which renders nothing, never loads it

    client = None if scheduler is None else connect_cluster(scheduler)
    bar = tqdm(total=len(tasks), desc="rendering views", unit="view", disable=not progress)
    workers = workers or os.cpu_count() or 1
    try:
        if client is not None:
            yield from _render_on_cluster(client, library, rig, config, bar)
        elif workers == 1:
            _init_worker(library, rig, config)
            for task in tasks:
                yield _render_task(task)
                bar.update()
        else:
            # The process pool's module (and multiprocessing) loads here, on first
            # use: a query, which renders nothing, does not import it.
            with concurrent.futures.ProcessPoolExecutor(
                workers, initializer=_init_worker, initargs=(library, rig, config)
            ) as pool:
                for result in pool.map(_render_task, tasks, chunksize=len(rig)):
                    yield result
                    bar.update()
    except BaseException:
        bar.leave = False  # the error's one line follows: no half-drawn bar above it
        raise
    finally:
        bar.close()
        if client is not None:
            client.close()


#: Seconds to wait for a Dask scheduler to answer, and then for its first worker.
CLUSTER_TIMEOUT_S = 10.0


def connect_cluster(address: str, timeout_s: float = CLUSTER_TIMEOUT_S):
    """A client of the Dask distributed scheduler at ``address``, once a worker has joined.

    Parameters
    ----------
    address : str
        ``tcp://host:port`` (or ``host:port``) of a running ``dask scheduler``.
    timeout_s : float
        Seconds to wait for the scheduler, then as long again for a worker.

    Returns
    -------
    distributed.Client

    Raises
    ------
    ClusterError
        Dask is not installed (the ``cluster`` extra), the scheduler does not answer, or
        no worker joins it in time.
    """
    try:
        from distributed import Client
    except ImportError as error:
        raise ClusterError(
            "building on a Dask cluster needs dask.distributed: pip install 'eigmotion[cluster]'"
        ) from error
    try:
        client = Client(address, timeout=timeout_s, set_as_default=False)
    except (OSError, TimeoutError, ValueError, TypeError) as error:
        reason = str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__
        raise ClusterError(f"cannot reach the Dask scheduler at {address!r}: {reason}") from error
    try:
        client.wait_for_workers(1, timeout=timeout_s)
    except (OSError, TimeoutError) as error:
        client.close()
        raise ClusterError(
            f"the Dask scheduler at {address!r} has no worker (none joined in {timeout_s:g} s)"
        ) from error
    return client


def _render_on_cluster(
    client, library: Sequence[LibraryMotion], rig: CameraRig, config: BuildConfig, bar
) -> Iterator[ViewImages]:
    """Every view rendered by the cluster's workers, one task per (motion, body), yielded
    in (motion, shape, view) order as the tasks finish.  The library, rig and
    configuration go to every worker once (scattered), not with each task."""
    from distributed import as_completed

    [shipped] = client.scatter([(library, rig, config)], broadcast=True, hash=False)
    groups = [(m, s) for m in range(len(library)) for s in range(len(config.bodies))]
    futures = {client.submit(_render_group, shipped, m, s, pure=False): (m, s) for m, s in groups}
    finished: dict[tuple[int, int], list[ViewImages]] = {}
    next_group = 0
    for future in as_completed(futures, loop=client.loop):
        finished[futures[future]] = future.result()
        future.release()
        bar.update(len(rig))
        while next_group < len(groups) and groups[next_group] in finished:
            yield from finished.pop(groups[next_group])
            next_group += 1


def _render_group(shipped: tuple, motion_index: int, shape_index: int) -> list[ViewImages]:
    """On a cluster worker: every view of one motion on one body.  ``shipped`` is the
    scattered ``(library, rig, config)``, the same object for every task of a build."""
    if _WORKER_STATE.get("shipped") is not shipped:
        library, rig, config = shipped
        _WORKER_STATE.update(library=library, rig=rig, config=config, shipped=shipped)
        _posed.cache_clear()
        _worker_resampled.cache_clear()
    n_views = len(_WORKER_STATE["rig"])
    return [_render_task((motion_index, shape_index, v)) for v in range(n_views)]
