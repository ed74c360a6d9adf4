#!/usr/bin/env python3
"""Benchmark issue 14's additions against the work they report on.

1. Progress bar overhead: the Fig. 3a drawing traced (warm-started tip control,
   Sec. 4.5 (v)) with no progress, and with a bar redrawn by its thread on a
   (fake) terminal every ``--interval`` s; runs interleaved, median of
   ``--repeat``; the ratio should be ~1 (the redraw thread only formats a line).
2. Schedule cost: the approach move that `trace --schedule` adds (graded steps
   from the straight arm), as a fraction of tracing the path alone.
3. Export cost: ParaView files (one .vtu per point + .pvd) and a GIF of at
   most 150 frames, against the trace itself.
4. GIF writer: our blitted frames written by Pillow against matplotlib's
   FuncAnimation + PillowWriter (the figure redrawn twice per frame), same
   40 frames, median of ``--repeat // 2`` interleaved runs.

Usage: python scripts/benchmarks/bench_export.py [--repeat 5] [--step 2] [--elements 180] [--interval 0.05]
"""
from __future__ import annotations

import argparse
import io
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))


class FakeTerminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--step", type=float, default=2.0)
    ap.add_argument("--elements", type=int, default=180)
    ap.add_argument("--interval", type=float, default=0.05, help="bar redraw interval [s]")
    args = ap.parse_args(argv)

    from elastica_petsc.core.model import load_config
    from elastica_petsc.ui.progress import Progress
    from elastica_petsc.io.vtk import write_trace
    from elastica_petsc.plots.animate import animate_trace
    from elastica_petsc.solvers.control import TipController
    from elastica_petsc.studies.schedule import trace_schedule
    from elastica_petsc.studies.trace import densify, paper_triangle, trace

    arm = load_config()
    points = densify(paper_triangle((400.0, 200.0)), args.step)
    with TipController(arm, n_elements=args.elements) as controller:
        trace(controller, points[:5])                       # warm-up (imports, first LU)

        def plain():
            return trace(controller, points)

        def with_bar():
            out = FakeTerminal()
            with Progress(len(points), "bench", stream=out, interval=args.interval) as bar:
                result = trace(controller, points, on_point=bar.update)
            return result, out.getvalue().count("\r")

        t_plain, t_bar, draws = [], [], []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            plain()
            t_plain.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            _, n = with_bar()
            t_bar.append(time.perf_counter() - t0)
            draws.append(n)
        t_sched = []
        for _ in range(max(1, args.repeat // 2)):
            t0 = time.perf_counter()
            planned = trace_schedule(controller, points, step_mm=args.step, speed_mm_s=5.0)
            t_sched.append(time.perf_counter() - t0)
    a, b, c = statistics.median(t_plain), statistics.median(t_bar), statistics.median(t_sched)
    print(f"path: {len(points)} points, {args.elements} elements, {args.repeat} repeats")
    print(f"| run | median [s] | ratio |\n|---|---|---|")
    print(f"| trace, no progress | {a:.3f} | 1.000 |")
    print(f"| trace, bar redrawn every {args.interval:g} s ({statistics.median(draws):.0f} "
          f"draws) | {b:.3f} | {b / a:.3f} |")
    print(f"| trace_schedule: approach ({planned.approach.n_points} points) + path + the "
          f"eigen solves of the suggested speed | {c:.3f} | {c / a:.3f} |")
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        write_trace(Path(tmp) / "vtk", arm, planned.path)
        t_vtk = time.perf_counter() - t0
        t0 = time.perf_counter()
        animate_trace(arm, planned.path, Path(tmp) / "a.gif", approach=planned.approach)
        t_gif = time.perf_counter() - t0
    print(f"| ParaView files ({planned.path.n_points} .vtu + .pvd), once | {t_vtk:.3f} | "
          f"{t_vtk / a:.3f} |")
    print(f"| GIF (150 frames), once | {t_gif:.3f} | {t_gif / a:.3f} |")
    gif_writers(arm, planned.path, max(1, args.repeat // 2))
    return 0


def gif_writers(arm, result, repeat: int) -> None:
    """Section 4: the same frames through both writers."""
    from matplotlib import animation

    from elastica_petsc.plots import animate as anim

    def matplotlib_writer(fig, draw, count, path, fps):
        movie = animation.FuncAnimation(fig, draw, frames=count, blit=False)
        movie.save(path, writer=animation.PillowWriter(fps=fps), dpi=anim.DPI)

    ours = anim._write_gif
    times = {"blitted frames, Pillow (ours)": [], "matplotlib FuncAnimation + PillowWriter": []}
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(repeat):
            for label, writer in zip(times, (ours, matplotlib_writer)):
                anim._write_gif = writer
                try:
                    t0 = time.perf_counter()
                    anim.animate_trace(arm, result, Path(tmp) / "w.gif", max_frames=40)
                    times[label].append(time.perf_counter() - t0)
                finally:
                    anim._write_gif = ours
    base = statistics.median(times["matplotlib FuncAnimation + PillowWriter"])
    print(f"\n| GIF writer, 40 frames | median [s] | ratio |\n|---|---|---|")
    for label, t in times.items():
        print(f"| {label} | {statistics.median(t):.3f} | {statistics.median(t) / base:.3f} |")


if __name__ == "__main__":
    sys.exit(main())
