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
