"""The library's action spans as the body measures them, and their plot.

The manifest's ``action`` spans of turns and jumps, and the filler before and after
them, are read off body signals over time (:func:`body_signals`) by one rule per label
(:func:`measured_span`, :func:`measured_filler`); :func:`plot` draws the signals, the
span shaded and the build's windows coloured by the label each gets.
``benchmarks/studies/plot_action_spans.py`` prints and plots them; docs/library.md
(action spans) says how each span was read off these signals.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.ndimage import uniform_filter1d

from eigmotion.mocap.kinematics import forward_kinematics
from eigmotion.mocap.library import FILLER_LABELS, LibraryMotion
from eigmotion.mocap.naming import canonical_joint_map
from eigmotion.retrieval.library_views import BuildConfig, window_bounds, window_labels

#: Signals are averaged over this long (a walking stride's pelvis sway, frame noise).
SMOOTH_S = 0.25
#: A turn is where the hips turn faster than this, deg/s (the stretch around the fastest
#: turning): above the sway of the walking before and after the library's turns.
TURN_RATE_DEG_S = 30.0
#: A jump is where the hips are further than this from their height standing at the
#: end, metres (crouch, flight, landing): above the bob of the running-jump's run-up.
JUMP_HIPS_M = 0.05
#: Around an action the person stands unless a foot moves this far (a step), metres...
STEP_M = 0.25
#: ...and runs when the lower ankle rises this far above its lowest (both feet off), m.
RUN_FLIGHT_M = 0.04
#: Colours of the window bars: the action, the filler, left out.
ACTION_RGB, FILLER_RGB, LEFT_OUT_RGB = "#d95f02", "#1b9e77", "#bbbbbb"


def body_signals(item: LibraryMotion) -> dict[str, np.ndarray]:
    """Per-frame body measures of a library motion.

    Returns
    -------
    dict of str to float64 arrays
        (F,) each: ``time_s`` (s from the first frame), ``root_speed`` (horizontal,
        m/s), ``heading_rate`` (deg/s, positive to the left, from the line through the
        hip joints), ``hips_height``, ``feet_height`` (the lower ankle joint),
        ``hands_height`` (the higher hand), metres above the floor; speeds and rates
        averaged over :data:`SMOOTH_S`.  ``feet_path`` (F, 2, 2): both ankles'
        horizontal x, z, metres.
    """
    motion = item.motion
    pose = forward_kinematics(motion)
    joints = canonical_joint_map(motion.skeleton)
    p = {name: pose.positions[:, j] for name, j in joints.items()}
    dt = motion.frame_time_s
    smooth = max(1, round(SMOOTH_S / dt))
    velocity = np.gradient(p["Hips"][:, [0, 2]], dt, axis=0)
    across = p["LeftUpLeg"] - p["RightUpLeg"]
    heading = np.degrees(np.unwrap(np.arctan2(-across[:, 2], across[:, 0])))
    return {
        "time_s": np.arange(motion.n_frames) * dt,
        "feet_path": np.stack([p["LeftFoot"][:, [0, 2]], p["RightFoot"][:, [0, 2]]], axis=1),
        "root_speed": uniform_filter1d(np.linalg.norm(velocity, axis=1), smooth, mode="nearest"),
        "heading_rate": uniform_filter1d(np.gradient(heading, dt), smooth, mode="nearest"),
        "hips_height": p["Hips"][:, 1],
        "feet_height": np.minimum(p["LeftFoot"][:, 1], p["RightFoot"][:, 1]),
        "hands_height": np.maximum(p["LeftHand"][:, 1], p["RightHand"][:, 1]),
    }


def measured_span(item: LibraryMotion, signals: dict) -> tuple[float, float] | None:
    """The action span read off the signals by its label's rule, seconds, or ``None``.

    A turn: the stretch around the fastest turning where the heading rate exceeds
    :data:`TURN_RATE_DEG_S`.  A jump: from the first to the last frame where the hips
    are more than :data:`JUMP_HIPS_M` from their height at the end.  Other labels have
    no rule.
    """
    t, dt = signals["time_s"], float(item.motion.frame_time_s)
    if item.label == "turn":
        rate = np.abs(signals["heading_rate"])
        fast = rate >= TURN_RATE_DEG_S
        first = last = int(np.argmax(rate))
        if not fast[first]:
            return None
        while first > 0 and fast[first - 1]:
            first -= 1
        while last + 1 < len(fast) and fast[last + 1]:
            last += 1
        return float(t[first]), float((last + 1) * dt)
    if item.label == "jump":
        away = np.flatnonzero(
            np.abs(signals["hips_height"] - signals["hips_height"][-1]) > JUMP_HIPS_M
        )
        return (float(t[away[0]]), float((away[-1] + 1) * dt)) if away.size else None
    return None


def outside_action(signals: dict, span: tuple[float, float]) -> tuple[str, str]:
    """What the person does before and after a span: ``"stand"``, ``"walk"`` or ``"run"``
    (``"-"`` for no time), by whether a foot steps (moves :data:`STEP_M` between the
    part's first and last frame: shifting the weight is standing) and whether both feet
    leave the floor (:data:`RUN_FLIGHT_M`)."""
    t, feet = signals["time_s"], signals["feet_path"]
    floor = signals["feet_height"].min()
    out = []
    for part in (np.flatnonzero(t < span[0]), np.flatnonzero(t >= span[1])):
        if part.size < 2:
            out.append("-")
        elif np.linalg.norm(feet[part[-1]] - feet[part[0]], axis=-1).max() < STEP_M:
            out.append("stand")
        else:
            flight = signals["feet_height"][part].max() - floor >= RUN_FLIGHT_M
            out.append("run" if flight else "walk")
    return out[0], out[1]


def measured_filler(signals: dict, span: tuple[float, float]) -> str | None:
    """The filler around a span: what the person does before it, or else after it, when
    that is walking or running (:func:`outside_action`); ``None`` for standing."""
    return next((part for part in outside_action(signals, span) if part in FILLER_LABELS), None)


def build_windows(item: LibraryMotion, config: BuildConfig) -> tuple[np.ndarray, list]:
    """The sliding windows the build cuts from a motion, seconds, and their labels.

    Returns
    -------
    windows_s : (W, 2) float64
        ``[start, stop)`` seconds, the whole motion left out.
    labels : list of (str or None)
    """
    n_frames = item.motion.resample(config.render_fps).n_frames
    frames = window_bounds(n_frames, config.render_fps, config.window_s, config.window_step_s)
    windows_s = frames[1:] / config.render_fps
    return windows_s, window_labels(item, windows_s)


def plot(items: list[LibraryMotion], config: BuildConfig, out: Path) -> None:
    """One panel per motion: signals, the span shaded, the windows as bars below."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cols = 2 if len(items) > 1 else 1
    rows = -(-len(items) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(7.5 * cols, 2.6 * rows), squeeze=False)
    for ax in axes.flat[len(items) :]:
        ax.set_visible(False)
    for ax, item in zip(axes.flat, items, strict=False):
        s = body_signals(item)
        t = s["time_s"]
        ax.plot(t, s["root_speed"], color="black", label="root speed (m/s)")
        ax.plot(t, s["hips_height"], color="tab:blue", label="hips (m)")
        ax.plot(t, s["feet_height"], color="tab:green", label="lower ankle (m)")
        ax.plot(t, s["hands_height"], color="tab:purple", label="higher hand (m)")
        rate = ax.twinx()
        rate.plot(t, s["heading_rate"], color="tab:red", lw=1, label="heading rate (deg/s)")
        rate.axhline(0.0, color="tab:red", lw=0.5, ls=":")
        rate.set_ylim(-250, 250)
        rate.tick_params(labelsize=7, colors="tab:red")
        if item.action is not None:
            ax.axvspan(*item.action, color=ACTION_RGB, alpha=0.15, lw=0)
        windows_s, labels = build_windows(item, config)
        for i, ((a, b), label) in enumerate(zip(windows_s, labels, strict=True)):
            colour = (
                LEFT_OUT_RGB if label is None else ACTION_RGB if label == item.label else FILLER_RGB
            )
            ax.plot([a, b], [-0.12 - 0.07 * i] * 2, color=colour, lw=3, solid_capstyle="butt")
        span = "whole motion" if item.action is None else f"action {span_text(item.action)} s"
        filler = f", filler {item.filler}" if item.filler else ""
        ax.set_title(f"{item.name} ({item.label}): {span}{filler}", fontsize=9)
        ax.set_xlim(0.0, item.motion.duration_s)
        ax.set_ylim(-0.14 - 0.07 * max(len(labels), 1), 3.2)
        ax.tick_params(labelsize=7)
        ax.set_xlabel("s from the motion's first frame", fontsize=7, labelpad=1)
        ax.grid(alpha=0.3)
    handles = axes.flat[0].get_lines()[:4] + [rate.get_lines()[0]]
    handles += [
        matplotlib.lines.Line2D([], [], color=c, lw=3, label=f"window: {what}")
        for c, what in ((ACTION_RGB, "action"), (FILLER_RGB, "filler"), (LEFT_OUT_RGB, "left out"))
    ]
    fig.legend(handles=handles, loc="lower center", ncol=4, fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0.6 / (2.6 * rows), 1, 1))
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=80)
    plt.close(fig)


def span_text(span: tuple[float, float] | None) -> str:
    """``"a.aa-b.bb"`` seconds, or ``"-"`` for no span."""
    return "-" if span is None else f"{span[0]:.2f}-{span[1]:.2f}"
