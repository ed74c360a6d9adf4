"""Animations: the arm, its cables and the tip trail, frame by frame (GIF or MP4).

* :func:`animate_trace` — the arm along a traced path (Fig. 3 as a movie),
  one frame per path point (subsampled to at most ``max_frames``).
* :func:`animate_control` — the arm through the iterations of one tip-control
  solve (Fig. 2 as a movie): the equilibrium (Eq. (9)) at each iterate of the
  tensions, re-solved warm-started from the previous iterate.
* :func:`animate_simulation` — a run of ``simulate`` (the arm in motion), frames
  timed to the simulated clock (real time, or ``slow_motion`` times slower).

GIF is written with Pillow (matplotlib's ``PillowWriter``); MP4 needs the
``ffmpeg`` program on PATH (:func:`check_animation_path` says so before any
computing).  Geometry in mm, tensions in N beside p = P l^2/B.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..core.errors import InputError
from ..core.model import Arm
from .common import TENDON_COLOURS, draw_setting, figure

FORMATS = (".gif", ".mp4")
DPI = 160                    # 6.4 x 5.2 in -> 1024 x 832 pixels; 8 pt text is 18 px high


@dataclass(frozen=True)
class Frame:
    """One picture: the centreline and attachment points [mm] and a caption."""

    x_mm: np.ndarray              # (N+1, 2)
    attachments_mm: np.ndarray    # (n, 2)
    tip_mm: np.ndarray            # (2,)
    caption: str
    duration_s: float = 0.0       # how long it is shown (0: the animation's fps)
    cables_mm: tuple = ()         # each cable's polyline, routing point to end (guides between)


def check_animation_path(path, overwrite: bool = False, option: str = "--animate") -> Path:
    """Refuse (InputError, one line) a file we could not write, before computing."""
    from matplotlib import animation

    from ..io.hdf5 import check_output_path

    path = Path(path)
    if path.suffix.lower() not in FORMATS:
        raise InputError(f"{option} {path}: animations are written as .gif or .mp4, got "
                         f"{path.suffix!r}")
    if path.suffix.lower() == ".mp4" and not animation.writers.is_available("ffmpeg"):
        raise InputError(f"{path}: MP4 needs the ffmpeg program, which is not installed "
                         "(apt-get install ffmpeg); write a .gif instead")
    return check_output_path(path, overwrite, FORMATS, option)


def _frame(arm: Arm, eq, caption: str) -> Frame:
    l_mm = arm.length_mm
    return Frame(eq.x * l_mm, eq.attachments * l_mm, eq.tip * l_mm, caption,
                 cables_mm=tuple(c * l_mm for c in eq.cable_points))


def _tensions(arm: Arm, p) -> str:
    P = arm.tensions_to_N(p)
    return ", ".join(f"P{i + 1} = {v:.2f} N" for i, v in enumerate(P))


def _pick(count: int, max_frames: int) -> np.ndarray:
    return np.unique(np.linspace(0, count - 1, min(count, max_frames)).round().astype(int))


def frame_times(end_s: float, slow_motion: float, fps: float, max_frames: int):
    """(times [s] of the frames in the run shown, display time of each [s]) for a run
    of ``end_s`` played ``slow_motion`` times slower than real time: one frame every
    1/``fps`` s of playback, longer if more than ``max_frames`` would be needed."""
    if not slow_motion > 0:
        raise InputError(f"--slow-motion must be positive, got {slow_motion}")
    play_s = end_s * slow_motion
    show_s = max(1.0 / fps, play_s / max(max_frames - 1, 1))    # each frame's display
    count = int(np.ceil(play_s / show_s - 1e-9)) + 1
    return np.minimum(np.arange(count) * show_s, play_s) / slow_motion, show_s


def trace_frames(arm: Arm, trace, max_frames: int = 150, approach=None, times_s=None,
                 slow_motion: float = 1.0, fps: float = 10.0) -> list[Frame]:
    """Frames of a traced path (``trace.results`` needed: trace with
    keep_results), preceded by those of its ``approach`` (another trace) if given.
    With ``times_s`` (the schedule's time of every row, approach rows first) the
    frames are timed to the schedule, ``slow_motion`` times slower than real time:
    one every 1/``fps`` s of playback (longer if more than ``max_frames`` would be
    needed), showing the row the motors have reached then, until it is replaced (the
    last, the end of the schedule, for one interval more)."""
    parts = [(name, t) for name, t in (("approach", approach), ("point", trace)) if t is not None]
    if any(not t.results for _, t in parts):
        raise InputError("animating a trace needs its per-point states (keep_results=True)")
    rows = [(name, k, t) for name, t in parts for k in range(t.n_points)]
    timed = times_s is not None and len(times_s) == len(rows) and np.all(np.isfinite(times_s))
    if timed:
        at_s, show_s = frame_times(float(times_s[-1]), slow_motion, fps, max_frames)
        picks = np.clip(np.searchsorted(times_s, at_s * (1 + 1e-12), side="right") - 1, 0,
                        len(rows) - 1)
    else:
        picks, at_s, show_s = _pick(len(rows), max_frames), None, 0.0
    frames = []
    for j, row in enumerate(picks):
        name, k, t = rows[row]
        clock = "" if at_s is None else f"t = {at_s[j]:.1f} s  "
        frame = _frame(arm, t.results[k].equilibrium,
                       f"{clock}{name} {k + 1}/{t.n_points}: {_tensions(arm, t.p[k])}"
                       + ("" if t.converged[k] else "  (NOT reached)"))
        frames.append(replace(frame, duration_s=show_s))
    return frames


def control_frames(controller, result) -> list[Frame]:
    """Frames of one tip-control solve: the equilibrium at every iterate of the
    tensions (``result.history_p``), solved warm-started in turn."""
    arm, frames, state = controller.arm, [], None
    l_mm = arm.length_mm
    for k, p in enumerate(result.history_p):
        state = controller.forward(p, start=state)
        E = result.history_E[k] * l_mm ** 2
        frames.append(_frame(arm, state, f"iteration {k}: {_tensions(arm, p)}, "
                                         f"E = {E:.3g} mm^2"))
    return frames


def simulation_frames(result, *, slow_motion: float = 1.0, fps: float = 20.0,
                      max_frames: int = 600) -> list[Frame]:
    """Frames of a run of ``simulate`` (a SimulationResult) timed to its clock,
    ``slow_motion`` times slower than real time (:func:`frame_times`): each shows the
    recorded step nearest to its time, captioned with the time and the tensions."""
    t = result.time_s
    at_s, show_s = frame_times(float(t[-1]), slow_motion, fps, max_frames)
    frames = []
    for j, state in enumerate(result.snapshots(_nearest(t, at_s))):
        frame = _frame(result.arm, state, f"t = {at_s[j]:.2f} s:  {_tensions(result.arm, state.p)}")
        frames.append(replace(frame, duration_s=show_s))
    return frames


def _nearest(times: np.ndarray, at: np.ndarray) -> np.ndarray:
    """Index of the entry of the increasing ``times`` nearest to each of ``at``."""
    if len(times) == 1:
        return np.zeros(len(at), int)
    k = np.clip(np.searchsorted(times, at), 1, len(times) - 1)
    return np.where(at - times[k - 1] <= times[k] - at, k - 1, k)


def animate_simulation(result, path, *, slow_motion: float = 1.0, fps: float = 20.0,
                       max_frames: int = 600, on_frame=None) -> Path:
    """A run of ``simulate`` as a GIF/MP4 (by suffix): the arm, its cables and the tip
    trail in real time (or ``slow_motion`` times slower), with the quasi-static path
    of a motor schedule as the target path when there is one; ``on_frame(done, total)``
    reports progress."""
    frames = simulation_frames(result, slow_motion=slow_motion, fps=fps, max_frames=max_frames)
    at_s, _ = frame_times(float(result.time_s[-1]), slow_motion, fps, max_frames)
    moved = result.tip_mm - result.tip_mm[0]
    history = History(result.time_s, moved, ("tip x - x(0)", "tip y - y(0)"),
                      "tip displacement [mm]", at_s)
    speed = "real time" if slow_motion == 1 else f"{slow_motion:g}x slower than real time"
    inputs = {"tensions": "constant tensions", "history": "tension history",
              "schedule": "motor schedule"}
    return animate(result.arm, frames, path, targets_mm=result.planned_tip_mm,
                   title=f"Simulation ({inputs.get(result.input, result.input)}, "
                         f"{result.elements} elements); {speed}", fps=fps, history=history,
                   on_frame=on_frame)


@dataclass(frozen=True)
class History:
    """A time plot under the arm: ``values`` (T, k) against ``time_s`` (T,) drawn up to
    each frame's time ``frame_time_s`` (one per frame), with a cursor there."""

    time_s: np.ndarray
    values: np.ndarray
    labels: tuple
    ylabel: str
    frame_time_s: np.ndarray


def _history_panel(ax, history: History):
    """Draw the axes of ``history``; returns draw(k) -> the artists moved for frame k."""
    t, v = history.time_s, history.values
    lines = [ax.plot([], [], lw=1.2, label=label)[0] for label in history.labels]
    cursor = ax.axvline(history.frame_time_s[0], color="0.4", lw=0.8)
    pad = 0.05 * max(float(np.ptp(v)), 1e-9)
    ax.set_xlim(t[0], t[-1] if t[-1] > t[0] else t[0] + 1.0)
    ax.set_ylim(float(v.min()) - pad, float(v.max()) + pad)
    ax.set_xlabel("time [s]")
    ax.set_ylabel(history.ylabel)
    ax.grid(True, lw=0.3, alpha=0.6)
    ax.legend(loc="lower right", bbox_to_anchor=(1.0, 1.0), ncol=len(lines), fontsize=7,
              frameon=False)                       # above the panel, off the curves

    def draw(k):
        now = history.frame_time_s[k]
        j = int(np.searchsorted(t, now * (1 + 1e-12), side="right"))
        for c, line in enumerate(lines):
            line.set_data(t[:j], v[:j, c])
        cursor.set_xdata([now, now])
        return [*lines, cursor]

    return draw


def animate(arm: Arm, frames: list[Frame], path, *, targets_mm=None, title: str = "",
            fps: float = 10.0, history: History | None = None, on_frame=None) -> Path:
    """Write the frames as a GIF or MP4 (by the suffix of ``path``): the arm,
    its cables to the routing points, the tip trail so far and the targets;
    with ``history``, a time plot under it (:class:`History`); ``on_frame(done,
    total)`` after each frame drawn."""
    from matplotlib import animation

    path = Path(path)
    if not frames:
        raise InputError("nothing to animate (no frames)")
    if history is None:
        fig, ax = figure(figsize=(6.4, 5.2))
        draw_history = None
    else:
        fig, (ax, hax) = figure(nrows=2, figsize=(6.4, 5.2),
                                gridspec_kw={"height_ratios": (3, 2), "hspace": 0.45})
        fig.subplots_adjust(bottom=0.17, top=0.93)
        draw_history = _history_panel(hax, history)
    draw_setting(ax, arm)
    routes = arm.routes() * arm.length_mm
    if targets_mm is not None:
        t = np.atleast_2d(targets_mm)
        ax.plot(t[:, 0], t[:, 1], "-" if len(t) > 1 else "*", color="tab:green", lw=3,
                ms=12, alpha=0.45, label="target" + ("s" if len(t) > 1 else ""))
    arm_line, = ax.plot([], [], "k-", lw=2.2, zorder=3, label="arm")
    trail, = ax.plot([], [], "-", color="tab:red", lw=1, zorder=4, label="tip trail")
    tip, = ax.plot([], [], "o", color="k", ms=5, zorder=5)
    cables = [ax.plot([], [], "-", lw=1.0, color=TENDON_COLOURS[i % len(TENDON_COLOURS)],
                      zorder=2)[0] for i in range(arm.n_tendons)]
    caption = fig.text(0.5, 0.04, "", ha="center", fontsize=9)    # under the axes, off the arm
    pts = np.vstack([f.x_mm for f in frames] + [routes, [[0.0, 0.0], [arm.length_mm, 0.0]]])
    pad = 0.05 * np.ptp(pts, axis=0).max()
    ax.set_xlim(pts[:, 0].min() - pad, pts[:, 0].max() + pad)
    ax.set_ylim(pts[:, 1].min() - pad, pts[:, 1].max() + pad)
    ax.set_aspect("equal")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_title(title, fontsize=10)
    ax.grid(True, lw=0.3, alpha=0.6)
    ax.legend(loc="upper left", fontsize=7)
    tips = np.array([f.tip_mm for f in frames])

    def draw(k):
        f = frames[k]
        arm_line.set_data(f.x_mm[:, 0], f.x_mm[:, 1])
        tip.set_data([f.tip_mm[0]], [f.tip_mm[1]])
        trail.set_data(tips[:k + 1, 0], tips[:k + 1, 1])
        for c, line in zip(cables, f.cables_mm):
            c.set_data(line[:, 0], line[:, 1])
        caption.set_text(f.caption)
        more = [] if draw_history is None else draw_history(k)
        return [arm_line, tip, trail, caption, *cables, *more]

    import matplotlib.pyplot as plt
    try:
        shown_ms = [int(round(1000.0 * (f.duration_s or 1.0 / fps))) for f in frames]
        if path.suffix.lower() == ".gif":
            _write_gif(fig, draw, shown_ms, path, on_frame)
        else:                          # constant frame rate: the frames' mean duration
            rate = 1000.0 / float(np.mean(shown_ms))
            movie = animation.FuncAnimation(fig, draw, frames=len(frames), blit=False)
            movie.save(path, writer=animation.FFMpegWriter(fps=rate), dpi=DPI,
                       progress_callback=None if on_frame is None else
                       (lambda k, total: on_frame(k + 1, total)))
    finally:
        plt.close(fig)
    return path


def _write_gif(fig, draw, shown_ms: list[int], path: Path, on_frame=None) -> None:
    """Blitted frames into an animated GIF with Pillow: the static picture
    (axes, routing points, targets) is drawn once, each frame redraws only
    the moving artists (5x faster than redrawing the figure twice per frame
    as matplotlib's writer does)."""
    from PIL import Image

    fig.set_dpi(DPI)
    canvas = fig.canvas
    moving = draw(0)
    for artist in moving:
        artist.set_animated(True)
    canvas.draw()
    background = canvas.copy_from_bbox(fig.bbox)
    images = []
    for k in range(len(shown_ms)):
        canvas.restore_region(background)
        for artist in draw(k):
            fig.draw_artist(artist)
        rgb = np.asarray(canvas.buffer_rgba())[..., :3]
        # a palette of its own per frame, made now: 1 byte per pixel kept, not 3 (what
        # Pillow's GIF writer would do to an RGB frame at the end, with all of them held)
        images.append(Image.fromarray(rgb).convert("P", palette=Image.Palette.ADAPTIVE))
        if on_frame is not None:
            on_frame(k + 1, len(shown_ms))
    images[0].save(path, save_all=True, append_images=images[1:], loop=0,
                   duration=shown_ms, optimize=False)


def animate_trace(arm: Arm, trace, path, *, approach=None, max_frames: int = 150,
                  fps: float = 10.0, times_s=None, slow_motion: float = 1.0) -> Path:
    """The arm along a traced path (GIF/MP4 by suffix), at most ``max_frames``
    frames, after the ``approach`` from the straight arm when given (the
    motors' whole schedule, :func:`elastica_petsc.studies.schedule.trace_schedule`);
    timed to the schedule's ``times_s`` when given (:func:`trace_frames`)."""
    targets = trace.targets_mm if approach is None else np.vstack((approach.targets_mm,
                                                                   trace.targets_mm))
    reached = int(np.sum(trace.converged))
    frames = trace_frames(arm, trace, max_frames, approach, times_s, slow_motion, fps)
    if times_s is not None and frames[0].duration_s:
        speed = "real time" if slow_motion == 1 else f"{slow_motion:g}x slower than real time"
    else:
        speed = ""
    return animate(arm, frames, path, targets_mm=targets,
                   title=f"Traced path: {trace.n_points} points ({reached} reached)"
                         + ("" if approach is None else
                            f", after a {approach.n_points}-point approach")
                         + (f"; {speed}" if speed else ""), fps=fps)


def animate_control(controller, result, path, *, fps: float = 2.0) -> Path:
    """The arm through the iterations of a tip-control solve (Fig. 2 as a movie)."""
    return animate(controller.arm, control_frames(controller, result), path,
                   targets_mm=result.target_mm,
                   title=f"Tip control ({result.method}): {result.iterations} iterations, "
                         f"{result.reason}", fps=fps)
