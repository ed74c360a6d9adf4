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

from .config import ConfigError, config_values, read_config
from .errors import InputError


class ModelError(InputError):
    """A physically or geometrically invalid arm; the message names the key."""


@dataclass(frozen=True)
class Guide:
    """A guide (spacer disk, eyelet) on the arm that a cable passes through:
    at arc length ``s_mm``, ``offset_mm`` along the normal to the left of the
    arm's tangent (docs/model.md §11)."""

    s_mm: float
    offset_mm: float = 0.0


@dataclass(frozen=True)
class Tendon:
    """One cable: from the fixed point ``route_mm`` (the motor end) through the
    ``guides`` in order, straight between consecutive points, to its end at arc
    length ``attach_mm``, ``attach_offset_mm`` along the left normal (Eqs. (3)-(4);
    without guides and offset, the paper's cable; docs/model.md §11)."""

    attach_mm: float
    route_mm: tuple[float, float]
    attach_offset_mm: float = 0.0
    guides: tuple[Guide, ...] = ()
    # Coulomb coefficient where the cable wraps its guides (capstan; docs/model.md §27):
    # only the friction load path models it, every other study refuses it (core/friction.py)
    friction_coefficient: float = 0.0

    @property
    def routed_straight(self) -> bool:
        """The paper's cable: straight from the routing point to the centreline."""
        return not self.guides and self.attach_offset_mm == 0.0


@dataclass(frozen=True)
class Motor:
    """Spool and stepper data used to turn cable lengths into motor steps."""

    spool_radius_mm: float = 31.0
    steps_per_rev: int = 200
    microsteps: int = 16
    max_tension_N: float | None = None  # P_crit of Eq. (22); None: no upper bound
    # stepper limits in microsteps/s and /s^2: one number, or one per tendon (core/motion.py)
    max_speed_steps_s: float | tuple[float, ...] | None = None
    max_accel_steps_s2: float | tuple[float, ...] | None = None


@dataclass(frozen=True)
class Limits:
    """Admissibility limits of the workspace (Eqs. (19)-(22))."""

    failure_strain: float = 0.025        # eps_Y, polycarbonate
    strain_energy_max_SE0: float = 18.0  # SE_max in units of B/(2l), Eq. (21)


@dataclass(frozen=True)
class Dynamics:
    """Damping and inertia options of the arm in motion (docs/model.md §16)."""

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
    guide_radius_mm: float | None = None     # offsets lie within +-this (None: width_mm/2)
    mass_per_length_kg_m: float | None = None
    youngs_modulus_Pa: float | None = None   # the material, when B came from it
    density_kg_m3: float | None = None       # the material, when the mass came from it
    gravity_m_s2: tuple[float, float] | None = None   # in the clamp's frame, arm along +x
    tip_mass_kg: float = 0.0
    motor: Motor = field(default_factory=Motor)
    limits: Limits = field(default_factory=Limits)
    dynamics: Dynamics = field(default_factory=Dynamics)

    def __post_init__(self) -> None:
        validate(self)

    @classmethod
    def paper(cls) -> "Arm":
        """The arm of the paper's Fig. 1 (``configs/paper.toml``)."""
        return load_config(None)

    @classmethod
    def from_toml(cls, path) -> "Arm":
        """An arm from a TOML configuration file (layout: ``configs/paper.toml``)."""
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

    @property
    def has_paths(self) -> bool:
        """Guides, offsets or weight: the kernel of docs/model.md §11 is needed."""
        return (not all(t.routed_straight for t in self.tendons)
                or np.any(self.gravity_load() != 0.0) or np.any(self.tip_weight() != 0.0))

    def gravity_load(self) -> np.ndarray:
        """q = rho_A g l^3 / B, the non-dimensional weight per length (docs/model.md §11)."""
        if self.gravity_m_s2 is None or self.mass_per_length_kg_m is None:
            return np.zeros(2)
        length_m = self.length_mm * 1e-3
        return (self.mass_per_length_kg_m * np.asarray(self.gravity_m_s2, float)
                * length_m**3 / self.bending_stiffness_Nm2)

    def tip_weight(self) -> np.ndarray:
        """m_tip g l^2 / B, the non-dimensional weight of the tip mass."""
        if self.gravity_m_s2 is None or not self.tip_mass_kg:
            return np.zeros(2)
        length_m = self.length_mm * 1e-3
        return (self.tip_mass_kg * np.asarray(self.gravity_m_s2, float)
                * length_m**2 / self.bending_stiffness_Nm2)

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
    for key in ("mass_per_length_kg_m", "youngs_modulus_Pa", "density_kg_m3",
                "guide_radius_mm"):
        if getattr(arm, key) is not None:
            positive(f"arm.{key}", getattr(arm, key))
    if not isinstance(arm.elements, int) or isinstance(arm.elements, bool) or arm.elements < 2:
        raise ModelError(f"arm.elements must be an integer >= 2, got {arm.elements!r}")
    from .inputs import elements
    elements(arm.elements, "arm.elements")
    if not isinstance(arm.tendons, (tuple, list)) or len(arm.tendons) < 1:
        raise ModelError("tendon: at least one [[tendon]] (an ep.Tendon) is needed")
    if arm.thickness_mm >= arm.length_mm:
        raise ModelError(f"arm.length_mm = {arm.length_mm:g} is not longer than the strip's "
                         f"thickness_mm = {arm.thickness_mm:g}: lengths are in millimetres "
                         "(typed in metres?)")
    _validate_weight(arm)
    for i, tendon in enumerate(arm.tendons, start=1):
        key = f"tendon[{i}]"
        if not isinstance(tendon, Tendon):
            raise ModelError(f"{key} must be an ep.Tendon(attach_mm, route_mm), got "
                             f"{type(tendon).__name__}")
        positive(f"{key}.attach_mm", tendon.attach_mm)
        if tendon.attach_mm > arm.length_mm * (1 + 1e-12):
            raise ModelError(
                f"{key}.attach_mm = {tendon.attach_mm} lies beyond the arm's length "
                f"{arm.length_mm} mm (need 0 < s_i <= l)")
        _validate_path(arm, tendon, key)
        _validate_friction(tendon, key)
        if len(tendon.route_mm) != 2 or not all(
                isinstance(c, (int, float)) and math.isfinite(c) for c in tendon.route_mm):
            raise ModelError(f"{key}.route_mm must be two numbers [x, y] in mm")
        if math.hypot(*tendon.route_mm) > MAX_ROUTE_DISTANCE * arm.length_mm:
            raise ModelError(f"{key}.route_mm lies more than {MAX_ROUTE_DISTANCE:g} arm lengths "
                             "from the clamp (a dead load is modelled well long before that)")
        first = tendon.guides[0] if tendon.guides else Guide(tendon.attach_mm,
                                                             tendon.attach_offset_mm)
        gap = math.hypot(tendon.route_mm[0] - first.s_mm, tendon.route_mm[1] - first.offset_mm)
        if gap < 1e-9 * arm.length_mm:
            raise ModelError(
                f"{key}.route_mm coincides with the cable's first point on the straight arm "
                "(a segment of zero length)")
    _distinct_tendons(arm)
    motor = arm.motor
    positive("motor.spool_radius_mm", motor.spool_radius_mm)
    for name in ("steps_per_rev", "microsteps"):
        value = getattr(motor, name)
        if not isinstance(value, int) or isinstance(value, bool) or value < 1:
            raise ModelError(f"motor.{name} must be a positive integer, got {value!r}")
    if motor.max_tension_N is not None:
        positive("motor.max_tension_N", motor.max_tension_N)
    from .motion import MotorLimits
    try:
        MotorLimits.of(motor, len(arm.tendons))
    except InputError as err:
        raise ModelError(str(err)) from None
    positive("limits.failure_strain", arm.limits.failure_strain)
    positive("limits.strain_energy_max_SE0", arm.limits.strain_energy_max_SE0)
    _warn_guide_extent(arm)


def _finite(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _validate_weight(arm: Arm) -> None:
    """Gravity needs a mass; a tip mass is >= 0 (docs/model.md §11)."""
    if not (_finite(arm.tip_mass_kg) and arm.tip_mass_kg >= 0):
        raise ModelError(f"arm.tip_mass_kg must be a number >= 0, got {arm.tip_mass_kg!r}")
    _validate_dynamics(arm.dynamics)
    if arm.gravity_m_s2 is None:
        return
    g = arm.gravity_m_s2
    if len(g) != 2 or not all(_finite(c) for c in g):
        raise ModelError(f"arm.gravity_m_s2 must be two numbers [gx, gy] in m/s^2, got {g!r}")
    if arm.mass_per_length_kg_m is None and not arm.tip_mass_kg and any(g):
        raise ModelError("arm.gravity_m_s2 is given but neither arm.mass_per_length_kg_m nor "
                         "arm.tip_mass_kg: gravity needs a mass")


def _validate_dynamics(dyn: Dynamics) -> None:
    if not (_finite(dyn.damping_ratio) and dyn.damping_ratio >= 0):
        raise ModelError(f"dynamics.damping_ratio must be a number >= 0, got {dyn.damping_ratio!r}")
    if not (_finite(dyn.kelvin_voigt_fraction) and 0 <= dyn.kelvin_voigt_fraction <= 1):
        raise ModelError("dynamics.kelvin_voigt_fraction must lie in [0, 1], got "
                         f"{dyn.kelvin_voigt_fraction!r}")


def _validate_path(arm: Arm, tendon: Tendon, key: str) -> None:
    """Guides on the arm, offsets within the arm's width, no two points of the
    path at one place (a segment of zero length has no direction)."""
    points = [(g.s_mm, g.offset_mm, f"{key}.guides[{j}]")
              for j, g in enumerate(tendon.guides, start=1)]
    points.append((tendon.attach_mm, tendon.attach_offset_mm, f"{key}.attach"))
    for s_mm, offset_mm, where in points:
        if not (_finite(s_mm) and _finite(offset_mm)):
            raise ModelError(f"{where}: arc length and offset must be numbers in mm")
        if not 0.0 < s_mm <= arm.length_mm * (1 + 1e-12):
            raise ModelError(f"{where}: s = {s_mm:g} mm lies outside the arm "
                             f"(need 0 < s <= l = {arm.length_mm:g} mm)")
        if abs(offset_mm) > guide_radius_mm(arm):
            raise ModelError(f"{where}: offset {offset_mm:g} mm is larger than "
                             + _guide_extent_text(arm))
    for j, (s0, d0, w0) in enumerate(points):
        for s1, d1, w1 in points[j + 1:]:
            _distinct(arm, (s0, d0, w0), (s1, d1, w1))


def _validate_friction(tendon: Tendon, key: str) -> None:
    """A friction coefficient >= 0, and > 0 only where the cable has guides to wrap."""
    mu = tendon.friction_coefficient
    if not (_finite(mu) and mu >= 0):
        raise ModelError(f"{key}.friction_coefficient must be a number >= 0, got {mu!r}")
    if mu > 0 and not tendon.guides:
        raise ModelError(f"{key}.friction_coefficient = {mu:g}: the cable has no guides to rub "
                         "on (friction acts where a cable wraps a guide)")


def guide_radius_mm(arm: Arm) -> float:
    """The largest offset of a guide or cable end from the centreline (mm):
    ``arm.guide_radius_mm``, or half of ``arm.width_mm`` where it is unset (the
    old meaning of width_mm, deprecated: :func:`_warn_guide_extent`)."""
    return 0.5 * arm.width_mm if arm.guide_radius_mm is None else arm.guide_radius_mm


def _guide_extent_text(arm: Arm) -> str:
    if arm.guide_radius_mm is not None:
        return f"arm.guide_radius_mm = {arm.guide_radius_mm:g} mm"
    return (f"half the arm's width (arm.width_mm = {arm.width_mm:g} mm; give "
            "arm.guide_radius_mm for the guides' extent)")


def _warn_guide_extent(arm: Arm) -> None:
    """A valid arm with offset guides or ends but no guide_radius_mm: warn once."""
    import warnings
    from .errors import InputDeprecation

    if arm.guide_radius_mm is not None or not (
            any(g.offset_mm for t in arm.tendons for g in t.guides)
            or any(t.attach_offset_mm for t in arm.tendons)):
        return
    warnings.warn(InputDeprecation(
        f"arm.width_mm = {arm.width_mm:g} bounds the guide offsets only because "
        f"arm.guide_radius_mm is not given; this use of width_mm is deprecated: add "
        f"guide_radius_mm = {0.5 * arm.width_mm:g} to [arm] (width_mm is the strip's width)"),
        stacklevel=2)


def _distinct(arm: Arm, a, b) -> None:
    (s0, d0, w0), (s1, d1, w1) = a, b
    if abs(s0 - s1) <= 1e-9 * arm.length_mm and abs(d0 - d1) <= 1e-9 * arm.length_mm:
        raise ModelError(f"{w0} and {w1} are at one point (s = {s0:g} mm, offset "
                         f"{d0:g} mm): two points of one cable must differ")


def arm_from_dict(data: dict) -> Arm:
    """Build an Arm from parsed TOML (mm, N m^2, N; layout of core/config.py)."""
    values = config_values(data)
    tendons = tuple(Tendon(**{**t, "guides": tuple(Guide(**g) for g in t["guides"])})
                    for t in values["tendons"])
    return Arm(tendons=tendons,
               motor=Motor(**values["motor"]), limits=Limits(**values["limits"]),
               dynamics=Dynamics(**values["dynamics"]), **values["arm"])


def load_config(path=None) -> Arm:
    """Read a TOML file (default: the paper's arm) into a validated Arm."""
    path, data = read_config(path)
    try:
        return arm_from_dict(data)
    except (ConfigError, ModelError) as err:
        raise ConfigError(f"{path}: {err}") from None

def _distinct_tendons(arm: Arm) -> None:
    """Two tendons with one path (routing point, guides, end point) pull as one:
    the tip map's Jacobian (Eq. (13)) is singular everywhere; refuse them."""
    seen = {}
    for i, t in enumerate(arm.tendons, start=1):
        points = [*t.route_mm, *(v for g in t.guides for v in (g.s_mm, g.offset_mm)),
                  t.attach_mm, t.attach_offset_mm]
        key = tuple(round(v / arm.length_mm, 9) for v in points)
        if key in seen:
            raise ModelError(f"tendon[{i}] is the same as tendon[{seen[key]}] (attach_mm "
                             f"{t.attach_mm:g}, route_mm {list(t.route_mm)}): two identical "
                             "tendons act as one; merge them")
        seen[key] = i
