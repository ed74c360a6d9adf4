"""The tendon-actuated arm as data: geometry, tendons, limits and units.

Everything a user types is in the paper's units (mm, N m^2, N).  The solvers
work in the non-dimensional form of docs/model.md §3: lengths in units of the arm
length l, tensions p = P l^2 / B, energies in units of SE_0 = B / (2 l),
curvature as l * kappa.  The conversions live here and nowhere else.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .errors import InputError


class ModelError(InputError):
    """A physically or geometrically invalid arm; the message names the key."""


@dataclass(frozen=True)
class Tendon:
    """One cable: attached to the centreline at arc length ``attach_mm`` and
    routed in a straight line to the fixed point ``route_mm`` (Eqs. (3)-(4))."""

    attach_mm: float
    route_mm: tuple[float, float]


@dataclass(frozen=True)
class Motor:
    """Spool and stepper data used to turn cable lengths into motor steps."""

    spool_radius_mm: float = 31.0
    steps_per_rev: int = 200
    microsteps: int = 16
    max_tension_N: float | None = None  # P_crit of Eq. (22); None: no upper bound


@dataclass(frozen=True)
class Limits:
    """Admissibility limits of the workspace (Eqs. (19)-(22))."""

    failure_strain: float = 0.025        # eps_Y, polycarbonate
    strain_energy_max_SE0: float = 18.0  # SE_max in units of B/(2l), Eq. (21)


@dataclass(frozen=True)
class Dynamics:
    """Damping and inertia options of the arm in motion (docs/model.md §11)."""

    damping_ratio: float = 0.0           # zeta_1: damping ratio of the unloaded first mode
    kelvin_voigt_fraction: float = 0.5   # share of zeta_1 from Kelvin-Voigt (stiffness) damping
    rotary_inertia: bool = False         # add rho I theta_dot^2 / 2 (I = A h^2 / 12)


@dataclass(frozen=True)
class Arm:
    """A planar inextensible elastica clamped at the origin along +x (Sec. 2)."""

    length_mm: float
    bending_stiffness_Nm2: float
    tendons: tuple[Tendon, ...]
    elements: int = 180
    thickness_mm: float = 3.0
    width_mm: float = 40.0
    mass_per_length_kg_m: float | None = None
    tip_mass_kg: float = 0.0
    motor: Motor = field(default_factory=Motor)
    limits: Limits = field(default_factory=Limits)
    dynamics: Dynamics = field(default_factory=Dynamics)

    def __post_init__(self) -> None:
        validate(self)

    @classmethod
    def paper(cls) -> "Arm":
        """The arm of the paper's Fig. 1 (``configs/paper.toml``)."""
        from .config import load_config
        return load_config(None)

    @classmethod
    def from_toml(cls, path) -> "Arm":
        """An arm from a TOML configuration file (layout: ``configs/paper.toml``)."""
        from .config import load_config
        return load_config(path)

    # --- unit conversions (docs/model.md §3) -------------------------------------
    @property
    def force_scale_N(self) -> float:
        """B / l^2 in newtons: P = p * force_scale_N."""
        length_m = self.length_mm * 1e-3
        return self.bending_stiffness_Nm2 / length_m**2

    @property
    def energy_scale_J(self) -> float:
        """SE_0 = B / (2 l) in joules."""
        return self.bending_stiffness_Nm2 / (2.0 * self.length_mm * 1e-3)

    @property
    def n_tendons(self) -> int:
        return len(self.tendons)

    def attachments(self) -> np.ndarray:
        """Attachment arc lengths s_i / l."""
        return np.array([t.attach_mm for t in self.tendons]) / self.length_mm

    def routes(self) -> np.ndarray:
        """Routing points r_i / l, shape (n, 2)."""
        return np.array([t.route_mm for t in self.tendons], dtype=float) / self.length_mm

    def to_mm(self, values) -> np.ndarray:
        """Lengths in units of l to millimetres."""
        return np.asarray(values, dtype=float) * self.length_mm

    def from_mm(self, values_mm) -> np.ndarray:
        """Millimetres to lengths in units of l."""
        return np.asarray(values_mm, dtype=float) / self.length_mm

    def tensions_to_N(self, p) -> np.ndarray:
        return np.asarray(p, dtype=float) * self.force_scale_N

    def tensions_from_N(self, P) -> np.ndarray:
        return np.asarray(P, dtype=float) / self.force_scale_N

    @property
    def max_tension(self) -> float | None:
        """The motor force limit as a non-dimensional tension, or None."""
        if self.motor.max_tension_N is None:
            return None
        return self.motor.max_tension_N / self.force_scale_N

    @property
    def kappa_limit(self) -> float:
        """l * kappa_max allowed by Eq. (19): 2 eps_Y l / h."""
        return 2.0 * self.limits.failure_strain * self.length_mm / self.thickness_mm


MAX_ROUTE_DISTANCE = 1e12     # arm lengths: far beyond any dead load (tests use 1e6 l)


def validate(arm: Arm) -> None:
    """Raise ModelError with one line naming the offending key."""

    def positive(name: str, value) -> None:
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise ModelError(f"{name} must be a positive number, got {value!r}")

    positive("arm.length_mm", arm.length_mm)
    positive("arm.bending_stiffness_Nm2", arm.bending_stiffness_Nm2)
    positive("arm.thickness_mm", arm.thickness_mm)
    positive("arm.width_mm", arm.width_mm)
    if arm.mass_per_length_kg_m is not None:
        positive("arm.mass_per_length_kg_m", arm.mass_per_length_kg_m)
    if not (isinstance(arm.tip_mass_kg, (int, float)) and math.isfinite(arm.tip_mass_kg)
            and arm.tip_mass_kg >= 0):
        raise ModelError(f"arm.tip_mass_kg must be a number >= 0, got {arm.tip_mass_kg!r}")
    dyn = arm.dynamics
    if not (isinstance(dyn.damping_ratio, (int, float)) and math.isfinite(dyn.damping_ratio)
            and dyn.damping_ratio >= 0):
        raise ModelError(f"dynamics.damping_ratio must be a number >= 0, got {dyn.damping_ratio!r}")
    if not (isinstance(dyn.kelvin_voigt_fraction, (int, float))
            and 0 <= dyn.kelvin_voigt_fraction <= 1):
        raise ModelError("dynamics.kelvin_voigt_fraction must lie in [0, 1], got "
                         f"{dyn.kelvin_voigt_fraction!r}")
    if not isinstance(arm.elements, int) or isinstance(arm.elements, bool) or arm.elements < 2:
        raise ModelError(f"arm.elements must be an integer >= 2, got {arm.elements!r}")
    if len(arm.tendons) < 1:
        raise ModelError("tendon: at least one [[tendon]] is needed")
    for i, tendon in enumerate(arm.tendons, start=1):
        key = f"tendon[{i}]"
        positive(f"{key}.attach_mm", tendon.attach_mm)
        if tendon.attach_mm > arm.length_mm * (1 + 1e-12):
            raise ModelError(
                f"{key}.attach_mm = {tendon.attach_mm} lies beyond the arm's length "
                f"{arm.length_mm} mm (need 0 < s_i <= l)")
        if len(tendon.route_mm) != 2 or not all(
                isinstance(c, (int, float)) and math.isfinite(c) for c in tendon.route_mm):
            raise ModelError(f"{key}.route_mm must be two numbers [x, y] in mm")
        if math.hypot(*tendon.route_mm) > MAX_ROUTE_DISTANCE * arm.length_mm:
            raise ModelError(f"{key}.route_mm lies more than {MAX_ROUTE_DISTANCE:g} arm lengths "
                             "from the clamp (a dead load is modelled well long before that)")
        gap = math.hypot(tendon.route_mm[0] - tendon.attach_mm, tendon.route_mm[1])
        if gap < 1e-9 * arm.length_mm:
            raise ModelError(
                f"{key}.route_mm coincides with its attachment point on the straight arm "
                "(a cable of zero length)")
    motor = arm.motor
    positive("motor.spool_radius_mm", motor.spool_radius_mm)
    for name in ("steps_per_rev", "microsteps"):
        value = getattr(motor, name)
        if not isinstance(value, int) or isinstance(value, bool) or value < 1:
            raise ModelError(f"motor.{name} must be a positive integer, got {value!r}")
    if motor.max_tension_N is not None:
        positive("motor.max_tension_N", motor.max_tension_N)
    positive("limits.failure_strain", arm.limits.failure_strain)
    positive("limits.strain_energy_max_SE0", arm.limits.strain_energy_max_SE0)
