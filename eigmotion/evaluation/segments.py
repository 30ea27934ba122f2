"""A clip's segments scored against the parts it shows (segmental F1 at 50 %)."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from eigmotion.errors import InvalidParameterError

#: A found segment counts as a part found when its intersection over union with a
#: part of the same label is at least this (segmental F1 at 50 %).
SEGMENT_MIN_IOU = 0.5


@dataclass(frozen=True)
class SegmentAgreement:
    """How a clip's segments agree with the parts it shows (:func:`segment_agreement`).

    Attributes
    ----------
    frames : int
        The clip's frames.
    right : int
        Frames whose segment has their part's label.
    wrong : int
        Frames whose segment has a specific label (not filler) other than their part's.
    found, extra, missed : int
        Segments that match a part (the same label, overlapping it by at least
        :data:`SEGMENT_MIN_IOU` intersection over union, each part matched once),
        segments that match none, and parts no segment matches.
    """

    frames: int
    right: int
    wrong: int
    found: int
    extra: int
    missed: int


def segment_agreement(
    segments: Sequence[tuple[int, int, str]],
    parts: Sequence[tuple[int, int, str]],
    filler: Iterable[str] = (),
) -> SegmentAgreement:
    """A clip's segments against the parts it shows.

    Parameters
    ----------
    segments, parts : sequence of (start, end, label)
        ``[start, end)`` frames; ``parts`` cover the clip, in order and without gaps.
    filler : iterable of str
        Labels that are no action of their own (walking to an action): a frame of
        another part given one of these is not counted wrong.

    Returns
    -------
    SegmentAgreement
    """
    gaps = any(a[1] != b[0] for a, b in zip(parts, parts[1:], strict=False))
    if not parts or parts[0][0] != 0 or gaps:
        raise InvalidParameterError(f"parts must cover the clip in order, got {list(parts)}")
    n = parts[-1][1]
    truth = np.empty(n, dtype=object)
    shown = np.full(n, None, dtype=object)
    for start, end, label in parts:
        truth[start:end] = label
    for start, end, label in segments:
        shown[max(start, 0) : min(end, n)] = label
    filler = set(filler)
    right = int(np.sum(shown == truth))
    wrong = sum(
        s is not None and s != t and s not in filler for s, t in zip(shown, truth, strict=True)
    )
    matched: set[int] = set()
    for start, end, label in segments:
        for k, (p_start, p_end, p_label) in enumerate(parts):
            overlap = min(end, p_end) - max(start, p_start)
            union = max(end, p_end) - min(start, p_start)
            if k not in matched and p_label == label and overlap >= SEGMENT_MIN_IOU * union:
                matched.add(k)
                break
    found = len(matched)
    return SegmentAgreement(n, right, int(wrong), found, len(segments) - found, len(parts) - found)
