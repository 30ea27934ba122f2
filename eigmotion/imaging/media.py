"""Reading and writing clips: video files, image folders and GIFs.

Every clip in eigmotion is an array of RGB frames, ``(F, H, W, 3) uint8``, plus a frame
rate in frames per second.  Videos are decoded and encoded by the FFmpeg build bundled
with OpenCV (``cv2.VideoCapture`` / ``cv2.VideoWriter``), GIFs by Pillow, the images
of a folder as :mod:`eigmotion.imaging.still_images` reads them.

What can be written here:

* ``.mp4`` / ``.mov`` — H.264 (``avc1``) when the FFmpeg build can encode it, else
  MPEG-4 part 2 (``mp4v``); the pip wheels of ``opencv-python-headless`` ship without an
  H.264 encoder, so ``mp4v`` is what they write.  Both are lossy.
* ``.avi`` — Motion-JPEG (``MJPG``), lossy, every frame independent.
* For these three, an odd width or height is padded by repeating the last column or
  row (the encoders need even sizes and would otherwise drop it).
* ``.gif`` — Pillow, an adaptive 256-colour palette per frame, looping forever.  The
  GIF encoder merges identical consecutive frames into one longer frame (the timing is
  kept, the frame count is not), and GIF delays are whole centiseconds, so the frame
  rate read back is ``100 / round(100 / fps)``.
"""

from __future__ import annotations

import math
import os
import queue
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from functools import lru_cache
from numbers import Real
from pathlib import Path

import cv2
import numpy as np

from eigmotion.errors import EigmotionError, InvalidParameterError, VideoError
from eigmotion.imaging.still_images import (
    IMAGE_EXTENSIONS,
    decoder_reason,
    image_files,
    opened_image,
    pil_rgb,
    read_image_rgb,
)
from eigmotion.limits import (
    MAX_CLIP_FRAMES,
    check_clip_size,
    check_frame_pixels,
)
from eigmotion.validation import Interval

#: Extensions read and written through OpenCV's FFmpeg backend.
VIDEO_EXTENSIONS = (".mp4", ".avi", ".mov", ".mkv")
#: Extensions :func:`write_video` accepts.
WRITABLE_EXTENSIONS = (".mp4", ".mov", ".avi", ".gif")
#: Frame rate reported for an image folder, and for a file that stores none, frames/s.
DEFAULT_FPS = 30.0
#: The frame rates a caller may give a clip of masks or sample it to, frames/s
#: (a constraint of :mod:`eigmotion.validation`).
FRAME_RATE_FPS = Interval(Real, 1e-3, 1e4)


def read_frames(
    path: str | os.PathLike,
    fps: float | None = None,
    max_frames: int | None = None,
    transform: Callable[[np.ndarray], np.ndarray] | None = None,
) -> tuple[np.ndarray, float]:
    """Read a whole clip into memory.

    Parameters
    ----------
    path : str or PathLike
        A video file (``.mp4``, ``.avi``, ``.mov``, ``.mkv``), an animated ``.gif``, or a
        folder of still images (``.png``, ``.jpg``, …) taken in name order, with digit
        runs compared as numbers (``f2.png`` before ``f10.png``).
    fps : float, optional
        Frame rate to report, frames/s.  For an image folder it defaults to
        :data:`DEFAULT_FPS`; for a file it overrides the rate stored in the file.
    max_frames : int, optional
        Stop after this many frames.
    transform : callable, optional
        Applied to each frame ``(H, W, 3) uint8`` as soon as it is decoded (e.g. a
        shrink), so that only its result is held.

    Returns
    -------
    frames : (F, H, W, 3) uint8
        RGB frames, ``F >= 1``.
    fps : float
        Frames per second.

    Raises
    ------
    VideoError
        The path is missing, of an unknown kind, unreadable, holds no frames, or holds
        frames of different sizes.
    InvalidParameterError
        ``fps`` or ``max_frames`` is not positive; a frame larger than
        :data:`~eigmotion.limits.MAX_FRAME_PIXELS`, or a clip beyond
        :data:`~eigmotion.limits.MAX_CLIP_FRAMES` or
        :data:`~eigmotion.limits.MAX_CLIP_BYTES` (checked as it is decoded).
    """
    path = Path(path)
    _checked_fps(fps)
    if max_frames is not None and int(max_frames) < 1:
        raise InvalidParameterError(f"max_frames must be >= 1, got {max_frames!r}")
    if not path.exists():
        raise VideoError(f"{path}: no such file or folder")
    held = _HeldFrames(path, transform)
    if path.is_dir():
        frames, stored_fps = _read_folder(path, max_frames, held)
    elif path.suffix.lower() == ".gif":
        frames, stored_fps = _read_gif(path, max_frames, held)
    elif path.suffix.lower() in VIDEO_EXTENSIONS:
        frames, stored_fps = _read_video(path, max_frames, held)
    else:
        raise VideoError(
            f"{path}: unknown clip type {path.suffix!r}; expected a folder of images or "
            f"one of {', '.join(VIDEO_EXTENSIONS + ('.gif',))}"
        )
    return frames, float(fps if fps is not None else stored_fps)


@dataclass(frozen=True)
class FrameSample:
    """The frames of a clip taken at a lower rate (or all of them).

    Attributes
    ----------
    frames : (F', H, W, 3) uint8
        RGB frames, ``F' >= 1``.
    frame_indices : (F',) int64
        Index in the clip of each frame, increasing.
    n_frames : int
        Frames in the whole clip.
    clip_fps : float
        The clip's frame rate, frames/s.
    fps : float
        The rate the frames are spaced at: ``clip_fps`` when every frame was taken,
        else the sample rate asked for (each frame is the clip's frame nearest to
        ``k / fps``).
    """

    frames: np.ndarray
    frame_indices: np.ndarray
    n_frames: int
    clip_fps: float
    fps: float


def read_frame_sample(
    path: str | os.PathLike, sample_fps: float | None = None, fps: float | None = None
) -> FrameSample:
    """Read the frames of a clip nearest to a lower frame rate.

    A video is still decoded frame by frame (its frames depend on each other), but
    only the frames kept are converted and stored: reading a 30 frames/s clip at 15
    costs about half as much.

    Parameters
    ----------
    path : str or PathLike
        As for :func:`read_frames`.
    sample_fps : float, optional
        Frames per second wanted; every frame when ``None`` or not below the clip's
        rate.  The frames kept are :func:`sample_indices`.
    fps : float, optional
        The clip's frame rate, overriding the stored one (as for :func:`read_frames`).

    Returns
    -------
    FrameSample
    """
    stream = FrameSampleStream(path, sample_fps, fps)
    frames = np.concatenate(list(stream.chunks(_WHOLE_CLIP)))
    return FrameSample(frames, stream.frame_indices, stream.n_frames, stream.clip_fps, stream.fps)


#: Chunk size that hands over a clip in one piece.
_WHOLE_CLIP = 1 << 30


class FrameSampleStream:
    """The frames :func:`read_frame_sample` takes, handed over in chunks as they come.

    A video is decoded by a background thread that starts at once, so the caller can
    work on one chunk while the next is being decoded (the decoder and OpenCV's
    colour conversion release the GIL).  FFmpeg decodes with one thread: on the small
    frames of a query its frame threading costs more time than it saves (a 3 s,
    320×240 clip: about 10 ms on one thread, 17 ms on two).  However the reading of
    :meth:`chunks` ends — the last frame, an error, or the caller closing it early —
    the decoding thread is stopped and joined before control returns.  A GIF or a video
    with ``fps`` given is read whole first; of a folder of images, the sample's.

    Parameters
    ----------
    path, sample_fps, fps
        As for :func:`read_frame_sample`.
    progress : bool
        A bar on stderr of the video's frames decoded, shown once the reading has
        taken more than a second (a long clip).
    transform : callable, optional
        Applied to each RGB frame (H, W, 3) uint8 taken, once, in order, as it is
        handed over, and to no other frame (it may keep what it sees): a clip shrunk
        this way is never held whole at its full size.  A folder's sample is known from
        its file count, so only those images are read.

    Attributes
    ----------
    frame_indices : (F',) int64
        Index in the clip of each frame handed over; set once :meth:`chunks` is
        exhausted, as are ``n_frames``, ``clip_fps`` and ``fps`` (see
        :class:`FrameSample`).
    """

    def __init__(
        self,
        path: str | os.PathLike,
        sample_fps: float | None = None,
        fps: float | None = None,
        progress: bool = False,
        transform: Callable[[np.ndarray], np.ndarray] | None = None,
    ):
        self.path = Path(path)
        self._progress = progress
        self._transform = transform
        self._expected_frames = 0  # the container's frame count, set by the decoder
        if sample_fps is not None and not (math.isfinite(sample_fps) and sample_fps > 0):
            raise InvalidParameterError(f"sample_fps must be > 0 frames/s, got {sample_fps!r}")
        self._sample_fps = sample_fps
        self.frame_indices: np.ndarray | None = None
        self.n_frames = 0
        self.clip_fps = self.fps = float("nan")
        self._decoded: queue.SimpleQueue | None = None
        self._decoder: threading.Thread | None = None
        self._stop = threading.Event()
        self._frames: np.ndarray | None = None
        video = self.path.is_file() and self.path.suffix.lower() in VIDEO_EXTENSIONS
        if video and fps is None:
            self._decoded = queue.SimpleQueue()
            self._decoder = threading.Thread(
                target=self._decode, name="eigmotion-decode", daemon=True
            )
            self._decoder.start()
        elif self.path.is_dir():  # only the images of the sample are read
            clip_fps = float(_checked_fps(fps) or DEFAULT_FPS)

            def sample(n_files: int) -> np.ndarray:
                self._finish(n_files, clip_fps)
                return self.frame_indices

            held = _HeldFrames(self.path, transform)
            self._frames, _ = _read_folder(self.path, None, held, sample)
            self._transform = None  # applied as the images were read
        else:  # read whole, the sample transformed as it is handed over
            frames, clip_fps = read_frames(self.path, fps)
            self._finish(len(frames), clip_fps)
            self._frames = frames[self.frame_indices]

    def chunks(self, size: int) -> Iterator[np.ndarray]:
        """The frames, ``size`` at a time (the last chunk may be shorter).

        Yields
        ------
        (k, H, W, 3) uint8
            RGB frames, ``1 <= k <= size``, in clip order.

        Raises
        ------
        VideoError
            The video cannot be opened or holds no frame; a frame of another size.
        """
        if self._decoded is None:
            for start in range(0, len(self._frames), size):
                chunk = self._frames[start : start + size]
                if self._transform is not None:
                    chunk = np.stack([self._transform(frame) for frame in chunk])
                yield chunk
            return
        # Hold back one frame: whether the last frame decoded belongs to the sample is
        # known only once the clip's length is (see _decode).
        held: list[tuple[int, np.ndarray]] = []
        bar = None
        started = time.monotonic()
        try:
            while (item := self._decoded.get()) is not _END_OF_CLIP:
                if isinstance(item, VideoError | InvalidParameterError):
                    raise item
                if self._progress and bar is None:
                    if time.monotonic() - started >= FRAME_BAR_DELAY_S:
                        bar = _frame_bar(self._expected_frames)
                if bar is not None:
                    bar.update(item[0] + 1 - bar.n)
                held.append(item)  # transformed when handed over: the last may be dropped
                if len(held) > size:
                    yield self._stacked(held[:size])
                    del held[:size]
        finally:
            # However the reading ends (an error, or the caller giving up early), the
            # decoder is stopped and waited for: a process that exits while FFmpeg is
            # still inside a decoding thread can abort instead of exiting cleanly.
            self.close()
            if bar is not None:
                bar.close()
        if not held:
            raise VideoError(f"{self.path}: no frame could be decoded (empty or corrupt video)")
        wanted = set(self.frame_indices.tolist())
        held = [(index, frame) for index, frame in held if index in wanted]
        if held:
            yield self._stacked(held)

    def close(self) -> None:
        """Stop the decoding thread and wait for it (for a stream given up before its
        :meth:`chunks` are read; reading them to their end, or an error, closes it)."""
        if self._decoder is not None:
            self._stop.set()
            self._decoder.join()

    def _stacked(self, frames: list[tuple[int, np.ndarray]]) -> np.ndarray:
        """The frames handed over, each through the transform (once)."""
        images = [frame for _, frame in frames]
        if self._transform is not None:
            images = [self._transform(image) for image in images]
        return _stack(images, self.path)

    def _finish(self, n_frames: int, clip_fps: float) -> None:
        rate = clip_fps if self._sample_fps is None else self._sample_fps
        self.frame_indices = sample_indices(n_frames, clip_fps, rate)
        self.n_frames, self.clip_fps, self.fps = n_frames, clip_fps, min(rate, clip_fps)

    def _decode(self) -> None:
        """Decode the video, converting to RGB and queueing only the frames the sample
        may take: the frame nearest to each sample time ``k / sample_fps``, as in
        :func:`sample_indices`.  Those are the sample, but for possibly one frame after
        its last, which :meth:`chunks` drops."""
        sample_fps = self._sample_fps
        capture = cv2.VideoCapture(str(self.path), cv2.CAP_FFMPEG, [cv2.CAP_PROP_N_THREADS, 1])
        n_frames = 0
        try:
            if not capture.isOpened():
                self._decoded.put(
                    VideoError(f"{self.path}: cannot be opened as a video (corrupt or unsupported)")
                )
                return
            clip_fps = capture.get(cv2.CAP_PROP_FPS)
            if not (np.isfinite(clip_fps) and clip_fps > 0):
                clip_fps = DEFAULT_FPS
            count = capture.get(cv2.CAP_PROP_FRAME_COUNT)  # a container's guess, or <= 0
            self._expected_frames = int(count) if np.isfinite(count) and count > 0 else 0
            _check_video_frame_size(capture, self.path)
            every = sample_fps is None or clip_fps <= sample_fps
            sample = 0
            while not self._stop.is_set() and capture.grab():
                if every or n_frames == int(np.rint(sample / sample_fps * clip_fps)):
                    if sample >= MAX_CLIP_FRAMES:
                        check_clip_size(sample + 1, 0, str(self.path))
                    ok, bgr = capture.retrieve()
                    if not ok:
                        break
                    self._decoded.put((n_frames, cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)))
                    sample += 1
                n_frames += 1
            self._finish(n_frames, float(clip_fps))
        except InvalidParameterError as exc:  # a limit: handed over as it is
            self._decoded.put(exc)
        except Exception as exc:  # noqa: BLE001 - handed to the reading thread, named
            self._decoded.put(VideoError(f"{self.path}: decoding failed ({exc})"))
        finally:
            capture.release()
            self._decoded.put(_END_OF_CLIP)


#: What the decoding thread of a :class:`FrameSampleStream` queues after the last frame.
_END_OF_CLIP = object()


#: Seconds a video is read before its progress bar shows.
FRAME_BAR_DELAY_S = 1.0


def progress_bar(total: int | None, desc: str, initial: int = 0):
    """A progress bar on stderr over ``total`` frames (None: unknown), cleared when done.

    tqdm is imported here: callers make the bar only once a job has taken a second
    (:data:`FRAME_BAR_DELAY_S`), so a short one never loads it."""
    from tqdm import tqdm

    return tqdm(total=total, initial=initial, desc=desc, unit="frame", file=sys.stderr, leave=False)


def _frame_bar(expected_frames: int):
    """A progress bar on stderr over a video's frames (made once the reading has taken
    :data:`FRAME_BAR_DELAY_S`: most clips are read before, and never load tqdm)."""
    return progress_bar(expected_frames or None, "reading frames")


def sample_indices(n_frames: int, clip_fps: float, sample_fps: float) -> np.ndarray:
    """Frame indices that sample a clip at ``sample_fps``.

    Parameters
    ----------
    n_frames : int
        Frames in the clip.
    clip_fps, sample_fps : float
        The clip's rate and the rate wanted, frames per second.

    Returns
    -------
    (F',) int64
        Increasing indices of the frames nearest to the times ``k / sample_fps``,
        ``k = 0, 1, …`` up to the clip's duration ``(n_frames - 1) / clip_fps``; every
        frame when ``clip_fps <= sample_fps``.
    """
    if clip_fps <= sample_fps:
        return np.arange(n_frames)
    duration_s = (n_frames - 1) / clip_fps
    # The small epsilon keeps a sample that falls exactly on the last frame.
    times_s = np.arange(int(math.floor(duration_s * sample_fps + 1e-9)) + 1) / sample_fps
    return np.minimum(np.rint(times_s * clip_fps).astype(np.int64), n_frames - 1)


def _stack(frames: list[np.ndarray], path: Path, names: list[str] | None = None) -> np.ndarray:
    if not frames:
        raise VideoError(f"{path}: holds no frames")
    first = frames[0].shape
    for i, frame in enumerate(frames):
        if frame.shape != first:
            what = names[i] if names is not None else f"frame {i}"
            raise VideoError(
                f"{path}: {what} is {frame.shape[1]}×{frame.shape[0]} pixels, but the "
                f"first frame is {first[1]}×{first[0]}; all frames must have one size"
            )
    return np.stack(frames)


class _HeldFrames:
    """The frames of a clip as they are decoded: each transformed (if asked) and
    checked against the pixel, frame-count and memory limits before it is kept."""

    def __init__(self, path: Path, transform: Callable[[np.ndarray], np.ndarray] | None):
        self.path = path
        self.transform = transform
        self.frames: list[np.ndarray] = []
        self.names: list[str] = []

    def add(self, frame: np.ndarray, name: str | None = None) -> None:
        if self.transform is not None:
            frame = self.transform(frame)
        check_clip_size(len(self.frames) + 1, frame.nbytes, str(self.path))
        self.frames.append(frame)
        if name is not None:
            self.names.append(name)

    def stacked(self) -> np.ndarray:
        return _stack(self.frames, self.path, self.names or None)


def _check_video_frame_size(capture, path: Path) -> None:
    """InvalidParameterError when the video's frames, as its header states them, hold
    more than :data:`~eigmotion.limits.MAX_FRAME_PIXELS`."""
    width = capture.get(cv2.CAP_PROP_FRAME_WIDTH)
    height = capture.get(cv2.CAP_PROP_FRAME_HEIGHT)
    if np.isfinite(width) and np.isfinite(height) and width > 0 and height > 0:
        check_frame_pixels(int(width), int(height), str(path))


def _read_video(path: Path, max_frames: int | None, held: _HeldFrames) -> tuple[np.ndarray, float]:
    capture = cv2.VideoCapture(str(path))
    try:
        if not capture.isOpened():
            raise VideoError(f"{path}: cannot be opened as a video (corrupt or unsupported)")
        _check_video_frame_size(capture, path)
        stored_fps = capture.get(cv2.CAP_PROP_FPS)
        while max_frames is None or len(held.frames) < max_frames:
            ok, bgr = capture.read()
            if not ok:
                break
            held.add(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB))
    finally:
        capture.release()
    if not held.frames:
        raise VideoError(f"{path}: no frame could be decoded (empty or corrupt video)")
    if not (np.isfinite(stored_fps) and stored_fps > 0):
        stored_fps = DEFAULT_FPS
    return held.stacked(), float(stored_fps)


def _read_gif(path: Path, max_frames: int | None, held: _HeldFrames) -> tuple[np.ndarray, float]:
    from PIL import ImageSequence

    durations_ms = []
    try:
        with opened_image(path) as image:
            for frame in ImageSequence.Iterator(image):
                held.add(pil_rgb(frame, path))
                durations_ms.append(float(frame.info.get("duration", 0) or 0))
                if max_frames is not None and len(held.frames) >= max_frames:
                    break
    except EigmotionError:
        raise
    except Exception as exc:  # noqa: BLE001 - Pillow raises many kinds on a damaged file
        raise VideoError(f"{path}: not a readable GIF ({decoder_reason(exc)})") from None
    positive = [d for d in durations_ms if d > 0]
    fps = 1000.0 / float(np.mean(positive)) if positive else DEFAULT_FPS
    return held.stacked(), fps


def _checked_fps(fps: float | None) -> float | None:
    """``fps`` itself; InvalidParameterError unless it is None or a rate > 0."""
    if fps is not None and not (np.isfinite(fps) and fps > 0):
        raise InvalidParameterError(f"fps must be > 0 frames/s, got {fps!r}")
    return fps


def _read_folder(
    folder: Path,
    max_frames: int | None,
    held: _HeldFrames,
    sample: Callable[[int], np.ndarray] | None = None,
) -> tuple[np.ndarray, float]:
    """The folder's images in name order (``sample(n_files)``: the indices of those to
    read, increasing; every one without it)."""
    files = image_files(folder)
    if not files:
        raise VideoError(
            f"{folder}: holds no frames (no files ending in {', '.join(IMAGE_EXTENSIONS)})"
        )
    if max_frames is not None:
        files = files[:max_frames]
    if sample is not None:
        files = [files[i] for i in sample(len(files))]
    for file in files:
        held.add(read_image_rgb(file), file.name)
    return held.stacked(), DEFAULT_FPS


def as_rgb_frames(frames: np.ndarray) -> np.ndarray:
    """Frames of any supported kind as RGB, for writing or display.

    Parameters
    ----------
    frames : (F, H, W, 3) uint8, (F, H, W) uint8 or (F, H, W) bool
        RGB frames, grey frames, or masks (``True`` becomes white).

    Returns
    -------
    (F, H, W, 3) uint8

    Raises
    ------
    InvalidParameterError
        Another shape or dtype, or no frame at all.
    """
    frames = np.asarray(frames)
    if frames.dtype == np.bool_:
        frames = frames.astype(np.uint8) * np.uint8(255)
    if frames.dtype != np.uint8:
        raise InvalidParameterError(
            f"frames must be uint8 (RGB or grey) or bool (masks), got dtype {frames.dtype}"
        )
    if frames.ndim == 3:
        frames = np.repeat(frames[..., None], 3, axis=-1)
    if frames.ndim != 4 or frames.shape[-1] != 3:
        raise InvalidParameterError(
            f"frames must have shape (F, H, W, 3) or (F, H, W), got {frames.shape}"
        )
    if frames.shape[0] == 0 or frames.shape[1] == 0 or frames.shape[2] == 0:
        raise InvalidParameterError(
            f"frames must hold at least one non-empty frame, got {frames.shape}"
        )
    return frames


def write_video(frames: np.ndarray, path: str | os.PathLike, fps: float = DEFAULT_FPS) -> Path:
    """Write frames as a video file or an animated GIF.

    Parameters
    ----------
    frames : (F, H, W, 3) uint8, (F, H, W) uint8 or (F, H, W) bool
        RGB frames, grey frames or masks (``True`` written white).
    path : str or PathLike
        Output file; its extension picks the format (see the module docstring):
        ``.mp4``, ``.mov``, ``.avi`` or ``.gif``.  Missing parent folders are created.
        Video files get odd sizes padded to even ones (last row/column repeated).
    fps : float
        Frames per second.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    InvalidParameterError
        Bad frames or ``fps``.
    VideoError
        Unknown extension, or the encoder could not be opened.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in WRITABLE_EXTENSIONS:
        raise VideoError(
            f"{path}: cannot write {suffix or 'a file without extension'!r}; expected one "
            f"of {', '.join(WRITABLE_EXTENSIONS)}"
        )
    if not (np.isfinite(fps) and fps > 0):
        raise InvalidParameterError(f"fps must be > 0 frames/s, got {fps!r}")
    frames = as_rgb_frames(frames)
    path.parent.mkdir(parents=True, exist_ok=True)
    if suffix == ".gif":
        _write_gif(frames, path, fps)
    else:
        fourcc = "MJPG" if suffix == ".avi" else mp4_fourcc()
        _write_cv2(frames, path, fps, fourcc)
    return path


def _write_cv2(frames: np.ndarray, path: Path, fps: float, fourcc: str) -> None:
    # The FFmpeg encoders drop an odd last row or column; pad instead, so nothing is lost.
    pad_rows, pad_cols = frames.shape[1] % 2, frames.shape[2] % 2
    if pad_rows or pad_cols:
        frames = np.pad(frames, ((0, 0), (0, pad_rows), (0, pad_cols), (0, 0)), mode="edge")
    height, width = frames.shape[1:3]
    writer = cv2.VideoWriter(
        str(path), cv2.VideoWriter_fourcc(*fourcc), float(fps), (width, height)
    )
    try:
        if not writer.isOpened():
            raise VideoError(
                f"{path}: the {fourcc!r} encoder could not be opened for {width}×{height} "
                f"frames at {fps} frames/s"
            )
        for frame in frames:
            writer.write(np.ascontiguousarray(frame[..., ::-1]))
    finally:
        writer.release()


def _write_gif(frames: np.ndarray, path: Path, fps: float) -> None:
    from PIL import Image

    duration_ms = max(10, int(round(100.0 / fps)) * 10)  # GIF delays are centiseconds
    images = [Image.fromarray(frame) for frame in frames]
    images[0].save(
        path,
        save_all=True,
        append_images=images[1:],
        duration=duration_ms,
        loop=0,
        optimize=False,
    )


@lru_cache(maxsize=1)
def mp4_fourcc() -> str:
    """The FourCC :func:`write_video` uses for ``.mp4``/``.mov``: ``avc1`` or ``mp4v``.

    H.264 (``avc1``) plays everywhere, but OpenCV's pip wheels cannot encode it; the
    answer is found once per process by opening a tiny writer.  FFmpeg reports the
    failed attempt on the process's stderr, which is silenced for that moment only.

    Returns
    -------
    str
    """
    with tempfile.TemporaryDirectory() as tmp, _quiet_stderr():
        probe = Path(tmp) / "probe.mp4"
        writer = cv2.VideoWriter(str(probe), cv2.VideoWriter_fourcc(*"avc1"), 30.0, (16, 16))
        ok = writer.isOpened()
        if ok:
            writer.write(np.zeros((16, 16, 3), np.uint8))
        writer.release()
    return "avc1" if ok else "mp4v"


class _quiet_stderr:
    """Redirect file descriptor 2 to /dev/null (native libraries write there directly)."""

    def __enter__(self):
        self._saved = None
        try:
            self._saved = os.dup(2)
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, 2)
            os.close(devnull)
        except OSError:  # no fd 2 to redirect: nothing to silence
            self._saved = None
        return self

    def __exit__(self, *exc):
        if self._saved is not None:
            os.dup2(self._saved, 2)
            os.close(self._saved)
        return False
