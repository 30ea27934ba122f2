"""A query's sliding windows: their search, the specific action they may show, and
the clip's segments.

Besides the whole clip, a query searches each window of
:func:`~eigmotion.retrieval.library_views.window_bounds` (:func:`search_windows`).  Where the
whole clip's answer is filler (walking into a turn), windows that show a specific
action answer instead (:func:`specific_window_entry`); and the windows' labels, made
consistent along the clip (:func:`window_label_path`), cut it into segments
(:func:`clip_segments`).  The constants here are read when a query is answered.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from eigmotion.errors import InvalidParameterError, VideoError
from eigmotion.mocap.library import FILLER_LABELS
from eigmotion.retrieval.eigenspace import Eigenspace
from eigmotion.retrieval.motion_image import ClipMotionImages
from eigmotion.retrieval.neighbours import NearestEntries
from eigmotion.retrieval.results import Match, Segment
from eigmotion.retrieval.search import TreeIndex

#: A window overrides a filler answer only when its nearest specific entry is nearer
#: than this fraction of its nearest filler entry (specific motions such as a walking
#: turn hold walking steps of their own), among :data:`FILLER_CANDIDATES` nearest.
SPECIFIC_MARGIN = 0.7
#: Nearest entries of each window the segments' labels are chosen from
#: (:func:`window_label_path`).
WINDOW_CANDIDATES = 8
#: Nearest entries of each window searched for a filler entry: a motion holds many
#: entries of nearly one image (its bodies, outfits and neighbouring views), so a
#: walked-up pick-up's window can fill the eight nearest of a walking window alone.
FILLER_CANDIDATES = 32
#: Windows that must show the same specific action for it to override filler: one
#: window alone is as often a walk's stride matched to a walking turn's.
MIN_SPECIFIC_WINDOWS = 2
#: What a change of label between consecutive windows costs the clip's segments, as a
#: fraction of the database's threshold: one window that matches another action
#: than its neighbours is more often a poor match than an action of its own
#: (:func:`window_label_path`).
SEGMENT_SWITCH_COST = 0.15


def window_label_path(
    labels: Sequence[Sequence[str]], distances: np.ndarray, switch_cost: float
) -> tuple[list[str], np.ndarray]:
    """One label per window of a clip: the labelling whose windows lie nearest their
    labels, each change of label between consecutive windows counted as
    ``switch_cost`` more (a Viterbi path).

    The labels to choose from are those of the windows' nearest entries: a label that
    is no window's nearest does not take over the clip for coming second everywhere.
    A label's distance from a window is that of the window's nearest entry of the
    label; where none of the window's searched entries has the label, the farthest of
    them stands in (the label is at least that far).  With ``switch_cost`` 0 every
    window takes the label of its nearest entry.

    Parameters
    ----------
    labels : sequence of W sequences of K str
        The labels of each window's K nearest entries, nearest first.
    distances : (W, K) float
        Their distances, eigenspace units.
    switch_cost : float
        Eigenspace units, >= 0.

    Returns
    -------
    path : list of W str
    distances : (W,) float64
        Each window's distance from its label in ``path``.
    """
    distances = np.asarray(distances, dtype=np.float64)
    if distances.ndim != 2 or distances.shape[0] != len(labels) or not len(labels):
        raise InvalidParameterError(
            f"distances must be (W, K) for {len(labels)} windows, got {distances.shape}"
        )
    candidates = list(dict.fromkeys(row[0] for row in labels))
    cost = np.repeat(distances[:, -1:], len(candidates), axis=1)  # (W, L)
    for w, row in enumerate(labels):
        for label, dist in zip(reversed(row), distances[w, ::-1], strict=True):
            if label in candidates:
                cost[w, candidates.index(label)] = dist  # the nearest written last
    total = cost[0].copy()
    came_from = np.empty(cost.shape, np.int64)
    for w in range(1, len(cost)):
        switch = total.min() + switch_cost
        stays = total <= switch  # a tie keeps the label
        came_from[w] = np.where(stays, np.arange(len(candidates)), total.argmin())
        total = np.where(stays, total, switch) + cost[w]
    chosen = [int(total.argmin())]
    for w in range(len(cost) - 1, 0, -1):
        chosen.append(int(came_from[w, chosen[-1]]))
    chosen.reverse()
    return [candidates[c] for c in chosen], cost[np.arange(len(cost)), chosen]


def search_windows(
    images: ClipMotionImages, windows: np.ndarray, eigenspace: Eigenspace, index: TreeIndex
) -> tuple[list[tuple[int, int]], NearestEntries | None]:
    """The nearest entries of each window's motion image: as many as the segments
    (:data:`WINDOW_CANDIDATES`) or the filler rule (:data:`FILLER_CANDIDATES`) read.

    Parameters
    ----------
    images : ClipMotionImages
        The clip's.
    windows : (W, 2) int
        Frame bounds ``[start, stop)`` of the windows (the whole clip's excluded).
    eigenspace : Eigenspace
        The database's.
    index : TreeIndex
        The database's entries.

    Returns
    -------
    kept : list of (int, int)
        The bounds of the windows that show a person moving, in order.
    NearestEntries or None
        Their search, one row per kept window; None when none is kept.
    """
    vectors, kept = [], []
    for start, stop in windows:
        try:
            vectors.append(images.window(start, stop))
            kept.append((int(start), int(stop)))
        except VideoError:
            continue  # no person or no motion in this window: not a segment
    if not vectors:
        return kept, None
    points = eigenspace.transform(np.asarray(vectors, dtype=np.float32))
    top_k = max(WINDOW_CANDIDATES, FILLER_CANDIDATES)
    return kept, index.search(points, top_k=min(top_k, index.n_entries))


def specific_window_entry(
    whole_label: str,
    windowed: NearestEntries | None,
    label_of: Callable[[int], str],
    threshold: float,
) -> tuple[float, int] | None:
    """The window entry that answers the clip instead of the whole clip's, if any.

    Only where the whole clip's label is filler
    (:data:`~eigmotion.mocap.library.FILLER_LABELS`: walking into a turn) and the
    windows show a specific action — at least :data:`MIN_SPECIFIC_WINDOWS` windows
    whose nearest entry has that label, lies within ``threshold`` and is nearer than
    :data:`SPECIFIC_MARGIN` times the window's nearest filler entry (the library's
    walking turns hold walking steps of their own).

    Parameters
    ----------
    whole_label : str
        The label of the whole clip's answer.
    windowed : NearestEntries or None
        :func:`search_windows`' search.
    label_of : callable
        An entry id's label.
    threshold : float
        The database's "unknown" threshold, eigenspace units.

    Returns
    -------
    (distance, entry id) or None
        The nearest of those window entries; None when the whole clip answers.
    """
    if windowed is None or whole_label not in FILLER_LABELS:
        return None
    specific: dict[str, list[tuple[float, int]]] = {}
    for ids, dists in zip(windowed.ids, windowed.distances, strict=True):
        labels = [label_of(int(i)) for i in ids]
        if labels[0] in FILLER_LABELS or dists[0] > threshold:
            continue
        filler = [d for d, label in zip(dists, labels, strict=True) if label in FILLER_LABELS]
        if not filler or dists[0] < SPECIFIC_MARGIN * filler[0]:
            specific.setdefault(labels[0], []).append((float(dists[0]), int(ids[0])))
    shown = [min(found) for found in specific.values() if len(found) >= MIN_SPECIFIC_WINDOWS]
    if not shown:
        return None
    return min(shown)


def clip_segments(
    kept: Sequence[tuple[int, int]],
    windowed: NearestEntries | None,
    n_frames: int,
    best: Match,
    label_of: Callable[[int], str],
    threshold: float,
) -> list[Segment]:
    """The clip's parts: consecutive windows with the same label
    (:func:`window_label_path`, each change costing :data:`SEGMENT_SWITCH_COST` times
    ``threshold``), merged; overlapping windows of different labels are split at the
    midpoint of their overlap.  Where the windows show one action throughout, it is
    the clip's answer, ``best``: the whole clip, ranked by its silhouette sequence as
    well, tells it better than any window.

    Parameters
    ----------
    kept, windowed
        As :func:`search_windows` returns them.
    n_frames : int
        Frames of the clip (as the query's masks count them).
    best : Match
        The clip's answer.
    label_of : callable
        An entry id's label.
    threshold : float
        The database's "unknown" threshold, eigenspace units.

    Returns
    -------
    list of Segment
        In order, frames as the query's masks count them.
    """
    if windowed is None:
        return [Segment(0, n_frames, best.label, best.distance)]
    ids, distances = windowed.ids[:, :WINDOW_CANDIDATES], windowed.distances[:, :WINDOW_CANDIDATES]
    labels = [[label_of(int(i)) for i in row] for row in ids]
    path, costs = window_label_path(labels, distances, SEGMENT_SWITCH_COST * threshold)
    if len(set(path)) == 1:
        return [Segment(kept[0][0], kept[-1][1], best.label, best.distance)]
    segments: list[Segment] = []
    for (start, stop), label, dist in zip(kept, path, costs.tolist(), strict=True):
        if segments and segments[-1].label == label and start < segments[-1].end_frame:
            last = segments[-1]
            segments[-1] = Segment(last.start_frame, stop, label, min(last.distance, dist))
        else:
            if segments and start < segments[-1].end_frame:
                last = segments[-1]
                cut = (start + last.end_frame) // 2
                segments[-1] = Segment(last.start_frame, cut, last.label, last.distance)
                start = cut
            segments.append(Segment(start, stop, label, dist))
    return segments


def snapped_to_cuts(segments: list[Segment], cuts: Sequence[int], reach: int) -> list[Segment]:
    """``segments`` with each boundary between two labels moved onto a cut between shots
    within ``reach`` frames of it (the nearest): a window that straddles a cut shows
    both shots, so the change of label is placed only to a window's length, and the cut
    places it exactly.

    Parameters
    ----------
    segments : list of Segment
        In order, each ending where the next starts (:func:`clip_segments`).
    cuts : sequence of int
        The first frame of each shot after the first, as the segments count frames.
    reach : int
        Frames a boundary may move, >= 0.

    Returns
    -------
    list of Segment
    """
    cuts = np.asarray(cuts, dtype=np.int64)
    if not len(cuts) or len(segments) < 2:
        return list(segments)
    out = list(segments)
    for k in range(1, len(out)):
        before, after = out[k - 1], out[k]
        boundary = after.start_frame
        near = cuts[np.abs(cuts - boundary) <= reach]
        if before.label == after.label or not len(near):
            continue
        cut = int(near[np.argmin(np.abs(near - boundary))])
        if before.start_frame < cut < after.end_frame:
            out[k - 1] = Segment(before.start_frame, cut, before.label, before.distance)
            out[k] = Segment(cut, after.end_frame, after.label, after.distance)
    return out


def within_person(segments: list[Segment], present: np.ndarray) -> list[Segment]:
    """``segments`` cut to the frames from the first to the last that show the person:
    a window that reaches into frames before the person comes into view (or after they
    leave) labels them too, and the clip's parts should not claim them.  A segment left
    without frames is dropped.

    Parameters
    ----------
    segments : list of Segment
        In order (:func:`clip_segments`), frames as ``present`` counts them.
    present : (F,) bool
        The frames whose silhouette holds the person.

    Returns
    -------
    list of Segment
        ``segments`` itself where no frame shows the person.
    """
    shown = np.flatnonzero(present)
    if not len(shown):
        return list(segments)
    first, stop = int(shown[0]), int(shown[-1]) + 1
    out = []
    for seg in segments:
        start, end = max(seg.start_frame, first), min(seg.end_frame, stop)
        if start < end:
            out.append(Segment(start, end, seg.label, seg.distance))
    return out
