"""``elastica-petsc stability``: smallest stiffness eigenvalues at an equilibrium (Sec. 4.3 (ii))."""
from __future__ import annotations

import sys

from . import common


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "stability", help="stability of the equilibrium at given tensions (SLEPc eigenvalues)",
        description="Solve the equilibrium for given tensions (as `solve`), then compute with "
                    "SLEPc the smallest eigenvalues of K v = lambda M v (paper Sec. 4.3 (ii), "
                    "Fig. 5b): stable under load control iff all are positive. Reports "
                    "lambda l^2/B (mesh independent; pi^2/4 for the unloaded arm), the paper's "
                    "raw lambda_min(K)/(B/l), the measured asymmetry of K, and, when the "
                    "config gives mass_per_length_kg_m, the lowest natural frequencies and a "
                    "suggested maximum tracing speed.")
    common.add_tension_options(parser)
    common.add_order_option(parser)
    parser.add_argument("--modes", type=int, default=4, metavar="K",
                        help="number of eigenvalues/modes to compute (default 4)")
    parser.add_argument("--amplitude-mm", type=float, default=1.0, metavar="MM",
                        help="tolerated vibration amplitude for the tracing-speed rule "
                             "v_max = 2 pi f_1 * amplitude (default 1 mm)")
    common.add_arm_options(parser)
    common.add_output_options(parser)
    parser.set_defaults(run=run)


def run(args) -> int:
    from ..solvers.equilibrium import EquilibriumSolver
    from ..core.errors import InputError
    from ..solvers.stability import StabilitySolver, max_tracing_speed_mm_s
    from ..io.summary import equilibrium_summary, format_equilibrium, rounded

    if args.modes < 1:
        raise InputError(f"--modes must be at least 1, got {args.modes}")
    if not args.amplitude_mm > 0:
        raise InputError(f"--amplitude-mm must be positive, got {args.amplitude_mm}")
    arm, disc = common.load_arm(args)
    if args.modes > disc.n_elements:
        raise InputError(f"--modes must be at most {disc.n_elements} (the stiffness of "
                         f"{disc.n_elements} elements has {disc.n_elements} eigenvalues), "
                         f"got {args.modes}")
    common.check_outputs(args)
    with EquilibriumSolver(disc) as solver:
        eq = solver.solve(common.tensions(args, arm), order=common.order(args))
    if not eq.converged:
        print(f"elastica-petsc: solve failed: {eq.message}", file=sys.stderr)
        return 1
    with StabilitySolver(disc, nev=args.modes) as stab:
        result = stab.solve(eq.u, eq.p)
        freqs = None
        if arm.mass_per_length_kg_m is not None:
            freqs = {control: stab.frequencies(eq.u, eq.p, arm, control=control)
                     for control in ("load", "length")}
    summary = {
        "equilibrium": equilibrium_summary(arm, eq),
        "stable": bool(result.stable),
        "eigenvalues": rounded(result.eigenvalues, 8),
        "lambda_min": round(float(result.lambda_min), 8),
        "lambda_min_raw": float(f"{result.raw_min:.8g}"),
        "negative_eigenvalues": int(result.negative),
        "inertia_negative_eigenvalues": int(result.inertia_negative),
        "asymmetry": float(f"{result.asymmetry:.3g}"),
        "eps_reason": result.reason,
        "mass": result.mass,
        "units": {"eigenvalues": "lambda l^2/B (K v = lambda M v, lumped mass)",
                  "lambda_min_raw": "lambda_min(K) / (B/l) at this mesh (paper Fig. 5b)"},
    }
    if freqs is not None:
        f1 = freqs["load"].f1_hz
        summary["frequencies_hz"] = {c: rounded(f.hz, 6) for c, f in freqs.items()}
        summary["max_tracing_speed_mm_s"] = round(
            max_tracing_speed_mm_s(f1, args.amplitude_mm), 4)
        summary["units"]["max_tracing_speed_mm_s"] = (
            f"2 pi f_1 (tensions held) x {args.amplitude_mm:g} mm tolerated vibration")
    if args.json:
        common.print_json(summary)
    else:
        print(format_equilibrium(arm, summary["equilibrium"]))
        print(f"\nstability (SLEPc, K v = lambda M v, lumped mass): "
              f"{'STABLE' if result.stable else 'UNSTABLE'}")
        print("  smallest eigenvalues lambda l^2/B: "
              + ", ".join(f"{v:.6g}" for v in result.eigenvalues))
        print(f"  paper's raw lambda_min(K)/(B/l) at N = {disc.n_elements}: {result.raw_min:.6g}")
        print(f"  negative eigenvalues: {result.negative} (inertia count: "
              f"{result.inertia_negative});  asymmetry ||K-K^T||/||K|| = {result.asymmetry:.2e}")
        if freqs is not None:
            for control, f in freqs.items():
                held = "tensions held" if control == "load" else "cable lengths held"
                print(f"  natural frequencies ({held}): "
                      + ", ".join(f"{v:.4g}" for v in f.hz) + " Hz")
            print(f"  suggested max tracing speed: {summary['max_tracing_speed_mm_s']:.3g} mm/s "
                  f"({summary['units']['max_tracing_speed_mm_s']})")
    if args.out:
        from ..io.hdf5 import atomic_h5, provenance, put, write_attrs, write_equilibrium
        with atomic_h5(args.out, args.overwrite) as fh:
            write_attrs(fh, provenance(arm, "stability"))
            write_equilibrium(fh, arm, eq)
            g = fh.create_group("stability")
            put(g, "eigenvalues", result.eigenvalues, "B/l^2", "lambda l^2/B, smallest first")
            put(g, "modes", result.modes, "rad", "theta part of the eigenvectors (N+1 nodes)")
            put(g, "lambda_min_raw", result.raw_min, "B/l", "lambda_min(K) at this mesh")
            put(g, "asymmetry", result.asymmetry, "1", "||K - K^T|| / ||K|| (probe estimate)")
            if freqs is not None:
                for control, f in freqs.items():
                    put(g, f"frequencies_{control}_hz", f.hz, "Hz",
                        f"natural frequencies, control={control}")
    if args.plot:
        plot_modes(arm, eq, result, args.plot)
    return 0


def plot_modes(arm, eq, result, path) -> None:
    """Equilibrium and its lowest modes (as perturbations of the shape)."""
    import numpy as np

    from ..plots.common import draw_arm, draw_setting, figure, finish_geometry, save

    fig, (ax, ax2) = figure(ncols=2, figsize=(12, 5))
    draw_setting(ax, arm)
    draw_arm(ax, arm, eq, label="equilibrium")
    finish_geometry(ax, "Equilibrium")
    s = np.linspace(0, arm.length_mm, eq.disc.n_elements + 1)
    for k, (lam, mode) in enumerate(zip(result.eigenvalues, result.modes)):
        ax2.plot(s, mode, label=f"mode {k + 1}: lambda l^2/B = {lam:.4g}")
    ax2.axhline(0, color="0.7", lw=0.8)
    ax2.set_xlabel("arc length s [mm]")
    ax2.set_ylabel("mode shape (theta, max-normalised)")
    ax2.set_title("Lowest stiffness modes")
    ax2.legend(fontsize=8)
    save(fig, path)
