"""``elastica-petsc calibrate``: fit the arm's parameters to measured states
(issue 23; docs/model.md §14).

    elastica-petsc calibrate --config arm.toml --data data.csv \\
        --vary bending_stiffness tendon1.route tendon2.route --out fitted.toml

Prints each parameter with its standard deviation, the combinations the data
cannot determine, residual statistics and cross-validation; writes the fitted
arm (--out, TOML), an HDF5 record (--h5) and a figure (--plot).  Bad input
(data columns, parameter names, bounds, too few rows): one line, exit 2,
nothing written.  Exit 1 if the fit did not converge or a row's equilibrium
could not be reached.
"""
from __future__ import annotations

import sys

from . import common

PARAMETER_HELP = ("bending_stiffness, tendonK.route, motorK.offset, motor.spool_radius, "
                  "clamp.angle, clamp.position, frame.rotation, frame.offset")


def add_parser(sub) -> None:
    parser = sub.add_parser(
        "calibrate", help="fit the arm to measured tips (exact Jacobians, uncertainties)",
        description="Fit parameters of the arm to measured static states (a CSV: tensions "
                    "tension_K_N or motor positions length_K_mm / steps_K, measured tip "
                    "tip_x_mm, tip_y_mm, optional markers marker_S_x_mm, marker_S_y_mm and "
                    "loading order) by TAO BRGN with exact Jacobians, and report standard "
                    "deviations, correlations, what the data cannot determine, residuals "
                    "and cross-validation.")
    parser.add_argument("--data", required=True, metavar="CSV", help="measured states")
    parser.add_argument("--vary", required=True, nargs="+", metavar="NAME",
                        help=f"parameters to fit: {PARAMETER_HELP}")
    parser.add_argument("--bounds", nargs="+", metavar="NAME=LO:HI", default=[],
                        help="bounds of varied scalars, e.g. tendon1.route.x=30:60 "
                             "(defaults: docs/model.md §14)")
    parser.add_argument("--input", choices=("tension", "length", "steps"),
                        help="read only this input group (e.g. of a schedule CSV)")
    parser.add_argument("--huber", type=float, metavar="MM",
                        help="robust fit: Huber loss with this threshold [mm]")
    parser.add_argument("--method", choices=("brgn", "pounders"), default="brgn",
                        help="TAO BRGN with the exact Jacobian (default) or POUNDERS "
                             "(derivative-free, a check; slower)")
    parser.add_argument("--folds", type=int, default=5, metavar="K",
                        help="k-fold cross-validation (0: none; default 5)")
    parser.add_argument("--candidates", metavar="CSV",
                        help="candidate commands (inputs only): propose the next measurements "
                             "(D-optimal)")
    parser.add_argument("--next", type=int, default=5, metavar="K",
                        help="how many next measurements to propose (default 5)")
    common.add_arm_options(parser)
    parser.add_argument("--out", metavar="TOML", help="write the fitted arm to this TOML file")
    parser.add_argument("--h5", metavar="H5", help="write the full record to this HDF5 file")
    parser.add_argument("--plot", metavar="PNG", help="draw measured vs predicted tips")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--overwrite", action="store_true", help="replace existing outputs")
    parser.add_argument("--quiet", action="store_true", help="no progress lines")
    parser.set_defaults(run=run)


def check_options(args) -> None:
    from ..core.errors import InputError
    from ..io.hdf5 import H5_SUFFIXES, PLOT_SUFFIXES, check_distinct, check_output_path

    if args.huber is not None and not args.huber > 0:
        raise InputError(f"--huber must be a positive number of mm, got {args.huber}")
    if args.folds < 0 or args.folds == 1:
        raise InputError(f"--folds must be 0 (none) or at least 2, got {args.folds}")
    if args.next < 1:
        raise InputError(f"--next must be at least 1, got {args.next}")
    paths = {}
    for option, path, suffixes in (("--out", args.out, (".toml",)), ("--h5", args.h5, H5_SUFFIXES),
                                   ("--plot", args.plot, PLOT_SUFFIXES)):
        if path is not None:
            check_output_path(path, args.overwrite, suffixes, option)
            paths[option] = path
    check_distinct(paths)


# how the library's messages name the options on the command line
FLAGS = {"vary": "--vary", "bounds": "--bounds", "input": "--input"}


def run(args) -> int:
    from ..core.calibration_data import read_calibration_csv
    from ..core.calibration_params import ParameterModel, parse_bounds
    from ..ui.progress import Progress
    from ..solvers.calibration import RowError
    from ..studies.calibrate import CalibrationProblem
    from ..studies.calibrate_attach import calibrate_with_attachments, split_attach_names

    arm, disc = common.load_arm(args)
    data = read_calibration_csv(args.data, arm.n_tendons, args.input, arm.length_mm,
                                options=FLAGS)
    candidates = (read_calibration_csv(args.candidates, arm.n_tendons, args.input,
                                       arm.length_mm, measured=False, options=FLAGS)
                  if args.candidates else None)
    bounds = parse_bounds(args.bounds, FLAGS)
    continuous, _ = split_attach_names(args.vary, arm, FLAGS)   # tendonK.attach: searched
    model = ParameterModel(arm, continuous, bounds, FLAGS)
    CalibrationProblem(model, data, disc.n_elements)          # too few rows: refused here
    check_options(args)
    comm = world()
    root = comm is None or comm.rank == 0
    with Progress(None, "calibrate", unit="stages") as bar:
        try:
            result = calibrate_with_attachments(
                arm, data, args.vary, bounds=bounds, names=FLAGS, elements=disc.n_elements,
                huber_mm=args.huber, folds=args.folds, candidates=candidates,
                next_count=args.next, progress=bar, comm=comm, method=args.method)
        except RowError as err:
            bar.close()
            if root:
                print(f"elastica-petsc: error: calibration stopped: {err}", file=sys.stderr)
            return 1
    return finish(args, result, root)


def world():
    """MPI.COMM_WORLD under mpiexec with more than one rank, else None."""
    from mpi4py import MPI

    return MPI.COMM_WORLD if MPI.COMM_WORLD.size > 1 else None


def finish(args, result, root: bool = True) -> int:
    """Write and print on rank 0 (every rank holds the same result)."""
    from ..io.calibration import write_calibration_h5, write_fitted_toml

    summary = result.summary()
    summary["ranks"] = result.ranks
    converged = summary["converged"] = summary["solver"]["converged"]
    if not root:
        return 0 if converged else 1
    if args.out:
        write_fitted_toml(args.out, result, args.overwrite)
    if args.h5:
        write_calibration_h5(args.h5, result, args.overwrite)
    if args.plot:
        from ..plots.calibrate import plot_calibration
        plot_calibration(result, args.plot)
    if args.json:
        common.print_json("calibrate", summary)
    else:
        print_summary(summary)
    return 0 if converged else 1


def print_summary(s: dict) -> None:
    print("Calibration: parameter = value +- one standard deviation (start)")
    for p in s["parameters"]:
        sd = "undetermined" if p["sigma"] is None else f"+- {p['sigma']:.4g}"
        print(f"  {p['name']:20s} = {p['value']:.6g} {sd} {p['unit']} (start {p['start']:.6g})")
    for a in s.get("attachments") or ():
        sd = "undetermined" if a["sigma"] is None else f"+- {a['sigma']:.3g}"
        print(f"  {a['name']:20s} = {a['value']:.6g} {sd} mm (node search, resolution "
              f"{a['resolution_mm']:.3g} mm; {len(a['profile_mm2'])} nodes tried)")
    if s["undetermined_combinations"]:
        print("The data cannot determine:")
        for words in s["undetermined_combinations"]:
            print(f"  {words}")
    r = s["residual"]
    print(f"Residuals: RMS {r['rms_mm']:.4g} mm, max {r['max_mm']:.4g} mm "
          f"(noise estimate {r['sigma_mm']:.3g} mm per coordinate, {r['dof']} dof)")
    cv = s["cross_validation"]
    if cv:
        print(f"Cross-validation ({cv['folds']} folds): " + (
            cv["error"] if "error" in cv else
            f"RMS {cv['rms_mm']:.4g} mm, max {cv['max_mm']:.4g} mm on left-out rows"))
    matched = [row for row in s["rows"] if row["branch"].startswith("matched") and
               row["branch"] != "matched: proportional"]
    for row in matched:
        print(f"  line {row['line']}: branch {row['branch']}")
    if s["down_weighted_lines"]:
        print("Down-weighted by the Huber loss: lines "
              + ", ".join(map(str, s["down_weighted_lines"])))
    sv = s["solver"]
    print(f"TAO {sv['method'].upper()}: {sv['tao_reason']} after {sv['iterations']} iterations "
          f"({sv['evaluations']} evaluations, {sv['seconds']:.3g} s); remaining step "
          f"{sv['remaining_step_sigma']:.2g} sigma")
    if not sv["converged"]:
        print(f"Not converged: the Gauss-Newton step still to go is {sv['remaining_step_sigma']:.2g} "
              "standard deviations" + (f"; {sv['failed_trial_points']} trial points had a row "
                                       "without an equilibrium (a row near a fold or snap limits "
                                       "the steps)" if sv["failed_trial_points"] else ""))
    for k, nxt in enumerate(s.get("next_measurements") or (), start=1):
        print(f"  next measurement {k}: candidate line {nxt['line']} ({nxt['kind']} "
              f"{nxt['inputs']}), log det gain {nxt['log_det_gain']:.3g}")
