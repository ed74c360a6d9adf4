"""The paper end to end (``elastica-petsc reproduce``).

Each experiment is a thin layer over the library that the subcommands use
(no second implementation): it writes its HDF5 file and figures into the
output folder and returns rows for ``REPORT.md`` — every number of docs/model.md §6,
the paper's value beside ours, the difference and a sentence where they
differ.  ``quick`` uses coarse grids (tracing step 5 mm, workspace spacing
50 mm); the full run uses the paper's resolution (180 elements, 1 mm steps,
about 4201 workspace targets).
"""
from __future__ import annotations

import datetime
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import __version__
from .core import jsontext
from .core.model import load_config
from .core.model import Arm

PAPER_P = np.array([25.2, 10.8])                # Fig. 8 tensions
FIG8_LENGTHS_MM = np.array([147.1, 472.5])     # Fig. 8 states 1 and 2
FIG2_TARGET_MM = np.array([535.8, 222.6])
TRIANGLE_CENTER_MM = (400.0, 200.0)            # our choice: the paper gives no coordinates
CURVE_CENTER_MM = (420.0, 190.0)
FULL_SPACING_MM = 11.67                        # 4202 targets in the half-disc y >= 0, |x| <= l


@dataclass
class Row:
    figure: str
    item: str
    paper: str
    ours: str
    difference: str = ""
    note: str = ""


@dataclass
class Context:
    arm: Arm
    out: Path
    quick: bool
    jobs: int
    comm: object
    rows: list = field(default_factory=list)
    files: dict = field(default_factory=dict)      # figure -> [file names]
    traces: dict = field(default_factory=dict)     # name -> TraceResult
    seconds: dict = field(default_factory=dict)
    command: str = "elastica-petsc reproduce"
    checkpoint_seconds: float | None = None        # None: the library's default
    placement: object = None                       # studies/placement.py: where experiments go

    @property
    def place(self):
        """The experiments' targets on this arm (the paper's on the paper's arm)."""
        if self.placement is None:
            from .studies.placement import Placement, placement
            paper = Placement(FIG2_TARGET_MM, TRIANGLE_CENTER_MM, CURVE_CENTER_MM, 1.0,
                              FIG8_LENGTHS_MM)
            targets = reached = None
            ws = self.out / "fig4_workspace.h5"
            if ws.exists():
                from .plots.workspace import read_workspace
                from .studies.workspace import Status
                data = read_workspace(ws)
                targets, reached = data["target"], data["status"] == Status.REACHED
            self.placement = placement(self.arm, paper, PAPER_P, targets, reached)
        return self.placement

    @property
    def trace_step_mm(self) -> float:
        return 5.0 if self.quick else 1.0

    @property
    def spacing_mm(self) -> float:
        """The paper's spacing, scaled with the arm's length (a user arm: l/600 mm)."""
        return (50.0 if self.quick else FULL_SPACING_MM) * self.arm.length_mm / 600.0

    def path(self, name: str, figure: str) -> Path:
        self.files.setdefault(figure, []).append(name)
        return self.out / name

    def add(self, *args, **kw) -> None:
        self.rows.append(Row(*args, **kw))


def _fmt(values, digits: int = 1) -> str:
    return "(" + ", ".join(f"{v:.{digits}f}" for v in np.atleast_1d(values)) + ")"


def _diff(ours, paper, digits: int = 1) -> str:
    return _fmt(np.asarray(ours) - np.asarray(paper), digits)


# --- Fig. 8: several equilibria under load and length control ----------------------------
def fig8(ctx: Context) -> None:
    from .solvers.equilibrium import EquilibriumSolver
    from .core.fem import Discretisation
    from .io.hdf5 import atomic_h5, provenance, write_attrs, write_equilibrium
    from .solvers.lengths import LengthSolver
    from .studies.search import length_equilibria
    from .plots.lengths import plot_states
    from .ui.progress import Progress

    arm, l_mm = ctx.arm, ctx.arm.length_mm
    disc = Discretisation.from_arm(arm)
    with EquilibriumSolver(disc) as eqs, LengthSolver.from_arm(arm) as ls:
        state1 = eqs.solve(PAPER_P, order=(2, 1))
        proportional = eqs.solve(PAPER_P)
        state3 = eqs.solve(PAPER_P, order=(1, 2))
        with Progress(None, "Fig. 8 search", unit="search steps") as bar:
            search = length_equilibria(ls, ctx.place.fig8_lengths_mm / l_mm, eq_solver=eqs,
                                       progress=bar)
        found1 = search.closest(p=PAPER_P).state
        found2 = search.closest(p=[9.7, 12.6]).state
    L1, L3 = state1.cable_lengths * l_mm, state3.cable_lengths * l_mm
    ctx.add("Fig. 8", "load control p = (25.2, 10.8), order 2,1: cable lengths [mm] (state 1)",
            "(147.1, 472.5)", _fmt(L1, 2), _diff(L1, FIG8_LENGTHS_MM, 2),
            "proportional loading reaches the same state: L = " + _fmt(
                proportional.cable_lengths * l_mm, 2))
    ctx.add("Fig. 8", "load control p = (25.2, 10.8), order 1,2: cable lengths [mm] (state 3)",
            "(96.2, 454.3)", _fmt(L3, 2), _diff(L3, [96.2, 454.3], 2),
            "tensioning tendon 1 first selects state 3 (path dependence)")
    lengths = _fmt(ctx.place.fig8_lengths_mm)
    ctx.add("Fig. 8", f"length control L = {lengths} mm: tensions of state 1 [P l^2/B]",
            "(25.2, 10.8)", _fmt(found1.p, 2), _diff(found1.p, PAPER_P, 2),
            "the lengths of state 1 under load control (a user arm)" if ctx.place.note else
            "the paper's lengths are rounded to 0.1 mm; dp/dL ~ 0.1-1 per mm")
    ctx.add("Fig. 8", f"length control L = {lengths} mm: tensions of state 2 [P l^2/B]",
            "(9.7, 12.6)", _fmt(found2.p, 2), _diff(found2.p, [9.7, 12.6], 2),
            f"{len(search.states)} distinct equilibria found from {len(search.starts)} starts "
            "(deflation); not a proof that there are no others")
    with atomic_h5(ctx.path("fig8.h5", "Fig. 8"), overwrite=True) as fh:
        write_attrs(fh, provenance(arm, "fig8"))
        for name, eq in (("state1", state1), ("state2", found2), ("state3", state3)):
            write_equilibrium(fh.create_group(name), arm, eq)
    plot_states(arm, [(state1, "state 1: p = (25.2, 10.8), L = " + _fmt(L1)),
                      (found2, "state 2: p = " + _fmt(found2.p) + ", L = "
                       + _fmt(found2.cable_lengths * l_mm)),
                      (state3, "state 3: p = (25.2, 10.8), L = " + _fmt(L3))],
                ctx.path("fig8.png", "Fig. 8"), circles_mm=ctx.place.fig8_lengths_mm,
                title="Fig. 8: states 1, 2 share cable lengths (attachments on the dashed "
                      "circles); states 1, 3 share tensions")


# --- Fig. 2: descent iterations ----------------------------------------------------------
def fig2(ctx: Context) -> None:
    from .solvers.control import TipController
    from .io.hdf5 import atomic_h5, provenance, write_attrs, write_control
    from .plots.control import plot_descent

    results = {}
    for method in ("gd", "blmvm"):
        with TipController(ctx.arm, method=method) as controller:
            results[method] = controller.solve_mm(ctx.place.fig2_target_mm, p0=np.zeros(2))
    gd, blmvm = results["gd"], results["blmvm"]
    monotone = bool(np.all(np.diff(gd.history_E) < 0))
    ctx.add("Fig. 2", f"target {_fmt(ctx.place.fig2_target_mm)} mm from P = 0: "
            "gradient-descent iterations",
            "over a dozen", str(gd.iterations), "",
            f"tip error {gd.tip_error_mm:.1e} mm; our TAO BLMVM needs {blmvm.iterations} "
            f"(tip error {blmvm.tip_error_mm:.1e} mm)")
    ctx.add("Fig. 2", "cost E decreases monotonically", "yes", "yes" if monotone else "NO")
    ctx.add("Fig. 2", "tensions at the target [N]", "not given",
            _fmt(blmvm.tensions_N, 3), "", "cable lengths " + _fmt(blmvm.cable_lengths_mm, 2) + " mm")
    for method, result in results.items():
        with atomic_h5(ctx.path(f"fig2_{method}.h5", "Fig. 2"), overwrite=True) as fh:
            write_attrs(fh, provenance(ctx.arm, "control"))
            write_control(fh, ctx.arm, result)
        plot_descent(ctx.arm, result, ctx.path(f"fig2_{method}.png", "Fig. 2"))


# --- Fig. 3 and Fig. 6: traced paths -------------------------------------------------------
def _trace(ctx: Context, name: str, points, figure: str):
    from .solvers.control import TipController
    from .io.hdf5 import atomic_h5, provenance, write_attrs, write_trace
    from .studies.trace import densify, trace
    from .plots.control import plot_trace
    from .core.schedule import schedule_from_trace

    from .ui.progress import Progress

    targets = densify(points, ctx.trace_step_mm)
    with TipController(ctx.arm) as controller, Progress(len(targets), f"trace {name}") as bar:
        result = trace(controller, targets, p0=np.full(2, 2.0), keep_results=True,
                       on_point=bar.update)
    schedule = schedule_from_trace(result, ctx.arm)
    with atomic_h5(ctx.path(f"{name}.h5", figure), overwrite=True) as fh:
        write_attrs(fh, provenance(ctx.arm, "trace"))
        fh.attrs["elements"] = result.results[0].equilibrium.disc.n_elements
        fh.attrs["step_mm"] = ctx.trace_step_mm
        write_trace(fh, ctx.arm, result, schedule)
    schedule.write_csv(ctx.path(f"{name}_schedule.csv", figure))
    plot_trace(ctx.arm, result, ctx.path(f"{name}.png", figure))
    ctx.traces[name] = result
    return result


def fig3(ctx: Context) -> None:
    from .studies.trace import convoluted_curve, paper_triangle, triangle_vertices
    from .plots.control import plot_curvature, plot_sensitivities, plot_tensions_lengths

    place = ctx.place
    radius = 80.0 * place.size
    tri = _trace(ctx, "fig3a", paper_triangle(place.triangle_center_mm, radius), "Fig. 3a")
    vertices = triangle_vertices(place.triangle_center_mm, radius)
    side = np.linalg.norm(vertices[1] - vertices[0])
    warm = tri.iterations[1:]
    ctx.add("Fig. 3a", "triangle side / incircle / circumcircle radius [mm]",
            "138.56 / 40 / 80", f"{side:.2f} / {radius / 2:.4g} / {radius:.4g}", "",
            f"centred at {place.triangle_center_mm} mm (the paper gives no coordinates)")
    ctx.add("Fig. 3a", "tip error of the computed tensions [mm]", "< 1e-5 (eps = 1e-10 mm^2)",
            f"max {np.max(tri.tip_errors_mm):.1e} over {tri.n_points} points", "",
            f"all {int(np.sum(tri.converged))} of {tri.n_points} targets reached "
            f"(step {ctx.trace_step_mm:g} mm)")
    ctx.add("Sec. 4.5 (v)", "iterations per warm-started target", "< 5",
            f"median {np.median(warm):g}, max {int(np.max(warm))}")
    ctx.add("Sec. 4.5 (v)", "time per target point (180 elements)", "< 1 s",
            f"{1e3 * tri.seconds / tri.n_points:.2f} ms", "",
            "includes the equilibrium, sensitivity and TAO work of every iteration")
    mono = tri.monotonic_fraction()
    ctx.add("Sec. 4.1", "cable length and tension change oppositely along the path",
            "verified in the examples", " / ".join(f"{100 * m:.0f} %" for m in mono),
            "", "fraction of path steps per tendon; the summed work condition "
                f"sum dL_i dP_i < 0 holds in {100 * tri.work_fraction():.0f} % of steps")
    plot_tensions_lengths(ctx.arm, tri, ctx.path("fig6a.png", "Fig. 6"))
    plot_sensitivities(ctx.arm, tri, ctx.path("fig6b.png", "Fig. 6"))
    plot_curvature(ctx.arm, tri, ctx.path("fig6c.png", "Fig. 6"))
    sens = np.array([r.sensitivity.tip for r in tri.results])
    ratio = np.median(np.linalg.norm(sens[:, 1], axis=1) / np.linalg.norm(sens[:, 0], axis=1))
    ctx.add("Fig. 6b", "tip sensitivity to cable 2 / to cable 1", "roughly 10",
            f"{ratio:.1f} (median along the path)")
    curve = _trace(ctx, "fig3b", convoluted_curve(place.curve_center_mm, 170.0 * place.size,
                                                  35.0 * place.size), "Fig. 3b")
    ctx.add("Fig. 3b", "convoluted curve traced, max tip error [mm]", "< 2 mm (experiment)",
            f"{np.max(curve.tip_errors_mm):.1e} ({curve.n_points} points)", "",
            "our own meander (paths.convoluted_curve): the paper does not list its points; "
            "the paper's 2 mm is the experiment's error, ours the model's tip tolerance")


# --- Figs. 4-5: workspace -------------------------------------------------------------------
def workspace(ctx: Context) -> Path:
    """Sample the workspace (all ranks take part under mpiexec; with ``jobs`` > 1
    outside mpiexec, a job of that many ranks is spawned: :mod:`.studies.workspace_job`)."""
    from .core.errors import InputError
    from .core.fem import Discretisation
    from .ui.progress import quiet
    from .studies.workspace import run_map

    out = ctx.out / "fig4_workspace.h5"
    kwargs = dict(spacing_mm=ctx.spacing_mm, out=str(out), overwrite=True,
                  provenance={"command_line": ctx.command},
                  checkpoint_seconds=ctx.checkpoint_seconds)
    if ctx.comm.size == 1 and ctx.jobs > 1:
        from .studies.workspace_job import spawn
        # the job's progress: a bar if our stdout is a terminal, else lines on stderr
        status = spawn(ctx.arm, ctx.arm.elements, ctx.jobs, progress=not quiet(),
                       **kwargs)
        if status == 130:
            raise KeyboardInterrupt
        if status != 0:
            raise InputError(f"the workspace job on {ctx.jobs} ranks ended with status {status}")
    else:
        result = run_map(ctx.arm, Discretisation.from_arm(ctx.arm), comm=ctx.comm,
                         progress=True, **kwargs)                  # a bar on rank 0 (none with --quiet)
        if not result.complete:
            raise KeyboardInterrupt
    return out


def fig4_5(ctx: Context, out: Path) -> None:
    from .plots.workspace import plot_workspace, read_workspace
    from .studies.workspace import Status, reason_counts

    ctx.files.setdefault("Figs. 4-5", []).append(out.name)
    data = read_workspace(out)
    reached = data["status"] == Status.REACHED
    region = f"spacing {ctx.spacing_mm:g} mm over the half-disc y >= 0 within reach l"
    ctx.add("Fig. 4", "sampled targets in y >= 0 / reached with P >= 0 (W_0)", "4201 green points",
            f"{len(reached)} targets / {int(reached.sum())} reached", "",
            f"{region}; {int(np.sum(data['status'] == Status.OUTSIDE_BOUNDARY))} proven outside the "
            "traced W_0 boundary (purple); "
            f"{int(np.sum(np.isin(data['status'], (Status.NEEDS_NEGATIVE, Status.UNDECIDED))))} "
            "not reached after the global search (orange; no proof either way)")
    red = data["target"][np.isin(data["status"], (Status.NEEDS_NEGATIVE, Status.UNDECIDED,
                                                  Status.OUTSIDE_BOUNDARY))]
    side = "left of / above" if len(red) and np.median(red[:, 0]) < np.median(
        data["tip"][reached, 0]) else "elsewhere relative to"
    ctx.add("Fig. 4", "points needing P_1 < 0 bound the workspace on one side", "yes",
            f"points not reached lie {side} the reached region", "")
    failed = data["status"] == Status.NOT_CONVERGED
    if failed.any():
        where = data["target"][failed]
        ours = (f"{int(failed.sum())} not converged at x = {where[:, 0].min():.0f} to "
                f"{where[:, 0].max():.0f} mm, y <= {where[:, 1].max():.0f} mm")
        comment = (f"stopping reasons: {reason_counts(data['reason'][failed])} (CABLE_COLLAPSE: "
                   "the optimiser heads for a cable pulled onto its routing point); grey in "
                   "fig4.png")
    else:
        ours, comment = "every target converged", ""
    ctx.add("Fig. 4", "regions not sampled well (numerical convergence difficulties)",
            "indicated in the figure", ours, "", comment)
    raw = data["lambda_min_raw"][reached]
    ctx.add("Fig. 5b", "smallest raw eigenvalue lambda_min(K)/(B/l) over the samples", "~1.8e-3",
            f"{np.nanmin(raw):.2e}", "",
            "mesh dependent (scales with h); the minimum depends on how close the sampling "
            "gets to the workspace boundary")
    paths = [(name, t.targets_mm) for name, t in ctx.traces.items()]
    png = ctx.path("fig4.png", "Figs. 4-5")
    ctx.files["Figs. 4-5"].append("fig4_restrictions.png")
    plot_workspace(out, png, paths=paths)
    # Fig. 5: ranges realised along the traced paths
    kappa = max(max(r.equilibrium.kappa_max for r in t.results) for t in ctx.traces.values())
    energy = max(max(r.equilibrium.strain_energy for r in t.results) for t in ctx.traces.values())
    p_max = max(float(np.max(t.p)) for t in ctx.traces.values())
    ctx.add("Fig. 5a", "l kappa_max along the experiments' paths", "<= 6.5", f"{kappa:.2f}", "",
            "our path placement differs from the paper's")
    ctx.add("Fig. 5c", "strain energy along the paths [SE_0 = B/(2l)]", "<= 18", f"{energy:.1f}")
    ctx.add("Fig. 5d", "largest tension along the paths [B/l^2]", "<= 40 (22.2 N)",
            f"{p_max:.1f} ({p_max * ctx.arm.force_scale_N:.1f} N)")


# --- Fig. 7: buckling under length control ----------------------------------------------
def fig7(ctx: Context) -> None:
    from .plots.buckling import plot_fig7
    from .studies.buckling import fig7 as fig7_scenario
    from .solvers.equilibrium import EquilibriumSolver
    from .core.fem import Discretisation
    from .solvers.lengths import LengthSolver

    from .studies.buckling import scenario_problem

    disc = Discretisation.from_arm(ctx.arm)
    problem = scenario_problem(disc)
    if problem is not None:              # a user arm: say so in the report, go on
        ctx.add("Fig. 7", "shortening L_2 buckles the straight segment (length control)",
                "a few mm", "not run", "", f"not applicable to this arm: {problem}")
        return
    with EquilibriumSolver(disc) as eqs, LengthSolver.from_arm(ctx.arm) as ls:
        result = fig7_scenario(eqs, ls)
    ctx.add("Fig. 7", "shortening L_2 buckles the straight segment (length control)",
            "a few mm", f"{result.dL2_cr_mm:.2f} mm", "",
            f"critical p_2 = {result.p2_cr:.2f} vs clamped-column estimate "
            f"{result.p_clamped:.2f}; two stable buckled states found")
    plot_fig7(ctx.arm, result, ctx.path("fig7.png", "Fig. 7"))


# --- Sec. 4.3: the aluminium thought experiment -------------------------------------------
def aluminium(ctx: Context, config: Path) -> None:
    alu = load_config(config)
    kappa = max(max(r.equilibrium.kappa_max for r in t.results) for t in ctx.traces.values())
    energy = max(max(r.equilibrium.strain_energy for r in t.results) for t in ctx.traces.values())
    p_max = max(float(np.max(t.p)) for t in ctx.traces.values())
    violated = []
    if kappa >= alu.kappa_limit:
        violated.append(f"strain (l kappa_max {kappa:.2f} > {alu.kappa_limit:g}, Eq. (19))")
    if alu.max_tension is not None and p_max >= alu.max_tension:
        violated.append(f"motor force ({p_max * alu.force_scale_N:.0f} N > "
                        f"{alu.motor.max_tension_N:g} N, Eq. (22))")
    ctx.add("Sec. 4.3", "aluminium arm (B x 30, eps_Y / 10) on the same paths",
            "would yield and exceed the motor load", "violates " + " and ".join(violated)
            if violated else "violates nothing", "",
            f"energy up to {energy * alu.energy_scale_J:.1f} J vs "
            f"{energy * ctx.arm.energy_scale_J:.2f} J for polycarbonate")


# --- driver and report ------------------------------------------------------------------------
def write_report(ctx: Context, command: str) -> Path:
    from petsc4py import PETSc

    lines = ["# Reproduction report: Handral & Rangarajan (2019), an elastica robot", "",
             f"- elastica_petsc {__version__}, PETSc {'%d.%d.%d' % PETSc.Sys.getVersion()}, "
             f"{ctx.arm.elements} elements, {'quick (coarse grids)' if ctx.quick else 'full'} run",
             f"- command: `{command}`",
             f"- created {datetime.datetime.now(datetime.timezone.utc).isoformat(timespec='seconds')}",
             f"- wall time per experiment [s]: "
             + ", ".join(f"{k} {v:.1f}" for k, v in ctx.seconds.items()), "",
             "Paper values are read from the text of the paper (docs/model.md §6). Differences are "
             "ours minus the paper's.", "",
             *([f"**Note:** {ctx.place.note}.", ""] if ctx.place.note else []),
             "| figure | item | paper | ours | difference | comment |",
             "|---|---|---|---|---|---|"]
    for r in ctx.rows:
        lines.append(f"| {r.figure} | {r.item} | {r.paper} | {r.ours} | {r.difference} | {r.note} |")
    lines += ["", "## Files", ""]
    for figure, names in ctx.files.items():
        lines.append(f"- {figure}: " + ", ".join(f"`{n}`" for n in names))
    path = ctx.out / "REPORT.md"
    path.write_text("\n".join(lines) + "\n")
    (ctx.out / "report.json").write_text(jsontext.dumps([r.__dict__ for r in ctx.rows],
                                                        indent=1))
    return path


def planned_files() -> list[str]:
    """Every file name :func:`run` writes into the output folder."""
    names = ["fig8.h5", "fig8.png"]
    names += [f"fig2_{m}.{ext}" for m in ("gd", "blmvm") for ext in ("h5", "png")]
    names += [f"{n}{tail}" for n in ("fig3a", "fig3b") for tail in (".h5", "_schedule.csv", ".png")]
    names += ["fig6a.png", "fig6b.png", "fig6c.png", "fig4_workspace.h5", "fig4.png",
              "fig4_restrictions.png", "fig7.png", "REPORT.md", "report.json"]
    return names


def check_output_folder(out: str | Path, overwrite: bool) -> Path:
    """Before any computation: ``out`` is (or can be made) a writable folder, and
    no file :func:`run` would write exists there unless ``overwrite``.
    Creates nothing (the caller makes the folder once every check has passed:
    a refusal leaves no empty folder behind); returns it."""
    from .core.errors import InputError
    from .io.hdf5 import probe_writable, check_output_path

    if not str(out).strip():
        raise InputError("--out: empty folder name")
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {out} exists and is not a folder")
    existing = [name for name in planned_files() if (out / name).exists()]
    if existing and not overwrite:
        more = f" and {len(existing) - 1} more" if len(existing) > 1 else ""
        raise InputError(f"{out} already holds {existing[0]}{more}; pass --overwrite to "
                         "replace them")
    if not out.is_dir():
        parent = next(p for p in out.absolute().parents if p.exists())
        if not parent.is_dir():
            raise InputError(f"--out {out}: {parent} is not a folder")
        probe_writable(parent, out)
        return out
    for name in planned_files():
        check_output_path(out / name, overwrite=True)
    return out


EXPERIMENTS = ("workspace", "fig8", "fig2", "fig3", "fig4_5", "fig7", "aluminium")


def run(ctx: Context, command: str, aluminium_config: Path, log=print) -> Path | None:
    """All experiments.  The workspace comes first: under mpiexec every rank
    takes part in it, then rank 0 alone does the rest (the other ranks are
    done, not spinning in a collective).  Returns the report path on rank 0."""
    ctx.command = command
    def timed(name, action):
        t0 = time.perf_counter()
        value = action()
        ctx.seconds[name] = time.perf_counter() - t0
        if ctx.comm.rank == 0:
            log(f"reproduce: {name} done in {ctx.seconds[name]:.1f} s")
        return value

    ws = timed("workspace", lambda: workspace(ctx))
    if ctx.comm.rank != 0:
        return None
    steps = {"fig8": lambda: fig8(ctx), "fig2": lambda: fig2(ctx), "fig3": lambda: fig3(ctx),
             "fig4_5": lambda: fig4_5(ctx, ws), "fig7": lambda: fig7(ctx),
             "aluminium": lambda: aluminium(ctx, aluminium_config)}
    for name in EXPERIMENTS[1:]:
        timed(name, steps[name])
    return write_report(ctx, command)
