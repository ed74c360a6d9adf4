"""``elastica-petsc lengths``: equilibria for prescribed cable lengths (length control,
paper Sec. 4.6, Fig. 8; docs/model.md §4.7).

Without ``--all``: the equilibrium reached from the straight arm by continuation
in the cable lengths (a stable path; snaps and buckling are recorded).  With
``--all``: the multi-start deflated search of :func:`elastica_petsc.studies.search.length_equilibria`.

The helpers below (text report, plots) are shared with
``elastica-petsc equilibria`` (load control), which prints the same layout.

HDF5 layout (``--out``): :mod:`elastica_petsc.io.states`.
"""
from __future__ import annotations

import sys

from . import common

NOT_COMPLETE = ("These are the equilibria that the listed starts and methods reached; "
                "the list is not proven complete: other equilibria may exist.")


def add_search_options(parser) -> None:
    parser.add_argument("--effort", type=int, default=1, metavar="K",
                        help="spend about K times the default work: curves through every "
                             "state in K x 4 directions (two tendons), K x 12 deflated "
                             "continuation points per path segment, K x 2 deflated solves per "
                             "start, and the start tension levels doubled K-1 more times "
                             "(default 1)")
    common.add_tension_option(parser, "--levels", nargs="+",
                              help="tension levels of the load-controlled start states of the "
                                   "search: every combination, every loading order "
                                   "(default 5 10 20, extended by --effort)")
    parser.add_argument("--deflation-rounds", type=int, metavar="K",
                        help="deflated Newton solves per start and sweep (default 2 x effort)")
    common.add_max_seconds_option(parser, "the search")


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "lengths", help="equilibria for prescribed cable lengths (length control, Fig. 8)",
        description="Solve for the equilibrium of the arm when the cable lengths L_i (mm) "
                    "are prescribed, as in the paper's experiments (Sec. 4.6): the tensions "
                    "are unknowns, a cable longer than its chord is slack (tension 0). "
                    "Without --all: the equilibrium reached from the straight arm by "
                    "continuation in the cable lengths. With --all: a multi-start deflated "
                    "search for several equilibria (Fig. 8: two states share L = (147.1, "
                    "472.5) mm); what it finds is not proven to be everything. Each state is "
                    "reported with tensions, tip, cable lengths, slack, taut flags and its "
                    "stability under load and under length control.")
    parser.add_argument("--lengths", type=float, nargs="+", required=True, metavar="MM",
                        help="prescribed cable lengths L_i in mm, one per tendon")
    parser.add_argument("--all", action="store_true",
                        help="search for several equilibria (multi-start, continuation and "
                             "deflation) instead of following the straight arm")
    add_search_options(parser)
    add_vtk_option(parser)
    common.add_arm_options(parser)
    common.add_output_options(parser)
    parser.set_defaults(run=run)


def add_vtk_option(parser) -> None:
    parser.add_argument("--vtk", metavar="DIR",
                        help="write every state for ParaView: DIR/state_K.vtu (arm and cables, "
                             "K the state's number) and DIR/states.pvd listing them")


# --- validation ------------------------------------------------------------------------
def check_search_options(args) -> dict:
    """Validated search settings (studies.search.effort_settings) from the options."""
    from ..core.errors import InputError
    from ..core.inputs import integer, tensions
    from ..studies.search import effort_settings

    if args.deflation_rounds is not None:
        integer(args.deflation_rounds, "--deflation-rounds", 0, 1000)
    if args.levels is not None and not all(v > 0 for v in tensions(
            args.levels, len(args.levels), "--levels", "P l^2/B")):
        raise InputError("--levels: tension levels must be positive numbers")
    settings = effort_settings(args.effort, args.levels, name="--effort")
    if args.deflation_rounds is not None:
        settings["deflation_rounds"] = args.deflation_rounds
    return dict(settings, effort=args.effort, max_seconds=common.max_seconds(args))


# --- plain data ------------------------------------------------------------------------


def format_states(arm, data: dict) -> str:
    """Readable report of the JSON object of ``lengths`` / ``equilibria``."""
    search = data["search"]
    n = len(data["equilibria"])
    if data["control"] == "length":
        target = "cable lengths L = (" + ", ".join(f"{v:.10g}" for v in data["lengths_mm"]) \
            + ") mm"
    else:
        target = "tensions p = (" + ", ".join(f"{v:g}" for v in data["tensions"]) + ") = (" + \
            ", ".join(f"{v:.4g}" for v in data["tensions_N"]) + ") N"
    lines = [f"{n} equilibri{'um' if n == 1 else 'a'} at {target}",
             f"search: {search['method']}; {search['starts']} start(s), {search['attempts']} "
             f"attempt(s), {search['failed']} failed, {search['refound']} re-found a known state"]
    if "coverage" in search:
        cov = search["coverage"]
        lines.append("coverage: " + "; ".join(
            f"{m}: {v['attempts']} attempt(s), {v['new_states']} new"
            for m, v in cov["by_method"].items())
            + f"; the last new state came at attempt {cov['last_new_state_at_attempt']} of "
              f"{search['attempts']} (more effort: --effort)")
    other = "load" if data["control"] == "length" else "length"
    numbers = [s["number"] for s in data["equilibria"]]
    if numbers != list(range(1, n + 1)):
        lines.append("state numbers: the paper's (Fig. 8) for the states it shows, the others "
                     "after them")
    for s in data["equilibria"]:
        own = "yes" if s["stable"] else "NO"
        oth = s[f"stable_under_{other}_control"]
        oth = "yes" if oth else ("not computed" if oth is None else "NO")
        origin = ""
        if "found_from" in s:
            f = s["found_from"]
            origin = f"; first found from '{f['start']}' by {f['method']}, " \
                     f"reached {f['attempts_reaching_it']}x"
        lines.append("")
        lines.append(f"state {s['number']}{origin}")
        lines.append(f"  stable under {data['control']} control: {own}; "
                     f"under {other} control: {oth}  (negative stiffness eigenvalues load/length: "
                     f"{s['unstable_modes']}/{s['unstable_modes_length_control']})")
        lines.append(f"  tip: ({s['tip_mm'][0]:.3f}, {s['tip_mm'][1]:.3f}) mm;  strain energy "
                     f"{s['strain_energy']:.4f} SE0;  l*kappa_max {s['kappa_max']:.4f}")
        by_length = data["control"] == "length"
        lines.append(f"  {'tendon':>6} {'p=Pl^2/B':>10} {'P [N]':>9} {'cable [mm]':>11} "
                     + (f"{'L set [mm]':>11} {'slack [mm]':>11} " if by_length else "")
                     + f"{'taut':>5}")
        for i in range(len(s["tensions"])):
            lines.append(f"  {i + 1:>6} {s['tensions'][i]:>10.4f} {s['tensions_N'][i]:>9.4f} "
                         f"{s['cable_lengths_mm'][i]:>11.3f} "
                         + (f"{s['lengths_requested_mm'][i]:>11.3f} {s['slack_mm'][i]:>11.3f} "
                            if by_length else "")
                         + f"{'yes' if s['taut'][i] else 'no':>5}")
        for i, clear in enumerate(s["cable_clear"], start=1):
            if not clear:
                lines.append(f"  note: cable {i} crosses the arm (a straight cable through the "
                             "arm: this state needs a guide or is not physical; core/clearance.py)")
        if s["kappa_max"] > s["kappa_limit"]:
            lines.append(f"  note: l*kappa_max = {s['kappa_max']:.4g} exceeds the strain limit "
                         f"{s['kappa_limit']:.4g} (Eq. (19))")
        for L in s["jumps_at_lengths_mm"]:
            lines.append("  note: the continuation jumped (snap/buckling) at L = ("
                         + ", ".join(f"{v:.3f}" for v in L) + ") mm")
    lines.append("")
    if search.get("stopped"):
        lines.append(f"{search['stopped']}: these are the states found before the time "
                     "limit; the list may be incomplete (exit status 5).")
    lines.append(data["note"])
    return "\n".join(lines)


def plot(arm, data: dict, states, path, title: str) -> None:
    from ..plots.lengths import plot_states

    entries = []
    for state, s in zip(states, data["equilibria"]):
        stab = "stable" if s["stable"] else "UNSTABLE"
        label = (f"state {s['number']}: p = (" + ", ".join(f"{v:.1f}" for v in s["tensions"])
                 + "), L = (" + ", ".join(f"{v:.1f}" for v in s["cable_lengths_mm"])
                 + f") mm, {stab}")
        entries.append((state, label))
    circles = data["lengths_mm"] if data["control"] == "length" else None
    plot_states(arm, entries, path, title=title, circles_mm=circles,
                numbers=[s["number"] for s in data["equilibria"]])


def finish(args, arm, data: dict, states, kind: str, title: str) -> int:
    """Print, write, plot; exit 5 if the time budget stopped the search
    (TIME_LIMIT), else 1 if no state converged."""
    if args.json:
        common.print_json(args.command, data)
    else:
        print(format_states(arm, data))
    if args.out:
        from ..io.states import write_states
        write_states(args.out, args.overwrite, arm, data, states, kind)
    if args.plot and states:
        plot(arm, data, states, args.plot, title)
    if args.vtk and states:
        from ..io.vtk import write_states as write_vtk       # io.states.write_states: HDF5
        write_vtk(args.vtk, arm, states, numbers=[s["number"] for s in data["equilibria"]])
    if data["search"].get("stopped"):
        print(f"elastica-petsc: {data['search']['stopped']}: {len(states)} state(s) found "
              "before the time limit; the list may be incomplete", file=sys.stderr)
        return common.TIME_LIMIT_EXIT
    if not states:
        msg = data.get("message") or "no equilibrium converged"
        print(f"elastica-petsc: {msg}", file=sys.stderr)
        return 1
    return 0


# --- the command -----------------------------------------------------------------------
def run(args) -> int:
    from ..ui.progress import Progress
    from ..studies.search import follow_lengths, search_lengths
    from ..io.summaries import search_summary, state_summary
    from ..io.summary import rounded

    arm, disc = common.load_arm(args)
    from ..core.inputs import cable_lengths_mm
    L_mm = cable_lengths_mm(arm, args.lengths, "--lengths")
    settings = check_search_options(args)
    common.check_outputs(args)
    data = {"control": "length", "lengths_mm": rounded(L_mm), "elements": disc.n_elements}
    if args.all:
        with Progress(None, "lengths --all", unit="search steps") as bar:
            result = search_lengths(arm, L_mm, elements=disc.n_elements, effort=args.effort,
                                    levels=args.levels, deflation_rounds=args.deflation_rounds,
                                    progress=bar, max_seconds=settings["max_seconds"])
        states = [f.state for f in result.states]
        data["equilibria"] = [state_summary(arm, f.state, "length", f) for f in result.states]
        data["search"] = search_summary(result, settings)
        data["note"] = NOT_COMPLETE
    else:
        state = follow_lengths(arm, L_mm, elements=disc.n_elements,
                               max_seconds=settings["max_seconds"])
        states = [state] if state.converged else []
        data["equilibria"] = [state_summary(arm, s, "length") for s in states]
        data["search"] = {
            "method": "length continuation from the straight arm (stable path; snaps "
                      "and buckling recorded; past a critical point where the buckling "
                      "mode gives no stable state, the nearest stable state the curve "
                      "search finds there)",
            "starts": 1, "attempts": 1, "failed": 0 if state.converged else 1,
            "refound": 0, "start_labels": ["straight arm"],
            "found_from": [{"state": 1, "start": "straight arm",
                            "method": "continuation", "attempts_reaching_it": 1}]
            if state.converged else [],
            "complete": False}
        data["note"] = ("One equilibrium: the one reached from the straight arm by length "
                        "continuation. Others may share these cable lengths: --all searches "
                        "for them; the list is not proven complete.")
        if not state.converged:
            data["message"] = state.message
        if state.reason == "TIME_LIMIT":
            data["search"].update(outcome="TIME_LIMIT", stopped=state.message)
    title = ("Equilibria found at L = (" + ", ".join(f"{v:g}" for v in L_mm)
             + ") mm (length control)")
    return finish(args, arm, data, states, "length_equilibria", title)
