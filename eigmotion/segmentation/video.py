"""The video front end: person silhouettes cut out of ordinary RGB video.

:func:`extract_silhouettes` turns frames into masks for :func:`~eigmotion.retrieval.motion_image.
motion_image`; :func:`load_clip_masks` does the same from a file (a video, a folder of
frames, or masks already made and stored as ``.npz``).

The frames are segmented against an image of the empty scene
(:mod:`eigmotion.segmentation.subtraction`, which describes each step), given or
estimated from the clip (:mod:`eigmotion.segmentation.background`); the parameters are
a :class:`~eigmotion.segmentation.config.SilhouetteConfig`.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from eigmotion.errors import InvalidParameterError, SceneMismatchError, VideoError
from eigmotion.imaging.arrays import read_npz, scalar
from eigmotion.imaging.media import (
    FRAME_RATE_FPS,
    VIDEO_EXTENSIONS,
    FrameSampleStream,
    sample_indices,
)
from eigmotion.imaging.still_images import read_image_rgb
from eigmotion.limits import check_clip_size
from eigmotion.segmentation.background import estimate_background
from eigmotion.segmentation.camera_motion import camera_motion
from eigmotion.segmentation.config import SilhouetteConfig
from eigmotion.segmentation.cut_bodies import hidden_rows_below, restored_legs
from eigmotion.segmentation.evidence import check_frames, shrink, start_colour_tables
from eigmotion.segmentation.fused import fuse_masks, without_seen_scene
from eigmotion.segmentation.learned import (
    count_people,
    enlarged,
    enlargement,
    learned_masks_and_landmarks,
    people_in_view,
    resolve_segmenter,
    stored_frame,
    working_size,
)
from eigmotion.segmentation.shots import shot_spans, shot_starts
from eigmotion.segmentation.subtraction import (
    CHUNK_FRAMES,
    frame_chunks,
    segment_chunks,
    subtract_scene,
)
from eigmotion.segmentation.workers import opencv_in_calling_threads
from eigmotion.validation import validate

#: Frame rate assumed for an ``.npz`` of masks that stores none, frames per second.
DEFAULT_NPZ_FPS = 30.0


def extract_silhouettes(
    frames: np.ndarray,
    background: np.ndarray | None = None,
    config: SilhouetteConfig = SilhouetteConfig(),  # noqa: B008 - frozen, immutable
) -> np.ndarray:
    """Cut the person out of every frame.

    Parameters
    ----------
    frames : (F, H, W, 3) uint8
        RGB video frames.
    background : (H, W, 3) uint8, optional
        The empty scene, RGB, same size as the frames.  Estimated from the clip when
        not given (see ``config.background``).
    config : SilhouetteConfig

    Returns
    -------
    (F, H', W') bool
        The person in each frame; all False where none was found in that frame.
        ``H', W'`` are ``H, W`` shrunk so that the longer side is at most
        ``config.work_max_side_px`` (the same aspect ratio).

    Raises
    ------
    InvalidParameterError
        ``frames`` or ``background`` of the wrong type or number of dimensions.
    VideoError
        Zero frames; a background of another size than the frames (both sizes named);
        no person in any frame.
    """
    frames = check_frames(frames)
    if background is None:
        # Beside a body that stays in place, an estimated background holds what the
        # body hid, inpainted: darker-than-scene pixels there are estimation residue
        # more often than clothing, so the shadow test stands everywhere.
        config = replace(config, upper_body_frac=0.0)
        frames = shrink(frames, config)
        with opencv_in_calling_threads():  # the estimate's steps run on the workers too
            try:
                masks = segment_chunks(
                    frame_chunks(frames), estimate_background(frames, config), config
                )
                if config.background == "median":
                    refined = estimate_background(frames, config, exclude=masks)
                    masks = segment_chunks(frame_chunks(frames), refined, config)
            except SceneMismatchError as error:
                raise SceneMismatchError(
                    "the frames show no one steady scene to estimate the empty scene from "
                    f"(median colour difference {error.difference:.0f} ΔE): a moving camera, "
                    "or a person who fills most of the frame; the learned segmenter (the "
                    "default without an image of the empty scene) needs none",
                    error.difference,
                ) from None
    else:
        background = _check_background(background)
        masks = segment_chunks(_same_size(frame_chunks(frames), background), background, config)
    return _person_found(masks, config, estimated=background is None)


def _check_background(background) -> np.ndarray:
    background = np.asarray(background)
    if background.dtype != np.uint8 or background.ndim != 3 or background.shape[2] != 3:
        raise InvalidParameterError(
            f"background must be (H, W, 3) uint8 RGB, got {background.dtype} {background.shape}"
        )
    return background


def _same_size(chunks: Iterable[np.ndarray], background: np.ndarray) -> Iterator[np.ndarray]:
    """The chunks, each checked to be frames of the background's size."""
    for chunk in chunks:
        chunk = check_frames(chunk)
        _check_size(chunk.shape[1:3], background)
        yield chunk


def _check_size(frame_size: tuple[int, int], background: np.ndarray) -> None:
    """VideoError unless ``frame_size`` (H, W) is the background's."""
    h, w = background.shape[:2]
    if tuple(frame_size) != (h, w):
        raise VideoError(
            f"background is {w}×{h} pixels but the frames are "
            f"{frame_size[1]}×{frame_size[0]}; expected the same size"
        )


def _person_found(
    masks: np.ndarray, config: SilhouetteConfig, estimated: bool = False
) -> np.ndarray:
    """``masks``, unless no frame shows a person (VideoError; with ``estimated``, the
    background was estimated from the clip, and the error says what that needs)."""
    if not masks.any():
        why = (
            " (no image of the empty scene was given, so it was estimated from the clip: "
            "a person shows only by moving; give an image of the empty scene)"
            if estimated
            else ""
        )
        raise VideoError(
            f"no person found in {len(masks)} frame(s): nothing that differs from the "
            f"background covers {config.min_person_frac:.2%} of the image{why}"
        )
    return masks


@dataclass(frozen=True)
class ClipMasks:
    """The person's silhouettes in a clip on disk.

    Attributes
    ----------
    masks : (F', H, W) bool
        One per frame taken.
    frame_indices : (F',) int64
        Index in the clip of each mask's frame, increasing.
    n_frames : int
        Frames in the whole clip.
    fps : float
        The rate the masks are spaced at, frames/s: the clip's rate when every frame
        was taken, else the sample rate asked for.
    clip_fps : float
        The clip's frame rate, frames/s.
    people : int
        People in view (:func:`~eigmotion.segmentation.learned.people_in_view`): with the
        learned segmenter the blobs of the network's masks, else those of the masks.
    segmenter : str
        The front end that cut them: ``"learned"``, ``"subtraction"``, ``"fused"``, or
        ``"masks"`` for an ``.npz`` of masks.
    hidden_below_px : int
        Rows of the person's body below the frame's bottom edge, at the masks' scale
        (feet out of the picture; :func:`~eigmotion.segmentation.cut_bodies.
        hidden_rows_below`); 0 when the body ends in the frame or nothing tells.
    landmarks : (F', 33, 4) float32 or None
        With the learned and fused front ends, the pose network's body landmarks per
        mask (:func:`~eigmotion.segmentation.learned.learned_masks_and_landmarks`): x and
        y in pixels of the clip's frames (continuous: 0 is the left or top edge of the
        first pixel), visibility, presence; NaN where the network saw no person.  None
        with the other front ends.
    world_landmarks : (F', 33, 3) float32 or None
        The same landmarks in 3D (the network's world landmarks: metres, centred
        between the hips, the camera's axes: x right, y down, z away from it); NaN and
        None where ``landmarks`` are.
    frame_size : (int, int) or None
        (H, W) of the clip's frames, the pixels ``landmarks`` are given in; None where
        ``landmarks`` are.
    shot_starts : (S,) int64 or None
        The first mask of each shot of an edited clip (:func:`~eigmotion.segmentation.
        shots.shot_starts`), 0 first; ``[0]`` for a clip of one shot.  None where the
        front end did not look (stored masks; the subtraction of an image of the
        empty scene, which fails on a clip of several scenes).
    camera : (F', 2, 3) float64 or None
        How the camera moved (:func:`~eigmotion.segmentation.camera_motion.
        camera_motion`): per mask, the similarity taking its pixels to the first
        mask's of its shot.  None where it stood still, and where the front end did
        not look (stored masks; a clip with an image of the empty scene, which needs a
        still camera).
    """

    masks: np.ndarray
    frame_indices: np.ndarray
    n_frames: int
    fps: float
    clip_fps: float
    people: int = 1
    segmenter: str = "subtraction"
    hidden_below_px: int = 0
    landmarks: np.ndarray | None = None
    world_landmarks: np.ndarray | None = None
    frame_size: tuple[int, int] | None = None
    shot_starts: np.ndarray | None = None
    camera: np.ndarray | None = None


def load_clip_masks(
    path: str | Path,
    background_path: str | Path | None = None,
    config: SilhouetteConfig = SilhouetteConfig(),  # noqa: B008 - frozen, immutable
    sample_fps: float | None = None,
    progress: bool = False,
    segmenter: str = "subtraction",
) -> ClipMasks:
    """Silhouettes of the person in a clip on disk.

    Parameters
    ----------
    path : str or Path
        A video (``.mp4``, ``.avi``, ``.mov``, ``.mkv``), a GIF or a folder of frame
        images (read by :func:`eigmotion.imaging.media.read_frames`), or an ``.npz`` with key
        ``masks`` ``(F, H, W)`` (bool, or numbers: > 0 is the person) and optionally
        ``fps`` (a scalar, frames per second; :data:`DEFAULT_NPZ_FPS` if absent).
    background_path : str or Path, optional
        An image of the empty scene, same size as the frames (video input only).
    config : SilhouetteConfig
    sample_fps : float, optional
        Take only the frames nearest to this rate (frames/s; see
        :func:`eigmotion.imaging.media.sample_indices`): the motion image samples the clip at
        its own rate anyway, and frames it skips need no silhouette.  Every frame when
        ``None``.
    progress : bool
        Bars on stderr over a long video's frames as they are read
        (:class:`eigmotion.imaging.media.FrameSampleStream`) and as the person networks
        look at them (:func:`~eigmotion.segmentation.learned.learned_masks_and_landmarks`).

    Returns
    -------
    ClipMasks

    Raises
    ------
    VideoError
        Missing or unreadable file, zero frames, no person, background of another size.
    InvalidParameterError
        An ``.npz`` without ``masks`` or with masks of the wrong shape; a background
        given with an ``.npz`` of masks; a bad ``sample_fps``; an unknown segmenter,
        the learned one with a background, or the fused one without.
    """
    path = Path(path)
    segmenter = resolve_segmenter(segmenter, background_path is not None)
    if path.suffix.lower() == ".npz":
        if background_path is not None:
            raise InvalidParameterError(
                f"{path}: background_path applies to video input, not to stored masks"
            )
        if sample_fps is not None:
            validate("sample_fps", sample_fps, FRAME_RATE_FPS)
        masks, clip_fps = _load_npz_masks(path)
        rate = clip_fps if sample_fps is None else sample_fps
        n_frames = len(masks)
        indices = sample_indices(n_frames, clip_fps, rate)
        masks = masks[indices]
        people = people_in_view(count_people(masks, config))
        return ClipMasks(masks, indices, n_frames, min(rate, clip_fps), clip_fps, people, "masks")
    if segmenter == "learned":
        return _learned_clip_masks(path, config, sample_fps, progress)
    if segmenter == "fused":
        return _learned_clip_masks(path, config, sample_fps, progress, background_path)
    start_colour_tables()  # while the video opens

    def to_working_size(frame: np.ndarray) -> np.ndarray:
        """Each frame shrunk as soon as it is decoded (as the segmentation would shrink
        it): a long clip in high definition is held at the working size only."""
        if background is not None:
            _check_size(frame.shape[:2], background)
        return shrink(frame[None], config)[0]

    background = None
    streamed = path.is_file() and path.suffix.lower() in VIDEO_EXTENSIONS
    if background_path is not None and not streamed:  # frames shrunk as they are read
        background = read_background(background_path)
    stream = FrameSampleStream(path, sample_fps, progress=progress, transform=to_working_size)
    try:  # read while the video starts decoding
        if background_path is not None and streamed:
            background = read_background(background_path)
    except BaseException:
        stream.close()
        raise
    starts = camera = None
    if background is None:  # estimated from each shot's frames
        frames = np.concatenate(list(stream.chunks(CHUNK_FRAMES)))
        starts = shot_starts(frames)
        masks = _shot_by_shot(frames, starts, config)
        camera = camera_motion(frames, masks, starts) if config.measure_camera else None
    else:  # segmented as it is decoded
        small = shrink(background[None], config)[0]
        masks = _person_found(segment_chunks(stream.chunks(CHUNK_FRAMES), small, config), config)
    people = people_in_view(count_people(masks, config))
    return ClipMasks(
        masks, stream.frame_indices, stream.n_frames, stream.fps, stream.clip_fps, people,
        shot_starts=starts, camera=camera,
    )  # fmt: skip


def _shot_by_shot(frames: np.ndarray, starts: np.ndarray, config: SilhouetteConfig) -> np.ndarray:
    """:func:`extract_silhouettes` without a background of each shot of ``frames``
    (F, H, W, 3) uint8 whose first frames are ``starts``: (F, H, W) bool.  A shot where
    no person is found, or whose frames show no steady scene, has empty masks; the
    first such error is raised when that is so of every shot."""
    if len(starts) == 1:
        return extract_silhouettes(frames, None, config)
    masks = np.zeros(frames.shape[:3], bool)
    errors = []
    for first, stop in shot_spans(starts, len(frames)):
        try:
            masks[first:stop] = extract_silhouettes(frames[first:stop], None, config)
        except VideoError as error:
            errors.append(error)
    if len(errors) == len(starts):
        raise errors[0]
    return masks


def _learned_clip_masks(
    path: Path,
    config: SilhouetteConfig,
    sample_fps: float | None,
    progress: bool,
    background_path: str | Path | None = None,
) -> ClipMasks:
    """:func:`load_clip_masks` of a video through the learned segmenter: each frame is
    kept at most :data:`~eigmotion.segmentation.learned.STORE_MAX_SIDE_PX` on its longer
    side as soon as it is decoded, and cut out once the clip is read (the network's
    second pass and its outlier rule look at the neighbouring frames).  With
    ``background_path`` (the fused front end) each decoded frame is also shrunk to the
    working size and cut out against the image of the empty scene, and the two are
    fused (:func:`~eigmotion.segmentation.fused.fuse_masks`): the clip is decoded once.
    The shrunk frames are kept: the cuts between shots are found on them
    (:func:`~eigmotion.segmentation.shots.shot_starts`), and without an image, with
    ``config.drop_seen_scene``, what shows the scene the clip itself shows is taken out
    of the learned masks (:func:`~eigmotion.segmentation.fused.without_seen_scene`) and
    the camera's motion is measured (:func:`~eigmotion.segmentation.camera_motion.
    camera_motion`).  Frames smaller than ``config.work_min_side_px`` are enlarged
    first (:func:`~eigmotion.segmentation.learned.enlargement`), the background image
    with them, and the masks are at the enlarged size; the landmarks are in the clip's
    frames' pixels."""
    sizes = []
    factors = []
    working: list[np.ndarray] = []
    background = None
    if background_path is not None or config.drop_seen_scene:
        start_colour_tables()  # while the video opens
    if background_path is not None:
        background = read_background(background_path)

    def keep_frame(frame: np.ndarray) -> np.ndarray:
        if not sizes:
            sizes.append(frame.shape[:2])
            factors.append(enlargement(*frame.shape[:2], config))
        if background is not None:
            _check_size(frame.shape[:2], background)
        frame = enlarged(frame, factors[0])
        working.append(shrink(frame[None], config)[0])
        return stored_frame(frame)

    stream = FrameSampleStream(path, sample_fps, progress=progress, transform=keep_frame)
    inputs = np.concatenate(list(stream.chunks(CHUNK_FRAMES)))
    small_frames = np.stack(working)  # (F, H', W', 3): the frames at the working size
    working.clear()
    starts = shot_starts(small_frames)
    masks, people, landmarks, world = learned_masks_and_landmarks(
        inputs, working_size(*sizes[0], config), config, shot_starts=starts, progress=progress
    )
    landmark_scale = masks.shape[1] / inputs.shape[1]
    masks = restored_legs(masks, landmarks, landmark_scale)
    hidden_below = hidden_rows_below(masks, landmarks, landmark_scale)
    if not masks.any():
        raise VideoError(
            f"no person found in {len(masks)} frame(s): the person segmenter found no one "
            f"covering {config.min_person_frac:.2%} of the image"
        )
    segmenter = "learned"
    camera = None
    if background is None and config.drop_seen_scene:
        masks = without_seen_scene(masks, small_frames, config, starts)
    if background is None and config.measure_camera:
        camera = camera_motion(small_frames, masks, starts)
    if background is not None:
        small = shrink(enlarged(background, factors[0])[None], config)[0]
        # The subtraction may find no one (clothes the colour of the scene, a dim room):
        # the learned masks then stand as they are.
        subtracted = subtract_scene(frame_chunks(small_frames), small, config)
        masks = fuse_masks(masks, subtracted.masks, config, subtracted.plain_scene)
        segmenter = "fused"
    return ClipMasks(
        masks, stream.frame_indices, stream.n_frames, stream.fps, stream.clip_fps,
        people_in_view(people), segmenter, hidden_below, _in_frame_pixels(landmarks, sizes[0],
        inputs.shape[1:3]), world, (int(sizes[0][0]), int(sizes[0][1])), starts, camera,
    )  # fmt: skip


def _in_frame_pixels(landmarks: np.ndarray, frame_size, stored_size) -> np.ndarray:
    """(F, 33, 4) landmarks with x, y taken from the stored frames' pixels to the
    clip's frames' (both continuous, 0 at the first pixel's edge)."""
    scaled = landmarks.copy()
    scaled[..., 0] *= frame_size[1] / stored_size[1]
    scaled[..., 1] *= frame_size[0] / stored_size[0]
    return scaled


def read_background(path: str | Path) -> np.ndarray:
    """An image of the empty scene, (H, W, 3) uint8 RGB, as
    :func:`~eigmotion.imaging.still_images.read_image_rgb` reads it (the same errors),
    and a VideoError naming it as the background image when the file is missing."""
    path = Path(path)
    if not path.is_file():
        raise VideoError(f"{path}: background image not found")
    return read_image_rgb(path)


def _load_npz_masks(path: Path) -> tuple[np.ndarray, float]:
    data = read_npz(path)
    if "masks" not in data:
        raise InvalidParameterError(f"{path}: no array 'masks'; found {sorted(data)}")
    masks = data["masks"]
    fps = scalar(data["fps"], f"{path}: fps") if "fps" in data else DEFAULT_NPZ_FPS
    if masks.ndim != 3:
        raise InvalidParameterError(f"{path}: masks must have shape (F, H, W), got {masks.shape}")
    if masks.shape[0] == 0:
        raise VideoError(f"{path}: the clip has zero frames")
    validate(f"{path}: fps", fps, FRAME_RATE_FPS)
    check_clip_size(masks.shape[0], 0, str(path))
    if masks.dtype != bool:
        real = np.issubdtype(masks.dtype, np.integer) or np.issubdtype(masks.dtype, np.floating)
        if not real or not np.all(np.isfinite(masks)):
            raise InvalidParameterError(f"{path}: masks must be bool or finite numbers")
        masks = masks > 0
    if not masks.any():
        raise VideoError(f"{path}: no person: every mask is empty")
    return masks, fps
