"""Quasi-static load paths with capstan friction at the guides (docs/model.md §27).

:func:`friction_path` follows a history of the motors (tensions, or cable lengths for
the length-controlled ones) in increments from a frictionless equilibrium; each
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
from ..core.friction import DEFAULT_SCALE, STICK, CapstanKernel
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
    length_control: np.ndarray  # per tendon: its motor held cable lengths (else tensions)
    compliance: float           # B/(EA l^2) of the cables where they stick (0: inextensible)
    p_motor: np.ndarray         # (K, n) motor tensions (the first segments')
    cable_lengths: np.ndarray   # (K, n) whole cable lengths L_i (what the motors paid out)
    tip: np.ndarray             # (K, 2) tip positions
    tip_angle: np.ndarray       # (K,) theta(l)
    tensions: np.ndarray        # (K, P) tension of every segment (tendon by tendon)
    modes: np.ndarray           # (K, G) SLIP_IN / STICK / SLIP_OUT of every guide (row 0: STICK)
    wrap: np.ndarray            # (K, G) turning angle beta of the cable at every guide
    states: np.ndarray = field(repr=False)    # (K, size) w = (angles, chords, q)
    increments: int = 0         # Newton solves, halvings included
    iterations: int = 0         # Newton iterations of all increments
    converged: bool = True
    message: str = ""


def check_history(history, n_tendons: int, length_control) -> np.ndarray:
    """A (K, n) array, K >= 1: per tendon a tension (>= 0) or, for a length-controlled
    one, a cable length (> 0)."""
    history = np.atleast_2d(np.asarray(history, float))
    if history.ndim != 2 or history.shape[1] != n_tendons or len(history) == 0:
        raise InputError(f"a load history is a list of motor values with {n_tendons} "
                         f"values each (one per tendon); got shape {np.shape(history)}")
    for row in history:
        check_tensions(np.where(length_control, 0.0, row), n_tendons)
        if not (row[length_control] > 0).all():
            raise InputError(f"cable lengths must be positive, got {row[length_control].tolist()}")
    return history


def friction_path(disc: GuidedDiscretisation, mu, history, *, length_control=None,
                  start_tensions=None, max_step: float = 1.0, max_length_step: float = 2e-3,
                  compliance: float = 0.0, scale: float = DEFAULT_SCALE,
                  petsc_options=None) -> FrictionPath:
    """Follow the motor ``history`` (K, n) with friction ``mu`` at the guides (a scalar or
    one per guide): per tendon a tension or, where ``length_control`` (per tendon) is
    True, the cable length L_i (units of l).  The path starts from the frictionless
    equilibrium at ``start_tensions`` and reaches every row of ``history`` in turn; without
    ``start_tensions`` (force control only) it starts at history[0].  Increments change no
    tension by more than ``max_step`` and no length by more than ``max_length_step``.
    ``compliance``: B/(EA l^2) of the cables, their stretch where they stick (0:
    inextensible; docs/model.md §27.6)."""
    kernel = CapstanKernel.of(disc, mu, scale, length_control, compliance)
    held = kernel.length_control
    history = check_history(history, disc.n_tendons, held)
    if start_tensions is None:
        if held.any():
            raise InputError("a path with length-controlled motors needs start_tensions (the "
                             "frictionless state it starts from)")
        start_tensions, history = history[0], history[1:]
    start_tensions = check_tensions(start_tensions, disc.n_tendons)
    start = solve_equilibrium(disc, start_tensions)
    if not start.converged:
        return _no_path(kernel, f"no frictionless equilibrium at the first tensions: "
                                f"{start.message}")
    w = kernel.frictionless_state(start.u, start_tensions)
    motor = np.where(held, kernel.cable_material(w, start_tensions), start_tensions)
    rows, counts, message, secant = [], [0, 0], "", [None, 0.0]
    steps = np.where(held, max_length_step, max_step)
    with CapstanSolver(kernel, petsc_options=petsc_options) as solver:
        rows.append(_record(kernel, w, motor, None))
        for target in history:
            w, start, message = _advance(solver, w, motor, target, steps, counts, secant)
            if message:
                break
            motor = target
            rows.append(_record(kernel, w, motor, start))
    stack = {key: np.array([r[key] for r in rows]) for key in rows[0]}
    return FrictionPath(mu=kernel.mu, length_control=held, compliance=kernel.compliance,
                        increments=counts[0], iterations=counts[1], converged=not message,
                        message=message, **stack)


def _advance(solver: CapstanSolver, w, p_from, p_to, max_step: np.ndarray, counts, secant):
    """w at the motor values p_to from w at p_from in increments of at most ``max_step``
    (per tendon), halved on failure: (w, the start of the last increment
    (:class:`~elastica_petsc.core.friction.IncrementStart`), message).  Each Newton solve
    starts from the secant predictor w + (step / last step) dw of the last accepted
    increment (``secant``: [dw, its step in units of max_step], updated), so that the
    guides' slip continues in its direction and the modes are right from the first
    iterate (from w itself every trial value is a tie between the modes)."""
    kernel = solver.kernel
    span = float(np.max(np.abs(p_to - p_from) / max_step))
    steps = max(1, int(np.ceil(span)))
    done, step, halvings = 0.0, 1.0 / steps, 0
    while done < 1.0 - 1e-12:
        step = min(step, 1.0 - done)
        p = p_from + (done + step) * (p_to - p_from)
        start = kernel.start_of(w, p_from + done * (p_to - p_from))
        guess = w.copy()
        if secant[0] is not None and secant[1] > 0.0:
            guess += (step * span / secant[1]) * secant[0]
        trial, its, reason, ok = solver.increment(guess, p, start)
        counts[0] += 1
        counts[1] += its
        if not ok:
            halvings += 1
            if halvings > MAX_HALVINGS:
                return w, start, (f"the increment to the motor values {np.round(p, 6).tolist()} "
                                  f"did not converge ({reason}) after {MAX_HALVINGS} halvings"
                                  + _singular_hint(kernel, reason))
            step *= 0.5
            secant[0] = None
            continue
        slack = np.flatnonzero(kernel.length_control & (kernel.segment_tensions(
            trial, p)[kernel.first_segments] < 0))
        if slack.size:
            return w, start, (f"cable {slack[0] + 1} would go slack at the motor values "
                              f"{np.round(p, 6).tolist()}: slack cables are not modelled with "
                              "friction")
        secant[:] = [trial - w, step * span]
        w, done = trial, done + step
    return w, start, ""


def _no_path(kernel: CapstanKernel, message: str) -> FrictionPath:
    """A path that could not start: no rows, not converged, ``message`` says why."""
    disc, n = kernel.disc, kernel.disc.n_tendons
    empty = {"p_motor": (0, n), "cable_lengths": (0, n), "tip": (0, 2), "tip_angle": (0,),
             "tensions": (0, disc.n_points), "modes": (0, kernel.n_guides),
             "wrap": (0, kernel.n_guides), "states": (0, kernel.size)}
    arrays = {key: np.zeros(shape, int if key == "modes" else float)
              for key, shape in empty.items()}
    return FrictionPath(mu=kernel.mu, length_control=kernel.length_control,
                        compliance=kernel.compliance, converged=False, message=message, **arrays)


def _singular_hint(kernel: CapstanKernel, reason: str) -> str:
    """Why Newton may fail: with inextensible cables, antagonistic cables that stick on
    both sides of one span, or hold their lengths there, make the tensions (nearly)
    indeterminate (docs/model.md §27.6)."""
    if reason not in ("DIVERGED_LINEAR_SOLVE", "DIVERGED_DTOL") or kernel.compliance > 0:
        return ""
    return ("; with inextensible cables the tensions of antagonistic cables that stick, or "
            "hold their lengths, on both sides of one span are (nearly) indeterminate and the "
            "Jacobian (nearly) singular; give the cables' axial stiffness (cable_stiffness_N, "
            "--cable-stiffness-kN)")


def _record(kernel: CapstanKernel, w, motor, start) -> dict:
    """What the path keeps of the state w (its modes in the increment that reached it,
    measured from ``start``; None: the start of the path, every guide at rest, STICK)."""
    disc = kernel.disc
    theta = disc.split(kernel.split(w)[0])[0]
    tensions = kernel.segment_tensions(w, motor)
    return {"p_motor": tensions[kernel.first_segments], "cable_lengths": kernel.cable_lengths(w),
            "tip": disc.node_positions(theta)[-1], "tip_angle": theta[-1], "tensions": tensions,
            "modes": (np.full(kernel.n_guides, STICK) if start is None
                      else kernel.modes(w, motor, start)),
            "wrap": kernel.wrap_angles(w),
            "states": w}
