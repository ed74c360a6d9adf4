"""``elastica-petsc replay``: step the length-controlled arm through a traced path
(paper Sec. 4.6: computed under load control, realised under length control).

Reads the HDF5 file written by ``elastica-petsc trace --out``: root attributes
``kind`` = "trace", ``config_json`` (the arm), ``elements``; datasets
``path/cable_lengths`` (K, n) mm and ``path/tip`` (K, 2) mm (required),
``path/tensions`` (K, n) P l^2/B, ``path/theta`` (K, N+1) rad,
``path/target`` (K, 2) mm, ``path/converged`` (K,) (used when present).
The first point is reached from the straight arm (through the load-controlled
state at the first planned tensions when they are given), every further one
by continuation in the cable lengths from the previous one
(:func:`elastica_petsc.studies.replay.replay`).

HDF5 layout (``--out``)::

    planned/cable_lengths (K, n) mm, planned/tip (K, 2) mm, planned/tensions (K, n) P l^2/B
    replay/index (k,) 1, replay/tip (k, 2) mm, replay/tip_error (k,) mm,
    replay/shape_error (k,) rad (NaN without planned shapes), replay/on_branch,
    replay/jumped, replay/stable, replay/converged (k,) 1, replay/tensions (k, n),
    replay/tensions_N (k, n) N, replay/theta (k, N+1) rad
    jumps/before_point (j,) 1, jumps/lengths (j, n) mm
    instabilities/before_point (i,) 1, instabilities/lengths (i, n) mm,
    instabilities/kind (i,) strings: "bifurcation" or "limit point"
"""
from __future__ import annotations

import sys

from . import common


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "replay", help="replay a traced path under length control (Sec. 4.6)",
        description="Read a path traced under load control (`elastica-petsc trace --out "
                    "FILE.h5`) and step the length-controlled model through its cable lengths, "
                    "starting from the straight arm, as the experiments do. Reports per point "
                    "the replayed tip, its distance from the planned tip, whether the arm "
                    "stayed on the planned branch, its stability under length control, and "
                    "the first jump (snap or buckling), if any.")
    parser.add_argument("trace", metavar="TRACE.h5", help="HDF5 file written by "
                                                          "`elastica-petsc trace --out`")
    parser.add_argument("--tip-tol-mm", type=float, default=1e-3, metavar="MM",
                        help="a point without a planned shape is on the branch if its tip is "
                             "within this distance of the planned tip (default 1e-3 mm)")
    parser.add_argument("--shape-tol", type=float, default=1e-3, metavar="RAD",
                        help="a point is on the branch if no nodal angle differs from the "
                             "planned shape by more (default 1e-3 rad)")
    parser.add_argument("--first-by-lengths", action="store_true",
                        help="reach the first point by length continuation from the straight "
                             "arm (default: through the load-controlled state at the first "
                             "planned tensions, when the file has them)")
    common.add_output_options(parser)
    parser.set_defaults(run=run)


def run(args) -> int:
    import numpy as np

    from ..core.errors import InputError
    from ..ui.progress import Progress
    from ..studies.replay import replay_trace
    from ..io.replay import read_trace, write_replay
    from ..io.summary import replay_summary

    for name in ("tip_tol_mm", "shape_tol"):
        if not getattr(args, name) > 0:
            raise InputError(f"--{name.replace('_', '-')} must be positive")
    trace = read_trace(args.trace)
    common.check_outputs(args)
    arm, K = trace["arm"], trace["K"]
    with Progress(K, "replay") as bar:
        result = replay_trace(trace, first_by_lengths=args.first_by_lengths,
                              tip_tol_mm=args.tip_tol_mm, shape_tol=args.shape_tol,
                              on_point=bar.update)
    pts = result.points
    data = replay_summary(args.trace, trace, result, tip_tol_mm=args.tip_tol_mm,
                          shape_tol=args.shape_tol)
    if args.json:
        common.print_json(args.command, data)
    else:
        print(format_replay(data, result.summary()))
    if args.out:
        write_replay(args.out, args.overwrite, arm, trace, result)
    if args.plot:
        from ..plots.lengths import plot_replay
        plot_replay(arm, {"planned_tip": trace["tip"], "target": trace["target"],
                          "tip": np.array([q.state.tip_mm for q in pts]).reshape(-1, 2),
                          "tip_error": [q.tip_error_mm for q in pts],
                          "shape_error": None if trace["theta"] is None
                          else [q.shape_error for q in pts],
                          "on_branch": [q.on_branch for q in pts],
                          "jumped": [q.jumped for q in pts],
                          "stable": [q.state.converged and q.stable for q in pts],
                          "criterion": "tip" if trace["theta"] is None else "shape",
                          "tol": args.tip_tol_mm if trace["theta"] is None else args.shape_tol,
                          "last_state": pts[-1].state if pts and pts[-1].state.converged
                          else None},
                    args.plot, title=f"Replay under length control of {args.trace}")
    if not result.completed:
        last = pts[-1].state.message if pts else ""
        print(f"elastica-petsc: replay stopped after {len(pts)} of {K} points: {last}",
              file=sys.stderr)
        return 1
    return 0


SHOWN_AT_ENDS = 3


def format_replay(data: dict, summary: str) -> str:
    lines = [summary, f"on-branch criterion: {data['branch_criterion']}"]
    if data["first_jump"] is not None:
        lines.append(f"first jump (snap/buckling): before point {data['first_jump']}")
    lines.append(f"{'point':>5} {'L [mm]':>20} {'planned tip [mm]':>20} {'replayed tip [mm]':>20} "
                 f"{'error [mm]':>10} {'p':>18} {'branch':>6} {'stable':>6} {'jump':>4}")
    points = data["points"]
    if len(points) > 2 * SHOWN_AT_ENDS + 1:      # long path: both ends and every event
        shown = [e for e in points if e["index"] < SHOWN_AT_ENDS
                 or e["index"] >= len(points) - SHOWN_AT_ENDS
                 or not e["on_branch"] or e["jumped"] or not e["stable"]]
        lines.insert(1, f"(table: first and last {SHOWN_AT_ENDS} points and every point off "
                        "the branch, unstable or after a jump; all points in --json/--out)")
    else:
        shown = points
    for e in shown:
        L = "(" + ", ".join(f"{v:.3f}" for v in e["lengths_mm"]) + ")"
        pt = f"({e['planned_tip_mm'][0]:.3f}, {e['planned_tip_mm'][1]:.3f})"
        t = f"({e['tip_mm'][0]:.3f}, {e['tip_mm'][1]:.3f})"
        p = "(" + ", ".join(f"{v:.3f}" for v in e["tensions"]) + ")"
        lines.append(f"{e['index']:>5} {L:>20} {pt:>20} {t:>20} {e['tip_error_mm']:>10.2e} "
                     f"{p:>18} {'yes' if e['on_branch'] else 'NO':>6} "
                     f"{'yes' if e['stable'] else 'NO':>6} {'YES' if e['jumped'] else '':>4}")
    return "\n".join(lines)
