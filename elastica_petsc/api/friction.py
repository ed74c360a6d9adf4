"""Quasi-static load paths with capstan friction at the guides, in mm and N
(docs/model.md §27): :func:`friction_path` and its :class:`FrictionResult`."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.errors import InputError
from ..core.model import Arm
from ..core.results import Result
from ..studies.friction import FrictionPath
from .arguments import mesh as _mesh, takes_petsc_options as _takes_petsc_options


@dataclass(frozen=True, repr=False)
class FrictionResult(Result):
    """A load path of ``arm`` with friction coefficient(s) ``path.mu`` at its guides:
    one row per point of the history (the start first); ``path`` holds the solver's
    non-dimensional values."""

    arm: Arm
    path: FrictionPath

    @property
    def converged(self) -> bool:
        return bool(self.path.converged)

    @property
    def message(self) -> str:
        return self.path.message

    @property
    def tip_mm(self) -> np.ndarray:
        """(K, 2) tip positions, mm."""
        return self.arm.to_mm(self.path.tip)

    @property
    def motor_tensions_N(self) -> np.ndarray:
        """(K, n) tension of each cable at its motor, N."""
        return self.arm.tensions_to_N(self.path.p_motor)

    @property
    def segment_tensions_N(self) -> np.ndarray:
        """(K, P) tension of every cable segment (each cable from its motor), N."""
        return self.arm.tensions_to_N(self.path.tensions)

    @property
    def cable_lengths_mm(self) -> np.ndarray:
        """(K, n) whole cable lengths, mm."""
        return self.arm.to_mm(self.path.cable_lengths)

    @property
    def wrap_deg(self) -> np.ndarray:
        """(K, G) the angle the cable turns through at each guide, degrees."""
        return np.degrees(self.path.wrap)

    @property
    def modes(self) -> np.ndarray:
        """(K, G) -1 slip toward the motor, 0 stick, +1 slip toward the end, per guide."""
        return self.path.modes

    def summary(self) -> dict:
        """The JSON object of ``elastica-petsc friction --json`` (docs/json.md): the
        friction coefficients, whether the path converged, and per row of the path the
        motors' tensions and cable lengths, the tip, every segment's tension and every
        guide's mode and wrap angle."""
        fp = self.path
        return {"mu": fp.mu.tolist(), "length_control": fp.length_control.tolist(),
                "converged": bool(fp.converged), "message": fp.message,
                "increments": int(fp.increments), "newton_iterations": int(fp.iterations),
                "motor_tensions_N": self.motor_tensions_N.tolist(),
                "cable_lengths_mm": self.cable_lengths_mm.tolist(),
                "tip_mm": self.tip_mm.tolist(),
                "segment_tensions_N": self.segment_tensions_N.tolist(),
                "modes": fp.modes.tolist(), "wrap_deg": self.wrap_deg.tolist()}


@_takes_petsc_options
def friction_path(arm: Arm, history, *, mu=None, length_control=None, start_tensions_N=None,
                  elements: int | None = None, max_step_N: float | None = None,
                  cable_stiffness_N: float | None = None) -> FrictionResult:
    """Follow the motors through ``history`` (K rows, one value per tendon: its motor
    tension in N, or for a tendon with ``length_control`` True its cable length in mm)
    with Coulomb friction ``mu`` (a scalar, or one per guide; default the arm's
    ``[[tendon]] friction_coefficient``) where the cables wrap the guides: capstan stick
    and slip at every guide (docs/model.md §27).  The path starts
    from the frictionless equilibrium at ``start_tensions_N`` (default: history[0], with
    every motor under force control).  ``max_step_N``: the largest tension change of one
    increment (default B/l^2, one non-dimensional unit).  ``cable_stiffness_N``: the
    cables' axial stiffness EA, their stretch where they stick (default inextensible;
    needed where cables stick on both sides of one span, docs/model.md §27.6)."""
    from ..core.friction import guide_friction
    from ..studies.friction import friction_path as follow

    disc = _mesh(arm, elements, friction=True)
    if not disc.has_paths:
        raise InputError("friction acts at guides: give the arm's cables guides "
                         "([[tendon]] guides = [...])")
    history = np.atleast_2d(np.asarray(history, float))
    if history.ndim != 2 or history.shape[1] != arm.n_tendons:
        raise InputError(f"history must hold {arm.n_tendons} values per row (one per tendon), "
                         f"got shape {history.shape}")
    held = np.zeros(arm.n_tendons, bool) if length_control is None else np.broadcast_to(
        np.asarray(length_control, bool), (arm.n_tendons,))
    scaled = np.where(held, history / arm.length_mm, history / arm.force_scale_N)
    start = None if start_tensions_N is None else \
        np.asarray(start_tensions_N, float) / arm.force_scale_N
    step = 1.0 if max_step_N is None else float(max_step_N) / arm.force_scale_N
    if not step > 0:
        raise InputError(f"max_step_N must be positive, got {max_step_N}")
    mu = guide_friction(arm) if mu is None else mu
    compliance = 0.0
    if cable_stiffness_N is not None:
        from ..core.inputs import positive
        compliance = arm.force_scale_N / positive(cable_stiffness_N, "cable_stiffness_N", "N")
    return FrictionResult(arm, follow(disc, mu, scaled, length_control=held,
                                      start_tensions=start, max_step=step,
                                      compliance=compliance))
