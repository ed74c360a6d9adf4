"""The arm in motion (PETSc TS, docs/model.md §16)."""
from __future__ import annotations

from ..core.model import Arm
from .arguments import takes_petsc_options as _takes_petsc_options


@_takes_petsc_options
def simulate(arm: Arm, *, tensions_N=None, history_csv=None, schedule_csv=None,
             initial_tensions_N=None, order=None, from_file=None, duration_s=None,
             settle_s: float = 0.0, dt_s: float | None = None, adaptive: bool = False,
             rtol: float = 1e-6, atol: float = 1e-8, radius: float | None = None,
             elements: int | None = None):
    """The arm in motion (PETSc TS, docs/model.md §16) from rest: the straight arm, the
    equilibrium at ``initial_tensions_N`` (loaded in ``order``) or the last shape in
    ``from_file``; driven by constant ``tensions_N``, a tension history CSV or a motor
    schedule CSV (cable lengths; slack and taut cables decided in every step).  ``radius``:
    rho_inf of the alpha method (default 1 under tensions, 0.5 under a schedule).  Returns a
    ``SimulationResult`` (``time_s``, ``tip_mm``, ``x_mm``, ``tensions_N``,
    ``cable_lengths_mm``, ``energy_J``, ``summary()``); needs the arm's mass per length."""
    from ..core.friction import check_frictionless
    from ..io.simulation import read_theta
    from ..studies.simulate import simulate as run

    check_frictionless(arm, "simulate")
    return run(arm, elements=elements, initial_tensions_N=initial_tensions_N,
               order=order, from_theta=None if from_file is None else read_theta(from_file),
               tensions_N=tensions_N, history_csv=history_csv, schedule_csv=schedule_csv,
               settle_s=settle_s, duration_s=duration_s, rtol=rtol, atol=atol, radius=radius,
               dt_s=dt_s, adaptive=adaptive)


@_takes_petsc_options
def fastest_speed(arm: Arm, schedule, max_deviation_mm: float, *, elements: int | None = None,
                  settle_s: float | None = None, start_mm_s: float | None = None,
                  rel_tol: float = 0.05, on_trial=None):
    """The fastest constant tip speed [mm/s] at which the motor ``schedule`` (a CSV path as
    ``trace --schedule`` writes it, a ``MotorSchedule`` or a ``TracedSchedule``), played from
    rest under length control on a mesh of ``elements``, keeps the tip within
    ``max_deviation_mm`` of its quasi-static tips and settles within it in ``settle_s``
    (docs/model.md §16.8).  Returns a ``SpeedStudy`` (``fastest_mm_s``, every trial)."""
    from ..core.schedule import read_schedule_csv
    from ..studies.speed import SETTLE_S, check_study, fastest_speed as run

    settle_s = SETTLE_S if settle_s is None else settle_s
    check_study(max_deviation_mm, settle_s, rel_tol)
    if hasattr(schedule, "schedule"):
        schedule = schedule.schedule
    elif not hasattr(schedule, "lengths_mm"):
        schedule = read_schedule_csv(schedule, arm.motor)
    return run(arm, schedule, max_deviation_mm, elements=elements,
               settle_s=settle_s, start_mm_s=start_mm_s,
               rel_tol=rel_tol, on_trial=on_trial)
