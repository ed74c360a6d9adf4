"""A simulation in user units: start state, motor input, the run (docs/model.md §16).

Start states: the straight arm at rest (sagging under any weight), the static equilibrium at given
tensions (loaded in a given order), or the last shape of a file the tool
wrote (``theta``/``theta_rad`` dataset).  Inputs: constant tensions, a
tension history (core/drive.py) or a motor schedule (cable lengths in time).
Units: mm, N, s, J at the edge; the solver works in l, B/l^2, tau =
sqrt(rho_A l^4 / B).
"""
from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass, field

import numpy as np

from ..core.drive import LengthDrive, TensionDrive, read_schedule, read_tension_history
from ..core.dynamics import Inertia, straight_cables
from ..core.errors import InputError
from ..core.fem import Discretisation
from ..core.model import Arm
from ..core.results import Result
from ..solvers.dynamics import SLACK, TAUT, DynamicsSolver, Trajectory
from ..solvers.equilibrium import Equilibrium, check_order, check_tensions, solve_equilibrium
from ..solvers.stability import StabilitySolver

# rho_inf under a motor schedule: the unresolved mesh modes that the impacts of rigid
# cables excite are damped, the resolved ones are not (docs/model.md §16.6)
SCHEDULE_RADIUS = 0.5


def time_scale_s(arm: Arm) -> float:
    """tau = sqrt(rho_A l^4 / B) [s]; needs the mass per length."""
    if arm.mass_per_length_kg_m is None:
        raise InputError("the arm has no mass: set [arm] mass_per_length_kg_m in the config "
                         "to simulate its motion")
    length_m = arm.length_mm * 1e-3
    return math.sqrt(arm.mass_per_length_kg_m * length_m**4 / arm.bending_stiffness_Nm2)


@dataclass(frozen=True, repr=False)
class SimulationResult(Result):
    """Every accepted step of a run, in mm, N, s, J (a result type: ``save(path)``
    writes ``simulate --out``'s layout, ``ep.read`` returns it)."""

    arm: Arm
    elements: int
    input: str                          # "tensions", "history" or "schedule"
    time_s: np.ndarray
    theta: np.ndarray                   # (T, N+1) rad
    x_mm: np.ndarray                    # (T, N+1, 2)
    tensions_N: np.ndarray              # (T, n)
    cable_lengths_mm: np.ndarray        # (T, n)
    energy_J: np.ndarray                # (T, 4): kinetic, strain, work of the tensions, weight's potential
    events: list                        # (time_s, tendon, "slack"|"taut")
    steps: int
    rejected: int
    completed: bool
    reason: str
    wall_s: float
    f1_hz: float
    planned_tip_mm: np.ndarray | None = None     # quasi-static tip at time_s (schedule)
    extras: dict = field(default_factory=dict)

    @property
    def tip_mm(self) -> np.ndarray:
        return self.x_mm[:, -1, :]

    def snapshots(self, steps=None):
        """The arm at the recorded ``steps`` (default: all), one at a time, as
        non-dimensional states (an :class:`Equilibrium` holding the shape and the
        tensions of the step, not an equilibrium: for drawing and export)."""
        disc = Discretisation.from_arm(self.arm, self.elements)
        p = self.arm.tensions_from_N(self.tensions_N)
        for k in range(len(self.time_s)) if steps is None else steps:
            yield Equilibrium(disc, p[k], disc.consistent_state(self.theta[k]), True,
                              "in motion", 0, 0)

    def to_vtk(self, directory, *, on_step=None) -> list:
        """ParaView files in ``directory``, as ``simulate --vtk`` writes them:
        ``simulation.pvd`` (the arm and its cables at every recorded step, time in s)
        and ``simulation_tip.vtu`` (the tip's path with per-step fields);
        ``on_step(done, total)`` after each step's file."""
        from ..io.vtk import write_simulation

        return write_simulation(directory, self, on_step=on_step)

    def animate(self, path, *, slow_motion: float = 1.0, fps: float = 20.0, on_frame=None):
        """A GIF/MP4 of the run (by the suffix of ``path``), in real time or
        ``slow_motion`` times slower, as ``simulate --animate`` writes it;
        ``on_frame(done, total)`` after each frame."""
        import elastica_petsc             # the plots layer sits above this one

        return elastica_petsc.animate_simulation(self, path, slow_motion=slow_motion, fps=fps,
                                                 on_frame=on_frame)

    @property
    def real_time_factor(self) -> float:
        return float(self.time_s[-1] / self.wall_s) if self.wall_s > 0 else math.inf

    def summary(self) -> dict:
        dev = None
        if self.planned_tip_mm is not None:
            dev = float(np.max(np.linalg.norm(self.tip_mm - self.planned_tip_mm, axis=1)))
        E = self.energy_J
        total = E[:, 0] + E[:, 1] - E[:, 2] + E[:, 3]
        return {"input": self.input, "elements": self.elements, "completed": self.completed,
                "reason": self.reason, "duration_s": float(self.time_s[-1]),
                "steps": self.steps, "rejected": self.rejected,
                "events": [{"time_s": float(t), "tendon": int(i), "kind": k}
                           for t, i, k in self.events],
                "wall_s": round(self.wall_s, 3), "real_time_factor": self.real_time_factor,
                "f1_hz": self.f1_hz, "max_tip_deviation_mm": dev,
                "energy_drift_J": float(np.max(np.abs(total - total[0]))),
                "final": {"time_s": float(self.time_s[-1]), "tip_mm": self.tip_mm[-1].tolist(),
                          "tensions_N": self.tensions_N[-1].tolist(),
                          "cable_lengths_mm": self.cable_lengths_mm[-1].tolist(),
                          "kinetic_energy_J": float(E[-1, 0])}}


def _start_theta(disc: Discretisation, tensions, order, from_theta):
    """Start shape and tensions (p): straight, an equilibrium, or a given shape."""
    n = disc.n_tendons
    if from_theta is not None:
        theta = np.asarray(from_theta, float)
        if theta.shape != (disc.n_elements + 1,):
            raise InputError(f"the start shape has {theta.size - 1} elements, the mesh "
                             f"{disc.n_elements}; use --elements {theta.size - 1}")
        return theta, np.zeros(n)
    if tensions is None or not np.any(tensions):      # at rest: sagging under any weight
        return disc.split(disc.straight())[0], np.zeros(n)
    eq = solve_equilibrium(disc, tensions, order=order)
    if not eq.converged:
        raise InputError(f"no equilibrium at the initial tensions: {eq.message}")
    return eq.theta, np.asarray(eq.p, float)


def first_frequency(disc: Discretisation, arm: Arm, theta, p) -> float:
    """omega_1 rho_A l^4 / B of the state (load control), with the tip mass."""
    with StabilitySolver(disc) as st:
        fr = st.frequencies(disc.consistent_state(theta), p, arm, nev=1,
                            tip_mass_kg=arm.tip_mass_kg)
    return float(math.sqrt(max(fr.omega2[0], 0.0)))


def build_inertia(arm: Arm, disc: Discretisation) -> Inertia:
    """Masses and damping of the arm (docs/model.md §16.2); zeta_1 at the unloaded
    first mode of this mesh with the tip mass (sagging under any weight, §11.5)."""
    tip = arm.tip_mass_kg / (arm.mass_per_length_kg_m * arm.length_mm * 1e-3)
    dyn = arm.dynamics
    rotary = (arm.thickness_mm / arm.length_mm) ** 2 / 12.0 if dyn.rotary_inertia else 0.0
    omega1 = first_frequency(disc, arm, disc.split(disc.straight())[0],
                             np.zeros(disc.n_tendons))
    return Inertia.build(disc, tip_mass=tip, rotary=rotary, damping_ratio=dyn.damping_ratio,
                         kelvin_voigt_fraction=dyn.kelvin_voigt_fraction, omega1=omega1)


def simulate(arm: Arm, *, elements: int | None = None, initial_tensions_N=None, order=None,
             from_theta=None, tensions_N=None, history_csv=None, schedule_csv=None,
             settle_s: float = 0.0, duration_s: float | None = None, rtol: float = 1e-6,
             atol: float = 1e-8, radius: float | None = None, dt_s: float | None = None,
             adaptive: bool = False, steps_per_period: int = 200, on_step=None, trajectory: Trajectory | None = None) -> SimulationResult:
    """Run the arm from rest (module docstring); ``on_step(t_s)`` after each step.

    Steps: fixed, ``dt_s`` or the start state's first period / ``steps_per_period``
    (default); ``adaptive``: TSAdapt with ``rtol``/``atol`` from that step.
    ``radius``: rho_inf of the alpha method; default 1 (no numerical dissipation)
    under tensions, ``SCHEDULE_RADIUS`` under a motor schedule (docs/model.md §16.6).
    """
    tau = time_scale_s(arm)
    disc = Discretisation.from_arm(arm, elements)
    try:
        straight_cables(disc)
    except ValueError:
        raise InputError("simulate handles arms with straight cables only: cable guides and "
                         "offset cable ends are not in the dynamics yet (docs/model.md §16.6)"
                         ) from None
    n = disc.n_tendons
    given = [x is not None for x in (tensions_N, history_csv, schedule_csv)]
    if sum(given) != 1:
        raise InputError("give exactly one input: --tensions-N, --history or --schedule")
    order = check_order(order, n)
    p_init = None if initial_tensions_N is None else check_tensions(
        arm.tensions_from_N(initial_tensions_N), n)
    planned = None
    if schedule_csv is not None:
        rows = read_schedule(schedule_csv, n)
        if rows.start_tensions_N is not None and p_init is None and from_theta is None:
            p_init = arm.tensions_from_N(rows.start_tensions_N)
        theta0, p0 = _start_theta(disc, p_init, order, from_theta)
        start_L_mm = arm.to_mm(_lengths(disc, theta0))
        L_mm = rows.lengths_from(start_L_mm, 2 * math.pi * arm.motor.spool_radius_mm
                                 / (arm.motor.steps_per_rev * arm.motor.microsteps))
        t_rows = rows.time_s - rows.time_s[0]
        drive = LengthDrive(t_rows / tau, arm.from_mm(L_mm))
        end_s = t_rows[-1] + settle_s if duration_s is None else duration_s
        gap = arm.from_mm(L_mm[0] - start_L_mm)
        modes = np.where(gap <= 1e-9, TAUT, SLACK)     # in contact; the solver resolves
        kind = "schedule"
        planned = rows
    else:
        theta0, p0 = _start_theta(disc, p_init, order, from_theta)
        if tensions_N is not None:
            drive = TensionDrive.constant(check_tensions(arm.tensions_from_N(tensions_N), n))
            kind = "tensions"
        else:
            t_h, P_h = read_tension_history(history_csv, n)
            drive = TensionDrive((t_h - t_h[0]) / tau, arm.tensions_from_N(P_h))
            kind = "history"
        if duration_s is None:
            raise InputError("--duration is needed with --tensions-N or --history")
        end_s, modes = duration_s, None
        p0 = drive.tensions(0.0) if p_init is None else p0
    if not (end_s > 0 and math.isfinite(end_s)):
        raise InputError(f"the duration must be a positive number of seconds, got {end_s:g}")
    if radius is None:
        radius = SCHEDULE_RADIUS if kind == "schedule" else 1.0
    inertia = build_inertia(arm, disc)
    f1 = first_frequency(disc, arm, theta0, p0) / (2 * math.pi * tau)
    dt0 = (dt_s / tau) if dt_s else 1.0 / (f1 * tau * steps_per_period)
    sim = DynamicsSolver(disc, inertia, rtol=rtol, atol=atol, radius=radius, dt0=dt0,
                         adaptive=adaptive)
    traj = trajectory if trajectory is not None else Trajectory()
    wall = _time.perf_counter()
    try:
        sim.run(theta0, np.zeros(disc.n_elements), p0, drive, modes, end_s / tau,
                on_step=None if on_step is None else (lambda t: on_step(t * tau)),
                trajectory=traj)
    except KeyboardInterrupt:
        traj.reason, traj.completed = "INTERRUPTED", False
    wall = _time.perf_counter() - wall
    return _result(arm, disc, kind, traj, tau, wall, f1, planned)


def _lengths(disc: Discretisation, theta) -> np.ndarray:
    x = disc.node_positions(theta)[list(disc.attach_nodes)]
    return np.linalg.norm(disc.routes - x, axis=1)


def _result(arm, disc, kind, traj, tau, wall, f1, rows) -> SimulationResult:
    t = np.asarray(traj.time) * tau
    theta = np.asarray(traj.theta)
    x = np.array([disc.node_positions(th) for th in theta]) * arm.length_mm
    B_over_l = arm.bending_stiffness_Nm2 / (arm.length_mm * 1e-3)
    energy = np.column_stack((traj.kinetic, traj.strain, traj.work, traj.gravity)) * B_over_l
    planned = None
    if rows is not None and rows.tips_mm is not None:      # the quasi-static path in time
        t_rows = rows.time_s - rows.time_s[0]
        planned = np.column_stack([np.interp(t, t_rows, rows.tips_mm[:, c]) for c in (0, 1)])
    return SimulationResult(
        arm=arm, elements=disc.n_elements, input=kind, time_s=t, theta=theta, x_mm=x,
        tensions_N=arm.tensions_to_N(np.asarray(traj.p)),
        cable_lengths_mm=arm.to_mm(np.asarray(traj.lengths)), energy_J=energy,
        events=[(float(e[0] * tau), e[1], e[2]) for e in traj.events], steps=traj.steps,
        rejected=traj.rejected, completed=traj.completed, reason=traj.reason, wall_s=wall,
        f1_hz=f1, planned_tip_mm=planned)
