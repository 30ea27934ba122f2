"""The learned front end: person masks from trained networks.

For clips without an image of the empty scene, networks trained to find people cut
the person out of each frame on their own, so the person need not move and the scene
need not be estimated.  Both are MediaPipe's (Apache-2.0), shipped with the package in
``eigmotion/data/segmenter/`` beside their licence, nothing downloaded
(:mod:`eigmotion.segmentation.networks`): the selfie segmentation network (256×256
RGB in, the probability of "person" per pixel out) and the pose landmark network (a
256×256 square centred on one person in; its segmentation, 33 body landmarks and a
flag that a person is there out).

Each frame is looked at twice (a frame smaller than
:attr:`~eigmotion.segmentation.config.SilhouetteConfig.work_min_side_px` enlarged
first: :func:`enlargement`; a dim clip brightened first: :func:`brightened`).  First
the selfie network sees it whole, resized to its input (no cropping); its
probabilities, resized back to the working size of the classical path
(:attr:`~eigmotion.segmentation.config.SilhouetteConfig.work_max_side_px`) and cut at
:data:`PERSON_PROBABILITY`, give a box around the person.  Where it finds no one and
there is no person of the frame before to follow (below), it looks again at
overlapping squares of the frame (:data:`TILE_SHARE`): a small person in a wide,
high-definition frame is a few pixels of the network's input when the frame is seen
whole.  Then a square around that box
(:data:`CROP_MARGIN` times its longer side, at least :data:`CROP_MIN_SIDE_PX` pixels so
the network never sees the frame enlarged more than twice) is cut out and given to the
second look's network (:data:`SECOND_LOOK`): the pose network when LiteRT is installed,
else the selfie network again.  Its probabilities, put back in place, replace the first
ones: a small or distant person fills the network's input instead of a few of its
pixels.  Where the pose network's flag says no person (under
:data:`PERSON_PROBABILITY`), the selfie network looks at the square instead, and where
that finds no one either, the first look's person stands if the network was sure of it
(:data:`SURE_PROBABILITY`; a person bent double, the head below the hips, is lost by
both networks on the square).  The frames
are looked at in order: where the look at the whole frame found no one and the pose
network found the person in the frame before, the square is that person's; where the
person the pose network found in the frame before was
taller than the frame's box (:data:`FOLLOW_TALLER`), the square also holds that person —
the selfie network, made for faces and shoulders, loses the legs of a person in dark
trousers who raises the arms, and a square around the upper body alone would cut the
legs off for the pose network too.  A frame with no box takes the box of its neighbours
(the median of those within :data:`BOX_NEIGHBOURS` frames, else the nearest frame's); a
first pass that finds nothing above :data:`PERSON_PROBABILITY` is searched again at
:data:`SEED_PROBABILITY`.  A square as large as the frame is not cut for the selfie
network (the first pass stands); the pose network always sees a square centred on the
person, black beyond the frame.  Then, as in the classical path, the largest blob and
the big pieces beside it are the person (:func:`person_in_frame`), and a frame whose
person covers more than :data:`OUTLIER_AREA` times its shot's median area is left empty:
the network has taken part of the scene (a rendered floor) for the person there
(the median over the frames whose second look stands, where there are any: a first
look sure of a floor in many frames does not set it).  The
masks go on to the motion image exactly as the classical masks do.
:func:`learned_masks_and_landmarks` also returns the pose network's landmarks, in the
frame's pixels and in 3D.

Every blob beside the largest one and at least :data:`PERSON_SHARE` of its area is
counted as one more person in view (:func:`people_in_view`): a clip with two people
side by side is answered from the largest, and the answer carries a warning.
"""

from __future__ import annotations

import itertools
import math
import time

import cv2
import numpy as np

from eigmotion.errors import InvalidParameterError
from eigmotion.imaging.media import FRAME_BAR_DELAY_S, progress_bar
from eigmotion.segmentation.config import SilhouetteConfig
from eigmotion.segmentation.networks import (
    MODEL_SIDE_PX,
    N_POSE_LANDMARKS,
    SELFIE_PATH,
    pose_network,
    selfie_network,
)
from eigmotion.segmentation.networks import runtime as runtime
from eigmotion.segmentation.shots import shot_spans

#: The front ends a query may cut the person out with: ``auto`` is ``learned`` when no
#: image of the empty scene is given and ``fused`` (the learned masks with what
#: subtracting that image finds beside them: :mod:`eigmotion.segmentation.fused`) when
#: one is.
SEGMENTERS = ("auto", "learned", "subtraction", "fused")

#: The selfie network's file, shipped with the package.
MODEL_PATH = SELFIE_PATH

#: A pixel whose probability of being the person is above this is the person.
PERSON_PROBABILITY = 0.5

#: Where the first pass finds no one above :data:`PERSON_PROBABILITY`, its largest
#: blob above this gives the box for the second pass.
SEED_PROBABILITY = 0.1

#: The second pass's square is this many times the person's box's longer side ...
CROP_MARGIN = 1.5

#: ... and at least this many pixels of the (stored) frame, and a fifth of its longer
#: side: the network's 256-pixel input never enlarges the frame more than twice.
CROP_MIN_SIDE_PX = MODEL_SIDE_PX // 2

#: A frame without a box of its own takes the median box of those this many frames
#: before and after it.
BOX_NEIGHBOURS = 2

#: The networks that may look again at the square around the person.
SECOND_LOOKS = ("pose", "selfie")

#: The one that does when LiteRT is installed (the pose network needs it).
SECOND_LOOK = "pose"

#: Where neither network finds anyone on the square, the first look's person stands
#: when the mean of its probabilities over the person is at least this: real people
#: bent double measured 0.87-0.98, what it took for a person in an empty scene 0.56-0.58.
SURE_PROBABILITY = 0.8

#: A frame whose person covers more than this many times the median person area of its
#: shot is left empty (the network took part of the scene for the person).
OUTLIER_AREA = 3.0

#: A frame's square also holds the person the pose network found in the frame before
#: when that person was more than this many times as tall as the frame's own box (the
#: first look lost part of the person; the module's description).
FOLLOW_TALLER = 1.15

#: Where the first look at the whole frame finds no one (and there is no person of the
#: frame before to follow), it looks again at overlapping squares of this share of the
#: frame's longer side (at least :data:`CROP_MIN_SIDE_PX`), half a square apart: a
#: person a tenth of a high-definition frame's height is a few pixels of the network's
#: input when the frame is seen whole.
TILE_SHARE = 0.5

#: Frames are kept for the network at most this many pixels on their longer side.
STORE_MAX_SIDE_PX = 640

#: A blob counts as a person in view when its area is at least this share of the
#: frame's largest blob (and at least the smallest person's area).
PERSON_SHARE = 0.3

#: The clip shows as many people as at least this share of its frames do.
PEOPLE_FRAME_SHARE = 1.0 / 3.0

#: A clip is dim when the 99th percentile of its pixels' brightness (the mean of R, G
#: and B, 0-255) is under this: the networks then see it brightened (:func:`brightened`).
DIM_LEVEL = 64.0

#: ... by the gain that brings that percentile to this, ...
BRIGHT_LEVEL = 200.0

#: ... at most this gain; the gain multiplies the sensor's noise too, so the brightened
#: frames are smoothed by a bilateral filter (diameter px, colour sigma in grey levels,
#: space sigma px), which keeps the person's edges.
MAX_GAIN = 4.0
DIM_DENOISE = (5, 40.0, 3.0)


def resolve_segmenter(segmenter: str, with_background: bool) -> str:
    """The front end a query uses: ``"learned"``, ``"subtraction"`` or ``"fused"``.

    Parameters
    ----------
    segmenter : {"auto", "learned", "subtraction", "fused"}
    with_background : bool
        Whether an image of the empty scene was given.

    Raises
    ------
    InvalidParameterError
        An unknown name, ``"learned"`` with a background image (the network does not
        use it), or ``"fused"`` without one.
    """
    if segmenter not in SEGMENTERS:
        raise InvalidParameterError(
            f"segmenter must be one of {', '.join(SEGMENTERS)}, got {segmenter!r}"
        )
    if segmenter == "auto":
        return "fused" if with_background else "learned"
    if segmenter == "learned" and with_background:
        raise InvalidParameterError(
            "the learned segmenter does not use an image of the empty scene: give "
            "--background with --segmenter fused, subtraction or auto, or leave it out"
        )
    if segmenter == "fused" and not with_background:
        raise InvalidParameterError(
            "the fused segmenter needs an image of the empty scene: give --background, "
            "or use --segmenter learned or auto"
        )
    return segmenter


def model_input(frame: np.ndarray) -> np.ndarray:
    """One RGB frame (H, W, 3) uint8 resized whole to the network's input,
    (:data:`MODEL_SIDE_PX`, :data:`MODEL_SIDE_PX`, 3) uint8 (area averaging when it
    shrinks, bilinear when it grows)."""
    h, w = frame.shape[:2]
    shrinking = h >= MODEL_SIDE_PX and w >= MODEL_SIDE_PX
    interpolation = cv2.INTER_AREA if shrinking else cv2.INTER_LINEAR
    return cv2.resize(frame, (MODEL_SIDE_PX, MODEL_SIDE_PX), interpolation=interpolation)


def stored_frame(frame: np.ndarray) -> np.ndarray:
    """One RGB frame (H, W, 3) uint8 as it is kept for the network: shrunk by a whole
    factor (area averaging) to at most :data:`STORE_MAX_SIDE_PX` on its longer side."""
    h, w = frame.shape[:2]
    factor = max(1, math.ceil(max(h, w) / STORE_MAX_SIDE_PX))
    if factor == 1:
        return frame
    return cv2.resize(frame, (w // factor, h // factor), interpolation=cv2.INTER_AREA)


def crop_input(frame: np.ndarray, box: tuple[float, float, float]) -> tuple[np.ndarray, np.ndarray]:
    """The square ``box`` of a frame resized to the network's input.

    Parameters
    ----------
    frame : (H, W, 3) uint8
        RGB.
    box : (float, float, float)
        Centre x, centre y and side of the square, pixels of ``frame``; what lies
        outside the frame is black.

    Returns
    -------
    input : (256, 256, 3) uint8
    matrix : (2, 3) float64
        The affine map from ``frame``'s pixel coordinates to the input's.
    """
    cx, cy, side = box
    scale = MODEL_SIDE_PX / side
    matrix = np.array(
        [[scale, 0.0, MODEL_SIDE_PX / 2 - scale * cx], [0.0, scale, MODEL_SIDE_PX / 2 - scale * cy]]
    )
    if scale < 1:  # blurred before it is shrunk
        frame = cv2.GaussianBlur(frame, (0, 0), 0.5 / scale)
    view = cv2.warpAffine(
        frame, matrix, (MODEL_SIDE_PX, MODEL_SIDE_PX), flags=cv2.INTER_LINEAR,
        borderMode=cv2.BORDER_CONSTANT, borderValue=0,
    )  # fmt: skip
    return view, matrix


def crop_probabilities_back(
    probabilities: np.ndarray, matrix: np.ndarray, frame_size: tuple[int, int],
    size: tuple[int, int],
) -> np.ndarray:  # fmt: skip
    """The network's (256, 256) probabilities for :func:`crop_input`'s square put back
    in place on the working size ``size`` (H', W') of a frame of ``frame_size`` (H, W)
    pixels; 0 outside the square.  (H', W') float32."""
    h, w = size
    ay, ax = frame_size[0] / h, frame_size[1] / w
    to_frame = np.array([[ax, 0, 0.5 * ax - 0.5], [0, ay, 0.5 * ay - 0.5], [0, 0, 1.0]])
    return cv2.warpAffine(
        probabilities, matrix @ to_frame, (w, h), flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
        borderMode=cv2.BORDER_CONSTANT, borderValue=0,
    )  # fmt: skip


def working_size(height: int, width: int, config: SilhouetteConfig) -> tuple[int, int]:
    """(H', W') of a frame of ``height`` × ``width`` pixels at the working size: as
    :func:`enlarged` enlarges it (``config.work_min_side_px``), then as
    :func:`~eigmotion.segmentation.evidence.shrink` shrinks it."""
    factor = enlargement(height, width, config)
    height, width = height * factor, width * factor
    factor = max(1, math.ceil(max(height, width) / config.work_max_side_px))
    return height // factor, width // factor


def enlargement(height: int, width: int, config: SilhouetteConfig) -> int:
    """The whole factor a frame of ``height`` × ``width`` pixels is enlarged by before
    the person networks see it: the smallest that brings its longer side to at least
    ``config.work_min_side_px``; 1 for a frame that large already (or a minimum of 0).

    The networks take a :data:`~eigmotion.segmentation.networks.MODEL_SIDE_PX`-pixel
    input: the whole frame, and a square of at least :data:`CROP_MIN_SIDE_PX` pixels of
    it around the person.  A smaller frame they enlarge themselves (bilinear), and in
    a frame smaller than the square (the 64 × 64 real clips) the person fills a part of
    it only, the rest black.  Enlarged first, by a bicubic filter, the frame gives the
    person the square's whole height.
    """
    longer = max(height, width)
    if config.work_min_side_px <= longer:
        return 1
    return math.ceil(config.work_min_side_px / longer)


def enlarged(frame: np.ndarray, factor: int) -> np.ndarray:
    """(H·factor, W·factor, C) uint8: ``frame`` (H, W, C) enlarged by a bicubic filter;
    ``frame`` itself for a factor of 1."""
    if factor == 1:
        return frame
    h, w = frame.shape[:2]
    return cv2.resize(frame, (w * factor, h * factor), interpolation=cv2.INTER_CUBIC)


def person_probabilities(inputs: np.ndarray) -> np.ndarray:
    """The network's probability of "person" per pixel.

    Parameters
    ----------
    inputs : (F, 256, 256, 3) uint8
        Frames made by :func:`model_input`, RGB.

    Returns
    -------
    (F, 256, 256) float32
        In [0, 1].
    """
    inputs = np.asarray(inputs)
    if (
        inputs.dtype != np.uint8
        or inputs.ndim != 4
        or inputs.shape[1:] != (MODEL_SIDE_PX, MODEL_SIDE_PX, 3)
    ):
        raise InvalidParameterError(
            f"network inputs must be (F, {MODEL_SIDE_PX}, {MODEL_SIDE_PX}, 3) uint8, got "
            f"{inputs.dtype} {inputs.shape}"
        )
    _, run = selfie_network()
    out = np.empty(inputs.shape[:3], np.float32)
    for i, frame in enumerate(inputs):
        out[i] = run(frame.astype(np.float32) * np.float32(1.0 / 255.0))
    return out


def learned_masks(
    frames: np.ndarray, size: tuple[int, int], config: SilhouetteConfig
) -> tuple[np.ndarray, np.ndarray]:
    """The person in each frame, and the people in view: :func:`learned_masks_and_landmarks`
    without the landmarks.

    Returns
    -------
    masks : (F, H', W') bool
    people : (F,) int64
    """
    masks, people, _, _ = learned_masks_and_landmarks(frames, size, config)
    return masks, people


def brightened(frames: np.ndarray) -> np.ndarray:
    """A dim clip brightened as a camera's exposure would: every frame multiplied by
    one gain that brings the 99th percentile of the clip's brightness to
    :data:`BRIGHT_LEVEL` (at most :data:`MAX_GAIN`), saturating at 255, then smoothed
    by a bilateral filter (:data:`DIM_DENOISE`); a clip whose percentile is
    :data:`DIM_LEVEL` or more is returned as it is.

    Parameters
    ----------
    frames : (F, H, W, 3) uint8
        RGB.

    Returns
    -------
    (F, H, W, 3) uint8
        ``frames`` itself where the clip is not dim.
    """
    if not len(frames):
        return frames
    sample = frames[:: max(1, len(frames) // 12), ::4, ::4]  # 12-23 frames, 1 pixel in 16
    level = float(np.percentile(sample.mean(axis=-1, dtype=np.float32), 99))
    if level >= DIM_LEVEL:
        return frames
    gain = min(MAX_GAIN, BRIGHT_LEVEL / max(level, 1.0))
    return np.stack([
        cv2.bilateralFilter(cv2.convertScaleAbs(frame, alpha=gain), *DIM_DENOISE)
        for frame in frames
    ])  # fmt: skip


def learned_masks_and_landmarks(
    frames: np.ndarray, size: tuple[int, int], config: SilhouetteConfig,
    second_look: str | None = None, shot_starts: np.ndarray | None = None,
    progress: bool = False,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """The person in each frame, the people in view, and the person's body landmarks
    in the image and in 3D (two passes of the networks: the module's description).

    Parameters
    ----------
    frames : (F, H, W, 3) uint8
        The clip's frames (:func:`stored_frame`), RGB.
    size : (int, int)
        (H', W') of the masks wanted: the frames' working size (:func:`working_size`).
    config : SilhouetteConfig
        Its ``min_person_frac`` and ``keep_piece_frac`` apply.
    second_look : {"pose", "selfie"}, optional
        The network that looks again at the square around the person: ``"pose"`` (the
        default when LiteRT is installed) or ``"selfie"`` (the default without).
    shot_starts : (S,) int, optional
        The first frame of each shot of an edited clip (:func:`~eigmotion.segmentation.
        shots.shot_starts`): the person is not followed across a cut, and the outlier
        rule compares each frame with its own shot's person.  Default one shot.
    progress : bool
        A bar on stderr over the frames once the work has taken
        :data:`~eigmotion.imaging.media.FRAME_BAR_DELAY_S` (a long clip).

    Returns
    -------
    masks : (F, H', W') bool
        All False in a frame where no blob covers ``min_person_frac`` of the image, or
        where the person covers more than :data:`OUTLIER_AREA` times its shot's median.
    people : (F,) int64
        Blobs per frame large enough to be a person (:data:`PERSON_SHARE`): the more
        of the two passes' counts (the square may leave out a person beside).
    landmarks : (F, 33, 4) float32
        Per frame, x and y (pixels of ``frames``, continuous: 0 is the left or top edge
        of the first pixel), visibility and presence (probabilities) of the pose
        network's 33 body landmarks (:data:`~eigmotion.segmentation.networks.N_POSE_LANDMARKS`,
        MediaPipe's order); NaN in a frame the pose network did not see or where it
        found no person (flag under :data:`PERSON_PROBABILITY`), and everywhere when
        the second look is the selfie network's.
    world : (F, 33, 3) float32
        The same frames' world landmarks (:class:`~eigmotion.segmentation.networks.
        PoseOutput`): metres, centred between the hips, the camera's axes (x right, y
        down, z away from it); NaN where ``landmarks`` are.
    """
    pose = pose_network()
    if second_look is None:
        second_look = SECOND_LOOK if pose is not None else "selfie"
    if second_look not in SECOND_LOOKS:
        raise InvalidParameterError(
            f"second_look must be one of {', '.join(SECOND_LOOKS)}, got {second_look!r}"
        )
    if second_look == "pose" and pose is None:
        raise InvalidParameterError(
            "the pose network runs through LiteRT only: pip install ai-edge-litert "
            "(installed with eigmotion where LiteRT has a wheel)"
        )
    started = time.monotonic()
    if config.brighten_dim:
        frames = brightened(frames)
    h, w = size
    frame_size = frames.shape[1:3]
    first = person_probabilities(np.stack([model_input(f) for f in frames]))
    probabilities = np.stack([cv2.resize(p, (w, h), interpolation=cv2.INTER_LINEAR) for p in first])
    # people are counted on the whole frame too: a square may leave out a person beside
    whole_frame_people = [person_in_frame(p > PERSON_PROBABILITY, config)[1] for p in probabilities]
    seen = np.array(whole_frame_people) > 0  # the whole frame shows someone
    boxes = _person_boxes(probabilities, config, frame_size)
    landmarks = np.full((len(frames), N_POSE_LANDMARKS, 4), np.nan, np.float32)
    world = np.full((len(frames), N_POSE_LANDMARKS, 3), np.nan, np.float32)
    longest = max(frame_size)
    masks = np.zeros((len(frames), h, w), bool)
    people = np.zeros(len(frames), np.int64)
    followed = None  # the box of the pose network's person in the frame before
    looked_again = np.zeros(len(frames), bool)  # frames whose second look stands
    cuts = set() if shot_starts is None else {int(i) for i in shot_starts}
    bar = None
    for i, box in enumerate(boxes):
        if progress and bar is None and time.monotonic() - started >= FRAME_BAR_DELAY_S:
            bar = progress_bar(len(frames), "finding the person", initial=i)
        if bar is not None:
            bar.update(1)
        if i in cuts:  # another view: the person of the frame before is not this one
            followed = None
        before, followed, found = followed, None, False
        if not seen[i]:  # the whole frame shows no one
            if before is not None:  # follow the person of the frame before
                box = before
            elif (tiled := _tiles_look(frames[i], size)) is not None:
                np.maximum(probabilities[i], tiled, out=probabilities[i])
                box = _own_box(probabilities[i], config, frame_size) or box
        if box is not None:
            if before is not None and before[3] - before[1] > FOLLOW_TALLER * (box[3] - box[1]):
                box = _union(box, before)  # the first look lost part of the person
            x0, y0, x1, y1 = box
            side = max(CROP_MARGIN * max(x1 - x0, y1 - y0), 0.2 * longest, CROP_MIN_SIDE_PX)
            if side < longest or second_look == "pose":
                view, matrix = crop_input(frames[i], ((x0 + x1) / 2, (y0 + y1) / 2, side))
                out = None if second_look == "selfie" else pose(
                    view.astype(np.float32) * np.float32(1.0 / 255.0))  # fmt: skip
                found = out is not None and out.person >= PERSON_PROBABILITY
                if found:
                    second = out.probabilities
                    landmarks[i], world[i] = out.landmarks, out.world
                    # the square's pixels (continuous) back to the frame's
                    scale, shift = matrix[[0, 1], [0, 1]], matrix[:2, 2]
                    landmarks[i, :, :2] = (out.landmarks[:, :2] - 0.5 - shift) / scale + 0.5
                else:  # the selfie network's second look, or no one the pose network knows
                    second = person_probabilities(view[None])[0]
                second = crop_probabilities_back(second, matrix, frame_size, size)
                if (
                    found
                    or (second > PERSON_PROBABILITY).any()
                    or not _sure(probabilities[i], config)
                ):
                    probabilities[i], looked_again[i] = second, True
                # else the first look's person stands
        masks[i], people[i] = person_in_frame(probabilities[i] > PERSON_PROBABILITY, config)
        people[i] = max(people[i], whole_frame_people[i])
        if found and masks[i].any():
            followed = _mask_box(masks[i], frame_size)
    if bar is not None:
        bar.close()
    for first, stop in shot_spans(shot_starts, len(frames)):
        _drop_outliers(masks[first:stop], people[first:stop], looked_again[first:stop])
    return masks, people, landmarks, world


def _drop_outliers(masks: np.ndarray, people: np.ndarray, looked_again: np.ndarray) -> None:
    """Empty, in place, the masks (F, H, W) bool of a shot whose person covers more than
    :data:`OUTLIER_AREA` times the shot's median person, and zero their ``people``."""
    area = masks.sum(axis=(1, 2))
    if area.any():
        # the typical person is the second look's where it has one (a first look that
        # took the floor for a person in many frames does not set it)
        typical = (
            area[(area > 0) & looked_again] if (area[looked_again] > 0).any() else area[area > 0]
        )
        outliers = area > OUTLIER_AREA * np.median(typical)
        masks[outliers], people[outliers] = False, 0


def _tiles_look(frame: np.ndarray, size: tuple[int, int]) -> np.ndarray | None:
    """The selfie network's looks at overlapping squares of one frame (H, W, 3)
    (:data:`TILE_SHARE`), the most of their probabilities at the working ``size``
    (H', W') float32; None where one square would cover the frame."""
    frame_size = frame.shape[:2]
    side = max(TILE_SHARE * max(frame_size), CROP_MIN_SIDE_PX)
    if side >= max(frame_size):
        return None
    out = np.zeros(size, np.float32)
    for cy, cx in itertools.product(*(_tile_centres(extent, side) for extent in frame_size)):
        view, matrix = crop_input(frame, (cx, cy, side))
        tile = person_probabilities(view[None])[0]
        np.maximum(out, crop_probabilities_back(tile, matrix, frame_size, size), out=out)
    return out


def _tile_centres(extent: int, side: float) -> np.ndarray:
    """Centres, pixels, of squares of ``side`` half a square apart along ``extent``."""
    return np.linspace(side / 2, extent - side / 2, max(1, math.ceil(2 * extent / side - 1)))


def _sure(probabilities: np.ndarray, config: SilhouetteConfig) -> bool:
    """Whether the person in a frame's (H', W') probabilities is one the network is
    sure of: their mean over the person's pixels is at least :data:`SURE_PROBABILITY`."""
    person, _ = person_in_frame(probabilities > PERSON_PROBABILITY, config)
    return bool(person.any()) and float(probabilities[person].mean()) >= SURE_PROBABILITY


def _person_boxes(
    probabilities: np.ndarray, config: SilhouetteConfig, frame_size: tuple[int, int]
) -> list[tuple[float, float, float, float] | None]:
    """The box (x0, y0, x1, y1), pixels of frames of ``frame_size`` (H, W), around the
    person of each frame of the first pass's (F, H', W') probabilities; a frame without
    one takes its neighbours' (the module's description); all None when no frame has
    one."""
    own = np.full((len(probabilities), 4), np.nan)
    for i, p in enumerate(probabilities):
        box = _own_box(p, config, frame_size)
        if box is not None:
            own[i] = box
    found = np.flatnonzero(~np.isnan(own[:, 0]))
    boxes: list[tuple[float, float, float, float] | None] = []
    for i in range(len(own)):
        if len(found) == 0:
            boxes.append(None)
            continue
        if i in found:
            box = own[i]
        else:
            near = found[np.abs(found - i) <= BOX_NEIGHBOURS]
            if len(near) == 0:
                near = found[[np.argmin(np.abs(found - i))]]
            box = np.median(own[near], axis=0)
        boxes.append(tuple(float(v) for v in box))
    return boxes


def _own_box(
    probabilities: np.ndarray, config: SilhouetteConfig, frame_size: tuple[int, int]
) -> tuple[float, float, float, float] | None:
    """The box (x0, y0, x1, y1), pixels of a frame of ``frame_size`` (H, W), around the
    person of one frame's (H', W') first-look probabilities: the person above
    :data:`PERSON_PROBABILITY`, else its largest blob, else the largest blob above
    :data:`SEED_PROBABILITY`; None where there is none."""
    person, _ = person_in_frame(probabilities > PERSON_PROBABILITY, config)
    if not person.any():
        person = _largest_blob(probabilities > PERSON_PROBABILITY)
    if not person.any():
        person = _largest_blob(probabilities > SEED_PROBABILITY)
    if not person.any():
        return None
    return _mask_box(person, frame_size)


def _union(
    box: tuple[float, float, float, float], other: tuple[float, float, float, float]
) -> tuple[float, float, float, float]:
    """The smallest box (x0, y0, x1, y1) holding both."""
    return (min(box[0], other[0]), min(box[1], other[1]), max(box[2], other[2]),
            max(box[3], other[3]))  # fmt: skip


def _mask_box(mask: np.ndarray, frame_size: tuple[int, int]) -> tuple[float, float, float, float]:
    """The box (x0, y0, x1, y1), pixels of frames of ``frame_size`` (H, W), around a
    non-empty (H', W') mask at the working size."""
    h, w = mask.shape
    ay, ax = frame_size[0] / h, frame_size[1] / w
    ys, xs = np.nonzero(mask)
    return xs.min() * ax, ys.min() * ay, (xs.max() + 1) * ax, (ys.max() + 1) * ay


def _largest_blob(mask: np.ndarray) -> np.ndarray:
    """The largest 8-connected blob of a (H, W) bool mask (all False when it has none)."""
    count, labels, stats, _ = cv2.connectedComponentsWithStats(mask.view(np.uint8), 8)
    if count <= 1:
        return np.zeros(mask.shape, bool)
    return labels == 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))


def person_in_frame(mask: np.ndarray, config: SilhouetteConfig) -> tuple[np.ndarray, int]:
    """The person's blobs of one frame's foreground, and how many blobs are people.

    The largest blob, when it covers at least ``config.min_person_frac`` of the image,
    plus pieces of at least ``config.keep_piece_frac`` of its area touching its bounding
    box grown by 25 % sideways and 50 % up and down (the classical path's rule).

    Parameters
    ----------
    mask : (H, W) bool

    Returns
    -------
    person : (H, W) bool
    people : int
        The largest blob, and the blobs beside it (sharing no column with it) of at
        least :data:`PERSON_SHARE` of its area and at least the smallest person's: the
        pieces of one person torn apart by the segmentation lie above one another.
    """
    out = np.zeros(mask.shape, bool)
    # Labelled inside the foreground's box (the same blobs, in the same order).
    x, y, w, h = cv2.boundingRect(mask.view(np.uint8))
    if not w:
        return out, 0
    count, labels, stats, _ = cv2.connectedComponentsWithStats(
        mask[y : y + h, x : x + w].view(np.uint8), 8
    )
    if count <= 1:
        return out, 0
    area = stats[1:, cv2.CC_STAT_AREA]
    largest = int(np.argmax(area))
    min_area = config.min_person_frac * mask.size
    if area[largest] < min_area:
        return out, 0
    x0, y0 = stats[1:, cv2.CC_STAT_LEFT], stats[1:, cv2.CC_STAT_TOP]
    x1, y1 = x0 + stats[1:, cv2.CC_STAT_WIDTH], y0 + stats[1:, cv2.CC_STAT_HEIGHT]
    bw, bh = x1[largest] - x0[largest], y1[largest] - y0[largest]
    near = (
        (x1 >= x0[largest] - 0.25 * bw)
        & (x0 <= x1[largest] + 0.25 * bw)
        & (y1 >= y0[largest] - 0.5 * bh)
        & (y0 <= y1[largest] + 0.5 * bh)
    )
    keep = near & (area >= config.keep_piece_frac * area[largest])
    keep[largest] = True
    beside = (x1 <= x0[largest]) | (x0 >= x1[largest])  # no column shared with it
    big = area >= max(min_area, PERSON_SHARE * area[largest])
    people = 1 + int(np.count_nonzero(big & beside))
    out[y : y + h, x : x + w] = np.r_[False, keep][labels]
    return out, people


def people_in_view(people: np.ndarray) -> int:
    """The people a clip shows: the most that at least :data:`PEOPLE_FRAME_SHARE` of its
    frames show (a stray blob in a frame or two does not count).

    Parameters
    ----------
    people : (F,) int
        People per frame (as :func:`learned_masks` or :func:`count_people` count them).
    """
    people = np.sort(np.asarray(people, np.int64))[::-1]
    if len(people) == 0:
        return 0
    return int(people[min(len(people) - 1, int(len(people) * PEOPLE_FRAME_SHARE))])


def count_people(masks: np.ndarray, config: SilhouetteConfig) -> np.ndarray:
    """People per frame in finished masks (F, H, W) bool, counted as
    :func:`person_in_frame` counts them; (F,) int64."""
    return np.array([person_in_frame(m, config)[1] for m in masks], np.int64)
