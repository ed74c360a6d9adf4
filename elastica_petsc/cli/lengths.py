"""``elastica-petsc lengths``: equilibria for prescribed cable lengths (length control,
paper Sec. 4.6, Fig. 8; docs/model.md §4.7).

Without ``--all``: the equilibrium reached from the straight arm by continuation
in the cable lengths (a stable path; snaps and buckling are recorded).  With
``--all``: the multi-start deflated search of :func:`elastica_petsc.studies.search.length_equilibria`.

The helpers below (state summaries, text report, HDF5 layout) are shared with
``elastica-petsc equilibria`` (load control), which prints the same layout.

HDF5 layout (``--out``), besides the provenance attributes of every file::

    target/lengths_mm        (n,)  mm        prescribed cable lengths   (lengths)
    target/tensions          (n,)  P l^2/B   prescribed tensions        (equilibria)
    target/tensions_N        (n,)  N
    equilibria/state_K/...   one group per state K (the paper's numbers for Fig. 8's
                             states, see studies.search.state_numbers): the layout of io.hdf5.write_equilibrium
                             plus tendons/lengths_requested (mm), tendons/slack (mm),
                             tendons/taut (1); solver attributes also hold
                             length_unstable_modes, stable_under_length_control,
                             found_start, found_method, hits
    root attributes          control, n_equilibria, state_numbers, search_* (method, starts,
                             attempts, failed, refound, start_labels_json, coverage_json,
                             effort_json), note
"""
from __future__ import annotations

import math
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
def check_lengths_mm(values, n_tendons: int):
    import numpy as np

    from ..core.errors import InputError

    L = np.asarray(values, dtype=float).ravel()
    if L.size != n_tendons:
        raise InputError(f"--lengths: expected {n_tendons} cable lengths in mm (one per "
                         f"tendon), got {L.size}")
    for i, v in enumerate(L, 1):
        if not (math.isfinite(v) and v > 0):
            raise InputError(f"--lengths: cable length of tendon {i} must be a positive "
                             f"number of mm, got {v:g}")
    return L


def check_search_options(args) -> dict:
    """Validated search settings (studies.search.effort_settings) from the options."""
    from ..core.errors import InputError
    from ..studies.search import effort_settings

    if args.effort < 1:
        raise InputError(f"--effort must be an integer >= 1, got {args.effort}")
    if args.deflation_rounds is not None and args.deflation_rounds < 0:
        raise InputError(f"--deflation-rounds must be >= 0, got {args.deflation_rounds}")
    if args.levels is not None and not all(math.isfinite(v) and v > 0 for v in args.levels):
        raise InputError("--levels: tension levels must be positive numbers")
    settings = effort_settings(args.effort, args.levels)
    if args.deflation_rounds is not None:
        settings["deflation_rounds"] = args.deflation_rounds
    return dict(settings, effort=args.effort)


# --- plain data ------------------------------------------------------------------------
def state_summary(arm, state, control: str, found=None) -> dict:
    """One equilibrium (a LengthEquilibrium) in the user's units.  ``stable`` is
    the stability under the command's own control (length or load)."""
    import numpy as np

    from ..io.summary import equilibrium_summary, rounded

    l_mm = arm.length_mm
    s = equilibrium_summary(arm, state)
    length_modes = int(getattr(state, "length_unstable_modes", -1))
    by_length = None if length_modes < 0 else length_modes == 0
    slack = np.asarray(state.slack_mm, float)
    slack = np.where(slack > 0.0, slack, 0.0)
    s.update({
        "stable_under_load_control": bool(state.stable),
        "stable_under_length_control": by_length,
        "unstable_modes_length_control": length_modes,
        "stable": by_length if control == "length" else bool(state.stable),
        "stability_control": control,
        "lengths_requested_mm": rounded(state.lengths_requested * l_mm),
        "slack_mm": rounded(slack),
        "taut": [bool(t) for t in state.taut],
        "jumps_at_lengths_mm": [rounded(np.asarray(L) * l_mm) for L in state.jumps],
        "instabilities_at_lengths_mm": [rounded(np.asarray(L) * l_mm)
                                        for L in state.instabilities],
    })
    s["number"] = int(found.number) if found is not None and found.number else 1
    if found is not None:
        s["found_from"] = {"start": found.start, "method": found.method,
                           "attempts_reaching_it": int(found.hits)}
    s["units"].update({"slack_mm": "mm", "lengths_requested_mm": "mm",
                       "cable_lengths_mm": "mm"})
    return s


def search_summary(result, settings: dict) -> dict:
    """How a SearchResult was obtained, and its coverage."""
    what = "cable lengths" if result.control == "length" else "tensions"
    how = "length continuation" if result.control == "length" else "loading paths"
    method = (f"deflated continuation in the {what} from the straight arm along every "
              f"loading order ({settings['steps']} points per segment; Farrell et al. 2016), "
              f"then a multi-start search: {how} and up to {settings['deflation_rounds']} "
              "deflated Newton solves (Farrell et al. 2015) from each start (load-controlled "
              "states at the tension levels " + " ".join(f"{v:g}" for v in settings["levels"])
              + " in every loading order, and any branch the continuation lost)")
    if result.control == "load":
        method = ("loading paths from the straight arm (every order, both sides of each "
                  "bifurcation), " + method)
    if settings["effort"] > 1:
        method += (f"; effort {settings['effort']}: the searches of every lower effort first, "
                   "then this one (the numbers above are its own)")
    if result.curves:
        method = result.curve_method() + "; around it (its curves also followed from the "\
            "states these add): " + method
    return {"method": method, "effort": settings,
            "coverage": {"by_method": {m: {"attempts": a, "new_states": k}
                                       for m, (a, k) in result.methods().items()},
                         "last_new_state_at_attempt": result.last_new_attempt,
                         "curves": dict(result.curves)},
            "starts": len(result.starts), "attempts": int(result.attempts),
            "failed": int(result.failures), "refound": int(result.duplicates),
            "start_labels": list(result.starts),
            "found_from": [{"state": f.number, "start": f.start, "method": f.method,
                            "attempts_reaching_it": int(f.hits)}
                           for f in result.states],
            "complete": False}


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
    lines.append(data["note"])
    return "\n".join(lines)


# --- HDF5 ------------------------------------------------------------------------------
def write_states(path, overwrite: bool, arm, data: dict, states, kind: str) -> None:
    import json

    from ..io.hdf5 import atomic_h5, provenance, put, write_attrs, write_equilibrium

    l_mm = arm.length_mm
    with atomic_h5(path, overwrite) as fh:
        write_attrs(fh, provenance(arm, kind))
        search = data["search"]
        write_attrs(fh, {"control": data["control"], "n_equilibria": len(states),
                         "elements": int(data["elements"]),
                         "search_method": search["method"], "search_starts": search["starts"],
                         "search_attempts": search["attempts"], "search_failed": search["failed"],
                         "search_refound": search["refound"],
                         "search_start_labels_json": json.dumps(search["start_labels"]),
                         "search_coverage_json": json.dumps(search.get("coverage", {})),
                         "search_effort_json": json.dumps(search.get("effort", {})),
                         "search_complete": False, "note": data["note"],
                         "state_numbers": [int(s["number"]) for s in data["equilibria"]]})
        target = fh.create_group("target")
        if data["control"] == "length":
            put(target, "lengths_mm", data["lengths_mm"], "mm", "prescribed cable lengths L_i",
                ("tendon",))
        else:
            put(target, "tensions", data["tensions"], "P l^2/B", "prescribed tensions p_i",
                ("tendon",))
            put(target, "tensions_N", data["tensions_N"], "N", "prescribed tensions P_i",
                ("tendon",))
        group = fh.create_group("equilibria")
        for state, summary in zip(states, data["equilibria"]):
            g = group.create_group(f"state_{summary['number']}")
            write_equilibrium(g, arm, state)
            put(g["tendons"], "lengths_requested", state.lengths_requested * l_mm, "mm",
                "prescribed cable lengths L_i (load control: the state's own chords)", ("tendon",))
            put(g["tendons"], "slack", summary["slack_mm"], "mm",
                "L_i - |r_i - x_i| (> 0: slack cable, tension 0)", ("tendon",))
            put(g["tendons"], "taut", summary["taut"], "1", "cable carries tension", ("tendon",))
            solver = g["solver"]
            write_attrs(solver, {
                "length_unstable_modes": int(summary["unstable_modes_length_control"]),
                "stable_under_length_control": bool(summary["stable_under_length_control"]),
                "stable_under_load_control": bool(summary["stable_under_load_control"])})
            if "found_from" in summary:
                f = summary["found_from"]
                write_attrs(solver, {"found_start": f["start"], "found_method": f["method"],
                                     "hits": int(f["attempts_reaching_it"])})


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
    """Print, write, plot; exit 1 if no state converged."""
    if args.json:
        common.print_json(args.command, data)
    else:
        print(format_states(arm, data))
    if args.out:
        write_states(args.out, args.overwrite, arm, data, states, kind)
    if args.plot and states:
        plot(arm, data, states, args.plot, title)
    if args.vtk and states:
        from ..io.vtk import write_states as write_vtk       # write_states: the HDF5 above
        write_vtk(args.vtk, arm, states, numbers=[s["number"] for s in data["equilibria"]])
    if not states:
        msg = data.get("message") or "no equilibrium converged"
        print(f"elastica-petsc: {msg}", file=sys.stderr)
        return 1
    return 0


# --- the command -----------------------------------------------------------------------
def run(args) -> int:
    from ..core.progress import Progress
    from ..studies.search import follow_lengths, search_lengths
    from ..io.summary import rounded

    arm, disc = common.load_arm(args)
    L_mm = check_lengths_mm(args.lengths, disc.n_tendons)
    common.check_cable_lengths(arm, L_mm)
    settings = check_search_options(args)
    common.check_outputs(args)
    data = {"control": "length", "lengths_mm": rounded(L_mm), "elements": disc.n_elements}
    if args.all:
        with Progress(None, "lengths --all", unit="search steps") as bar:
            result = search_lengths(arm, L_mm, elements=disc.n_elements, effort=args.effort,
                                    levels=args.levels, deflation_rounds=args.deflation_rounds,
                                    progress=bar)
        states = [f.state for f in result.states]
        data["equilibria"] = [state_summary(arm, f.state, "length", f) for f in result.states]
        data["search"] = search_summary(result, settings)
        data["note"] = NOT_COMPLETE
    else:
        state = follow_lengths(arm, L_mm, elements=disc.n_elements)
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
    title = ("Equilibria found at L = (" + ", ".join(f"{v:g}" for v in L_mm)
             + ") mm (length control)")
    return finish(args, arm, data, states, "length_equilibria", title)
