"""The library's action spans: body signals over time, the span shaded, the windows.

For every library motion with an ``action`` span in the manifest (or the motions
named), plots over time the signals the spans are read from — horizontal root speed
(m/s), hip height, the lower ankle's height (both feet off the floor when it rises),
the higher hand's height (m), and on a second axis the hips' heading rate (°/s) —
shades the span, and draws under it the build's sliding windows coloured by the label
each gets (:func:`eigmotion.retrieval.library_views.window_labels`: the action's, the
filler's, or left out).  Prints one line per motion: the manifest's span and filler, the span its
label's rule measures (:func:`measured_span`; turns and jumps), what the person does
before and after it and the filler that makes (:func:`measured_filler`), and the
windows per label.

    python benchmarks/studies/plot_action_spans.py [NAME ...] [--out docs/library/action_spans.png]

See docs/library.md (action spans) for how each span was read off these signals.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from eigmotion.evaluation.action_spans import (
    body_signals,
    build_windows,
    measured_filler,
    measured_span,
    outside_action,
    plot,
    span_text,
)
from eigmotion.mocap.library import load_library
from eigmotion.retrieval.library_views import BuildConfig

REPO = Path(__file__).resolve().parents[2]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", help="library motions (default: those with a span)")
    parser.add_argument("--out", type=Path, default=REPO / "docs/library/action_spans.png")
    args = parser.parse_args()
    library = load_library(include_distractors=True)
    if args.names:
        by_name = {item.name: item for item in library}
        unknown = [n for n in args.names if n not in by_name]
        if unknown:
            raise SystemExit(f"not in the library: {', '.join(unknown)}")
        items = [by_name[n] for n in args.names]
    else:
        items = [i for i in library if i.action is not None and i.mirror_of is None]
    config = BuildConfig()
    print(
        f"{'motion':26s} {'label':9s} {'action (s)':11s} {'filler':6s} {'measured (s)':12s} "
        f"{'before/after (filler)':22s} windows"
    )
    for item in items:
        _, labels = build_windows(item, config)
        counts = {str(label): labels.count(label) for label in dict.fromkeys(labels)}
        signals = body_signals(item)
        measured = measured_span(item, signals)
        around = "-"
        if measured is not None:
            around = "/".join(outside_action(signals, measured))
            around += f" ({measured_filler(signals, measured) or '-'})"
        print(
            f"{item.name:26s} {item.label:9s} {span_text(item.action):11s} {item.filler or '-':6s} "
            f"{span_text(measured):12s} {around:22s} {counts}"
        )
    plot(items, config, args.out)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
