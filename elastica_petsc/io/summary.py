"""Solved states as plain data with units: the JSON of the command line and
the text summaries.  Internally everything is non-dimensional (docs/model.md §3);
here lengths become mm, tensions both p = P l^2/B and newtons, energies
SE_0 = B/(2l) and joules.
"""
from __future__ import annotations

import numpy as np

from ..core.clearance import state_cable_clear
from ..solvers.equilibrium import Equilibrium
from ..core.model import Arm


def rounded(values, digits: int = 6) -> list:
    """A JSON-friendly list of floats."""
    return np.round(np.asarray(values, dtype=float), digits).tolist()


def equilibrium_summary(arm: Arm, eq: Equilibrium) -> dict:
    """The state of :class:`Equilibrium` in the user's units."""
    l_mm = arm.length_mm
    return {
        "converged": bool(eq.converged),
        "reason": eq.reason,
        "message": eq.message,
        "iterations": int(eq.iterations),
        "load_steps": int(eq.load_steps),
        "stable": bool(eq.stable),
        "unstable_modes": int(eq.unstable_modes),
        "snaps_at_tensions": [rounded(p) for p in eq.snaps],
        "bifurcations": [{"critical_tensions": rounded(b.p_critical, 8),
                          "critical_tensions_N": rounded(arm.tensions_to_N(b.p_critical), 8),
                          "side": b.side, "rule": b.rule} for b in eq.bifurcations],
        "elements": int(eq.disc.n_elements),
        "tensions": rounded(eq.p),
        "tensions_N": rounded(arm.tensions_to_N(eq.p)),
        "tip_mm": rounded(eq.tip * l_mm),
        "attachments_mm": [rounded(x * l_mm) for x in eq.attachments],
        "cable_lengths_mm": rounded(eq.cable_lengths * l_mm),
        "cable_directions": [rounded(d) for d in eq.directions],
        "cable_clear": [bool(c) for c in state_cable_clear(eq)],
        "strain_energy": round(eq.strain_energy, 6),
        "strain_energy_J": round(eq.strain_energy * arm.energy_scale_J, 6),
        "kappa_max": round(eq.kappa_max, 6),
        "kappa_limit": round(arm.kappa_limit, 6),
        "units": {"tensions": "P l^2/B", "tensions_N": "N", "tip_mm": "mm",
                  "strain_energy": "B/(2l)", "kappa_max": "l*kappa",
                  "cable_clear": "per tendon: the straight cable [x_i, r_i] does not cross the "
                                 "arm (core/clearance.py)"},
    }


def format_equilibrium(arm: Arm, summary: dict) -> str:
    """A readable multi-line report of :func:`equilibrium_summary`."""
    s = summary
    lines = []
    if s["converged"]:
        lines.append(f"converged: yes ({s['reason']}, {s['iterations']} Newton iterations, "
                     f"{s['load_steps']} load steps, {s['elements']} elements)")
    else:
        lines.append(f"converged: NO ({s['reason']}): {s['message']}")
    lines.append("stable under load control: " + (
        "yes" if s["stable"] else f"NO ({s['unstable_modes']} negative stiffness eigenvalue(s))"))
    for p in s["snaps_at_tensions"]:
        lines.append(f"note: the loading path snapped (limit point) at p = {p}")
    for b in s["bifurcations"]:
        lines.append("note: the loading path crossed a symmetric bifurcation (not a limit point) "
                     "at critical tensions p = (" + ", ".join(f"{v:.6g}" for v in
                                                            b["critical_tensions"])
                     + f") and took the {b['side']} branch: {b['rule']}")
    lines.append(f"tip: ({s['tip_mm'][0]:.3f}, {s['tip_mm'][1]:.3f}) mm")
    lines.append(f"{'tendon':>6} {'s [mm]':>8} {'p=Pl^2/B':>10} {'P [N]':>9} "
                 f"{'attachment [mm]':>22} {'cable [mm]':>11}")
    for i, tendon in enumerate(arm.tendons):
        x = s["attachments_mm"][i]
        lines.append(f"{i + 1:>6} {tendon.attach_mm:>8.1f} {s['tensions'][i]:>10.4f} "
                     f"{s['tensions_N'][i]:>9.4f} {f'({x[0]:.3f}, {x[1]:.3f})':>22} "
                     f"{s['cable_lengths_mm'][i]:>11.3f}")
    lines.append(f"strain energy: {s['strain_energy']:.4f} SE0 = {s['strain_energy_J']:.4f} J")
    lines.append(f"max curvature: l*kappa = {s['kappa_max']:.4f} "
                 f"(strain limit {s['kappa_limit']:.4g}, Eq. (19))")
    lines.extend(crossing_lines(s["cable_clear"]))
    return "\n".join(lines)


def crossing_lines(cable_clear) -> list[str]:
    """Warnings for cables whose straight segment crosses the arm."""
    return [f"WARNING: tendon {i}'s cable crosses the arm (a straight segment of the cable, "
            "between its routing point, guides and attachment, passes through the arm: not a "
            "physical state for a real cable)"
            for i, clear in enumerate(cable_clear, start=1) if not clear]


def stability_summary(arm: Arm, eq: Equilibrium, result, freqs: dict | None,
                      amplitude_mm: float) -> dict:
    """The stability of ``eq`` (SLEPc, Sec. 4.3 (ii)) in the user's units; with
    natural frequencies (``freqs``: control -> Frequencies) the suggested
    maximum tracing speed v = 2 pi f_1 * ``amplitude_mm``."""
    from ..solvers.stability import max_tracing_speed_mm_s

    eq_summary = equilibrium_summary(arm, eq)
    summary = {
        "equilibrium": eq_summary,
        "stable": bool(result.stable),
        "eigenvalues": rounded(result.eigenvalues, 8),
        "lambda_min": round(float(result.lambda_min), 8),
        "lambda_min_raw": float(f"{result.raw_min:.8g}"),
        "negative_eigenvalues": int(result.negative),
        "inertia_negative_eigenvalues": int(result.inertia_negative),
        "asymmetry": float(f"{result.asymmetry:.3g}"),
        "eps_reason": result.reason,
        "mass": result.mass,
        # bifurcations crossed on the way: where the smallest eigenvalue crossed zero
        "critical_loads_crossed": eq_summary["bifurcations"],
        "units": {"eigenvalues": "lambda l^2/B (K v = lambda M v, lumped mass)",
                  "lambda_min_raw": "lambda_min(K) / (B/l) at this mesh (paper Fig. 5b)"},
    }
    if freqs is not None:
        summary["frequencies_hz"] = {c: rounded(f.hz, 6) for c, f in freqs.items()}
        summary["max_tracing_speed_mm_s"] = round(
            max_tracing_speed_mm_s(freqs["load"].f1_hz, amplitude_mm), 4)
        summary["units"]["max_tracing_speed_mm_s"] = (
            f"2 pi f_1 (tensions held) x {amplitude_mm:g} mm tolerated vibration")
    return summary


def format_stability(arm: Arm, summary: dict) -> str:
    """The text that ``elastica-petsc stability`` prints."""
    lines = [format_equilibrium(arm, summary["equilibrium"]),
             f"\nstability (SLEPc, K v = lambda M v, lumped mass): "
             f"{'STABLE' if summary['stable'] else 'UNSTABLE'}",
             "  smallest eigenvalues lambda l^2/B: "
             + ", ".join(f"{v:.6g}" for v in summary["eigenvalues"]),
             f"  paper's raw lambda_min(K)/(B/l) at N = {summary['equilibrium']['elements']}: "
             f"{summary['lambda_min_raw']:.6g}",
             f"  negative eigenvalues: {summary['negative_eigenvalues']} (inertia count: "
             f"{summary['inertia_negative_eigenvalues']});  asymmetry ||K-K^T||/||K|| = "
             f"{summary['asymmetry']:.2e}"]
    for b in summary.get("critical_loads_crossed", []):
        lines.append("  critical load crossed on the way (smallest eigenvalue of K through zero, "
                     "a bifurcation): p_cr = (" + ", ".join(f"{v:.8g}" for v in
                                                          b["critical_tensions"])
                     + ") = (" + ", ".join(f"{v:.6g}" for v in b["critical_tensions_N"])
                     + f") N; the path continued on the {b['side']} buckled branch")
    for control, hz in summary.get("frequencies_hz", {}).items():
        held = "tensions held" if control == "load" else "cable lengths held"
        lines.append(f"  natural frequencies ({held}): " + ", ".join(f"{v:.4g}" for v in hz)
                     + " Hz")
    if "max_tracing_speed_mm_s" in summary:
        lines.append(f"  suggested max tracing speed: {summary['max_tracing_speed_mm_s']:.3g} "
                     f"mm/s ({summary['units']['max_tracing_speed_mm_s']})")
    return "\n".join(lines)


def replay_summary(path, trace: dict, result, *, tip_tol_mm: float, shape_tol: float) -> dict:
    """A replay under length control (``elastica-petsc replay``) in the user's
    units: the verdict, the jumps and instabilities met, and every point."""
    arm, K = trace["arm"], trace["K"]
    pts = result.points
    first_jump = next((q.index for q in pts if q.jumped), None)
    data = {
        "file": str(path),
        "elements": int(trace["elements"]),
        "points_planned": K,
        "points_replayed": len(pts),
        "completed": bool(result.completed),
        "all_on_branch": bool(result.all_on_branch),
        "first_departure": result.first_departure,
        "first_jump": first_jump,
        "max_tip_error_mm": float(f"{result.max_tip_error_mm:.6g}"),
        "start_method": result.start_method,
        "branch_criterion": (f"shape within {shape_tol:g} rad of the planned shape"
                             if trace["theta"] is not None else
                             f"tip within {tip_tol_mm:g} mm of the planned tip"),
        "jumps": [{"before_point": int(k), "lengths_mm": rounded(L)} for k, L in result.jumps],
        "instabilities": [{"before_point": int(k), "lengths_mm": rounded(L), "kind": kind}
                          for k, L, kind in result.instabilities],
        "unstable_points": [q.index for q in pts if q.state.converged and not q.stable],
        "units": {"lengths_mm": "mm", "tip_mm": "mm", "tip_error_mm": "mm",
                  "shape_error": "rad", "tensions": "P l^2/B", "tensions_N": "N"},
    }
    data["points"] = [_replay_point(q, arm, trace) for q in pts]
    return data


def _replay_point(q, arm: Arm, trace: dict) -> dict:
    """One replayed point of :func:`replay_summary`."""
    s = q.state
    entry = {"index": q.index, "lengths_mm": rounded(q.lengths_mm),
             "planned_tip_mm": rounded(q.planned_tip_mm), "tip_mm": rounded(s.tip_mm),
             "tip_error_mm": float(f"{q.tip_error_mm:.6g}"),
             "shape_error": None if q.shape_error is None else float(f"{q.shape_error:.6g}"),
             "on_branch": bool(q.on_branch), "jumped": bool(q.jumped),
             "converged": bool(s.converged),
             "stable": bool(s.converged and q.stable),
             "stable_under_load_control": bool(s.converged and s.stable),
             "tensions": rounded(s.p), "tensions_N": rounded(arm.tensions_to_N(s.p)),
             "slack_mm": rounded(np.where(s.slack_mm > 0, s.slack_mm, 0.0)),
             "message": s.message}
    if trace["tensions"] is not None:
        entry["planned_tensions"] = rounded(trace["tensions"][q.index])
    if trace["converged"] is not None:
        entry["planned_converged"] = bool(trace["converged"][q.index])
    return entry
