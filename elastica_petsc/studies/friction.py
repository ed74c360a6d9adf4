"""Quasi-static load paths with capstan friction at the guides (docs/model.md §26).

:func:`friction_path` follows a history of motor tensions (force control) in
increments from the frictionless equilibrium at its first point; each
increment solves the equilibrium with the stick/slip complementarity of every
guide (:class:`~elastica_petsc.solvers.friction.CapstanSolver`), measured from
the state the increment starts at, so a guide that sticks keeps the cable
beyond it.  A failed increment is halved (the path is history dependent: it
is never skipped).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.errors import InputError
from ..core.friction import DEFAULT_SCALE, CapstanKernel
from ..core.guided import GuidedDiscretisation
from ..core.results import Result
from ..solvers.equilibrium import check_tensions, solve_equilibrium
from ..solvers.friction import CapstanSolver

# an increment is halved at most this many times before the path is reported as failed
MAX_HALVINGS = 12


@dataclass(frozen=True, repr=False)
class FrictionPath(Result):
    """The states of a load path with friction at each point of the history,
    non-dimensional (lengths / l, p = P l^2/B)."""

    mu: np.ndarray              # friction coefficient of each guide
    p_motor: np.ndarray         # (K, n) motor tensions of the history reached
    tip: np.ndarray             # (K, 2) tip positions
    tip_angle: np.ndarray       # (K,) theta(l)
    tensions: np.ndarray        # (K, P) tension of every segment (tendon by tendon)
    modes: np.ndarray           # (K, G) SLIP_IN / STICK / SLIP_OUT of every guide
    wrap: np.ndarray            # (K, G) turning angle beta of the cable at every guide
    states: np.ndarray = field(repr=False)    # (K, size) w = (angles, chords, q)
    increments: int = 0         # Newton solves, halvings included
    iterations: int = 0         # Newton iterations of all increments
    converged: bool = True
    message: str = ""


def check_history(history, n_tendons: int) -> np.ndarray:
    """A (K, n) array of motor tensions, K >= 1, each row a valid tension vector."""
    history = np.atleast_2d(np.asarray(history, float))
    if history.ndim != 2 or history.shape[1] != n_tendons or len(history) == 0:
        raise InputError(f"a load history is a list of tension vectors with {n_tendons} "
                         f"values each; got shape {np.shape(history)}")
    for row in history:
        check_tensions(row, n_tendons)
    return history


def friction_path(disc: GuidedDiscretisation, mu, history, *, max_step: float = 1.0,
                  scale: float = DEFAULT_SCALE, petsc_options=None) -> FrictionPath:
    """Follow the motor tensions ``history`` (K, n) with friction ``mu`` at the guides
    (a scalar or one per guide), from the frictionless equilibrium at history[0];
    increments no larger than ``max_step`` in any tension."""
    kernel = CapstanKernel.of(disc, mu, scale)
    history = check_history(history, disc.n_tendons)
    start = solve_equilibrium(disc, history[0])
    if not start.converged:
        raise InputError(f"no frictionless equilibrium at the first tensions: {start.message}")
    w = kernel.frictionless_state(start.u, history[0])
    rows, counts, message, secant = [], [0, 0], "", [None, 0.0]
    with CapstanSolver(kernel, petsc_options=petsc_options) as solver:
        rows.append(_record(kernel, w, history[0], kernel.beyond(w)))
        for p_from, p_to in zip(history[:-1], history[1:]):
            w, s_ref, message = _advance(solver, w, p_from, p_to, max_step, counts, secant)
            if message:
                break
            rows.append(_record(kernel, w, p_to, s_ref))
    stack = {key: np.array([r[key] for r in rows]) for key in rows[0] if key != "s"}
    return FrictionPath(mu=kernel.mu, increments=counts[0], iterations=counts[1],
                        converged=not message, message=message, **stack)


def _advance(solver: CapstanSolver, w, p_from, p_to, max_step: float, counts, secant):
    """w at p_to from w at p_from in increments (halved on failure): (w, the cable
    beyond each guide at the start of the last increment, message).  Each Newton
    solve starts from the secant predictor w + (step / last step) dw of the last
    accepted increment (``secant``: [dw, its tension step], updated), so that the
    guides' slip continues in its direction and the modes are right from the
    first iterate (from w itself every trial value is a tie between the modes)."""
    kernel = solver.kernel
    span = float(np.max(np.abs(p_to - p_from)))
    steps = max(1, int(np.ceil(span / max_step)))
    done, step, halvings = 0.0, 1.0 / steps, 0
    s_ref = kernel.beyond(w)
    while done < 1.0 - 1e-12:
        step = min(step, 1.0 - done)
        p = p_from + (done + step) * (p_to - p_from)
        s_ref = kernel.beyond(w)
        guess = w.copy()
        if secant[0] is not None and secant[1] > 0.0:
            guess += (step * span / secant[1]) * secant[0]
        trial, its, reason, ok = solver.increment(guess, p, s_ref)
        counts[0] += 1
        counts[1] += its
        if not ok:
            halvings += 1
            if halvings > MAX_HALVINGS:
                return w, s_ref, (f"the increment to motor tensions {np.round(p, 6).tolist()} did "
                                  f"not converge ({reason}) after {MAX_HALVINGS} halvings")
            step *= 0.5
            secant[0] = None
            continue
        secant[:] = [trial - w, step * span]
        w, done = trial, done + step
    return w, s_ref, ""


def _record(kernel: CapstanKernel, w, p_motor, s_before) -> dict:
    """What the path keeps of the state w (its modes in the increment that reached it,
    measured from ``s_before``)."""
    disc = kernel.disc
    theta = disc.split(kernel.split(w)[0])[0]
    return {"p_motor": np.asarray(p_motor, float), "tip": disc.node_positions(theta)[-1],
            "tip_angle": theta[-1], "tensions": kernel.segment_tensions(w, p_motor),
            "modes": kernel.modes(w, p_motor, s_before), "wrap": kernel.wrap_angles(w),
            "states": w, "s": kernel.beyond(w)}
