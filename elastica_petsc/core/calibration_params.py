"""The parameters a calibration can vary, and how they enter the model
(docs/model.md §14).  Numpy only; physical units (mm, N m^2, degrees).

Names (``vary``; ``--vary`` on the command line), each a group of one or two scalars:

    bending_stiffness   B [N m^2] (tension rows only: p = P l^2 / B)
    tendonK.route       routing point r_K = (x, y) [mm], in the frame of the config
    motorK.offset       the unknown zero of motor K: the actual cable length is the
                        commanded one plus the offset [mm] (length and steps rows)
    motor.spool_radius  spool radius [mm] (steps rows: 2 pi r per revolution)
    clamp.angle         rotation alpha of the clamp against the config frame [deg]
    clamp.position      position c of the clamp in the config frame [mm]
    frame.rotation      rotation beta of the measurement frame [deg]
    frame.offset        origin t of the measurement frame [mm]

The model of Sec. 2 has the clamp at the origin along +x.  With a clamp at c
turned by alpha, the routing points seen by the arm are rho_K = R(-alpha)(r_K - c)
(its own frame: these are the routes of the fitted TOML), a point x of the arm
lies at c + R(alpha) x in the config frame, and it is measured at

    m = t + R(beta) (c + R(alpha) x).

Length rows: L_K = length_K_mm + offset_K.  Steps rows (motors zeroed with the
arm straight and unloaded): L_K = |rho_K - (s_K, 0)| + offset_K
+ steps_K 2 pi r / (steps_per_rev microsteps); through guides, the straight
arm's path length from rho_K through the guides (s, offset) to the end
(:func:`straight_lengths`).  An arm with weight is not straight when unloaded:
its steps rows are refused (studies/calibrate.py).
"""
from __future__ import annotations

import dataclasses
import math
import re
from dataclasses import dataclass

import numpy as np

from .errors import InputError
from .model import Arm, Motor


class ParameterError(InputError):
    """An unknown or unusable calibration parameter or bound."""


# how a message names the options: the library's keywords; the command line passes
# its flags ({"vary": "--vary", ...}) so that each layer names what its user typed
LIBRARY_NAMES = {"vary": "vary=", "bounds": "bounds=", "input": "input="}


def said(names: dict | None, key: str, value=None) -> str:
    """``key`` as the user wrote it: ``vary='x'`` (library) or ``--vary 'x'`` (CLI)."""
    flag = (names or LIBRARY_NAMES)[key]
    if value is None:
        return flag.rstrip("=")
    return f"{flag}{value}" if flag.endswith("=") else f"{flag} {value}"


GROUPS = ("bending_stiffness", "tendonK.route", "motorK.offset", "motor.spool_radius",
          "clamp.angle", "clamp.position", "frame.rotation", "frame.offset",
          "tendonK.attach")
_INDEXED = re.compile(r"^(tendon|motor)(\d+)\.(route|offset|attach)$")


@dataclass(frozen=True)
class Parameter:
    """One scalar of the calibration vector: its name (``tendon2.route.x``), the
    group it belongs to (``tendon2.route``), unit, start value, scale (a
    typical change, for the scaled Jacobian) and bounds."""

    name: str
    group: str
    unit: str
    start: float
    scale: float
    lower: float
    upper: float


def _group_parameters(group: str, arm: Arm, names=None) -> list[Parameter]:
    """Scalars, units, starts, scales and default bounds of one ``vary`` name."""
    vary = said(names, "vary", repr(group))
    if group == "bending_stiffness":
        b = arm.bending_stiffness_Nm2
        return [Parameter(group, group, "N m^2", b, 0.1 * b, 0.2 * b, 5.0 * b)]
    if group == "motor.spool_radius":
        r = arm.motor.spool_radius_mm
        return [Parameter(group, group, "mm", r, 0.05 * r, 0.5 * r, 1.5 * r)]
    if group in ("clamp.angle", "frame.rotation"):
        return [Parameter(group, group, "deg", 0.0, 1.0, -15.0, 15.0)]
    if group in ("clamp.position", "frame.offset"):
        return [Parameter(f"{group}.{a}", group, "mm", 0.0, 5.0, -50.0, 50.0) for a in "xy"]
    m = _INDEXED.match(group)
    if m is None:
        raise ParameterError(f"{vary}: unknown parameter (known: {', '.join(GROUPS)})")
    kind, k, what = m.group(1), int(m.group(2)), m.group(3)
    if not 1 <= k <= arm.n_tendons or (kind, what) not in (
            ("tendon", "route"), ("motor", "offset"), ("tendon", "attach")):
        if (kind, what) in (("tendon", "route"), ("motor", "offset")):
            raise ParameterError(f"{vary}: the arm has tendons 1..{arm.n_tendons}")
        raise ParameterError(f"{vary}: unknown parameter (known: {', '.join(GROUPS)})")
    if what == "attach":
        raise ParameterError(f"{vary}: attachment points sit on mesh nodes, so they are not a "
                             "continuous parameter of this model; ep.calibrate and the "
                             "calibrate command search them node by node "
                             "(studies/calibrate_attach.py)")
    if what == "route":
        x, y = arm.tendons[k - 1].route_mm
        return [Parameter(f"{group}.x", group, "mm", x, 5.0, x - 50.0, x + 50.0),
                Parameter(f"{group}.y", group, "mm", y, 5.0, y - 50.0, y + 50.0)]
    return [Parameter(group, group, "mm", 0.0, 1.0, -30.0, 30.0)]


def parse_bounds(texts, names=None) -> dict[str, tuple[float, float]]:
    """``NAME=LO:HI`` (a scalar such as ``tendon1.route.x`` or a one-scalar group)."""
    out = {}
    for text in texts or ():
        name, _, rng = str(text).partition("=")
        lo, _, hi = rng.partition(":")
        try:
            out[name.strip()] = (float(lo), float(hi))
        except ValueError:
            raise ParameterError(f"{said(names, 'bounds', repr(text))}: expected NAME=LO:HI, e.g. "
                                 "bending_stiffness=0.1:0.4") from None
    return out


def has_weight(arm: Arm) -> bool:
    """Gravity acts on the arm or its tip mass (docs/model.md §11.5)."""
    return bool(np.any(arm.gravity_load() != 0.0) or np.any(arm.tip_weight() != 0.0))


def straight_lengths(arm: Arm, rho_mm) -> tuple[np.ndarray, np.ndarray]:
    """Cable lengths [mm] (n,) on the straight unloaded arm for routing points
    ``rho_mm`` (n, 2), through the guides (at (s, offset)), and dL/drho (n, 2):
    only the first segment, from rho to the first point, moves with rho."""
    L, grad = [], []
    for t, r in zip(arm.tendons, np.asarray(rho_mm, float)):
        pts = np.array([(g.s_mm, g.offset_mm) for g in t.guides]
                       + [(t.attach_mm, t.attach_offset_mm)])
        first = r - pts[0]
        reach = float(np.linalg.norm(first))
        L.append(reach + float(np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1))))
        grad.append(first / reach)
    return np.array(L), np.array(grad)


def rotation(deg: float) -> np.ndarray:
    a = math.radians(deg)
    return np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])


def rotation_derivative(deg: float) -> np.ndarray:
    """d R / d(degrees)."""
    a = math.radians(deg)
    return math.radians(1.0) * np.array([[-math.sin(a), -math.cos(a)],
                                         [math.cos(a), -math.sin(a)]])


class ParameterModel:
    """The calibration vector theta (physical units) of ``vary`` about ``arm``:
    the arm it describes, the row drives and the measurement transform, each
    with its derivative with respect to theta (module docstring)."""

    def __init__(self, arm: Arm, vary, bounds: dict | None = None, names: dict | None = None):
        """``names``: how messages name the options (:data:`LIBRARY_NAMES`; the
        command line passes its flags)."""
        vary = [vary] if isinstance(vary, str) else list(vary)
        if not vary:
            raise ParameterError(f"{said(names, 'vary')}: name at least one parameter, e.g. "
                                 "bending_stiffness")
        if len(set(vary)) != len(vary):
            raise ParameterError(f"{said(names, 'vary')}: "
                                 f"{next(v for v in vary if vary.count(v) > 1)!r} given twice")
        if "clamp.angle" in vary and has_weight(arm):
            raise ParameterError(
                f"{said(names, 'vary', repr('clamp.angle'))}: not supported for an arm with "
                "weight (turning the clamp would turn gravity in the arm's frame, a "
                "derivative the calibration does not have); vary frame.rotation instead")
        self.arm0, self.groups = arm, vary
        params = [p for g in vary for p in _group_parameters(g, arm, names)]
        known = {p.name for p in params}
        for name, (lo, hi) in (bounds or {}).items():
            if name not in known:
                raise ParameterError(f"{said(names, 'bounds', name)}: not a varied scalar "
                                     f"(varied: {', '.join(p.name for p in params)})")
            if not lo < hi:
                raise ParameterError(f"{said(names, 'bounds', name)}: need LO < HI, got "
                                     f"{lo:g}:{hi:g}")
        params = [dataclasses.replace(p, lower=bounds[p.name][0], upper=bounds[p.name][1])
                  if bounds and p.name in bounds else p for p in params]
        for p in params:
            if not p.lower <= p.start <= p.upper:
                raise ParameterError(f"{said(names, 'bounds', p.name)}: [{p.lower:g}, "
                                     f"{p.upper:g}] excludes "
                                     f"the start value {p.start:g} {p.unit}")
        self.params = params
        self.index = {p.name: j for j, p in enumerate(params)}

    # --- the vector ----------------------------------------------------------------------
    @property
    def size(self) -> int:
        return len(self.params)

    @property
    def names(self) -> list[str]:
        return [p.name for p in self.params]

    def start(self) -> np.ndarray:
        return np.array([p.start for p in self.params])

    def scales(self) -> np.ndarray:
        return np.array([p.scale for p in self.params])

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return (np.array([p.lower for p in self.params]),
                np.array([p.upper for p in self.params]))

    def _get(self, theta, name: str, default: float) -> float:
        j = self.index.get(name)
        return default if j is None else float(theta[j])

    def values(self, theta) -> dict:
        """Every model quantity at theta (varied or not), physical units."""
        arm, n = self.arm0, self.arm0.n_tendons
        get = lambda name, default: self._get(theta, name, default)   # noqa: E731
        routes = np.array([[get(f"tendon{k}.route.{a}", arm.tendons[k - 1].route_mm[i])
                            for i, a in enumerate("xy")] for k in range(1, n + 1)])
        return {"bending_stiffness": get("bending_stiffness", arm.bending_stiffness_Nm2),
                "routes": routes,
                "offsets": np.array([get(f"motor{k}.offset", 0.0) for k in range(1, n + 1)]),
                "spool_radius": get("motor.spool_radius", arm.motor.spool_radius_mm),
                "clamp_angle": get("clamp.angle", 0.0),
                "clamp_position": np.array([get(f"clamp.position.{a}", 0.0) for a in "xy"]),
                "frame_rotation": get("frame.rotation", 0.0),
                "frame_offset": np.array([get(f"frame.offset.{a}", 0.0) for a in "xy"])}

    def column(self, name: str) -> np.ndarray:
        e = np.zeros(self.size)
        if name in self.index:
            e[self.index[name]] = 1.0
        return e

    # --- the arm in its own frame -------------------------------------------------------
    def arm_routes(self, theta) -> tuple[np.ndarray, np.ndarray]:
        """rho_K = R(-alpha)(r_K - c) [mm], (n, 2), and d rho / d theta, (n, 2, P)."""
        v = self.values(theta)
        alpha, c = v["clamp_angle"], v["clamp_position"]
        Rt = rotation(-alpha)
        rel = v["routes"] - c
        rho = rel @ Rt.T
        d = np.zeros(rho.shape + (self.size,))
        dRt = -rotation_derivative(-alpha)
        for k in range(len(rho)):
            for i, a in enumerate("xy"):
                d[k, :, :] += np.outer(Rt[:, i], self.column(f"tendon{k + 1}.route.{a}"))
                d[k, :, :] -= np.outer(Rt[:, i], self.column(f"clamp.position.{a}"))
            d[k, :, :] += np.outer(dRt @ rel[k], self.column("clamp.angle"))
        return rho, d

    def arm(self, theta) -> Arm:
        """The arm in its own frame (clamp at the origin along +x) at theta."""
        v = self.values(theta)
        rho = self.arm_routes(theta)[0]
        tendons = tuple(dataclasses.replace(t, route_mm=(float(r[0]), float(r[1])))
                        for t, r in zip(self.arm0.tendons, rho))
        motor = dataclasses.replace(self.arm0.motor, spool_radius_mm=v["spool_radius"])
        return dataclasses.replace(self.arm0, bending_stiffness_Nm2=v["bending_stiffness"],
                                   tendons=tendons, motor=motor)

    # --- the inputs of a row ------------------------------------------------------------
    def tensions(self, theta, tensions_N) -> tuple[np.ndarray, np.ndarray]:
        """p = P l^2 / B (n,) and dp/dtheta (n, P)."""
        b = self.values(theta)["bending_stiffness"]
        l_m = self.arm0.length_mm * 1e-3
        p = np.asarray(tensions_N, float) * l_m**2 / b
        return p, np.outer(-p / b, self.column("bending_stiffness"))

    def lengths(self, theta, kind: str, inputs) -> tuple[np.ndarray, np.ndarray]:
        """Actual cable lengths L [mm] (n,) of a length or steps row and dL/dtheta (n, P)."""
        v = self.values(theta)
        n = self.arm0.n_tendons
        L = np.asarray(inputs, float) + v["offsets"]
        dL = np.array([self.column(f"motor{k}.offset") for k in range(1, n + 1)])
        if kind == "steps":
            motor: Motor = self.arm0.motor
            per_step = 2.0 * math.pi / (motor.steps_per_rev * motor.microsteps)
            rho, drho = self.arm_routes(theta)
            straight, direction = straight_lengths(self.arm0, rho)
            L = straight + v["offsets"] + np.asarray(inputs, float) * per_step * v["spool_radius"]
            dL = dL + np.einsum("kc,kcp->kp", direction, drho) \
                + np.outer(np.asarray(inputs, float) * per_step,
                           self.column("motor.spool_radius"))
        return L, dL

    # --- the measurement frame ----------------------------------------------------------
    def measure(self, theta, x_mm) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Points x [mm] of the arm (k, 2) as measured: m (k, 2), dm/dx (2, 2) and
        the explicit dm/dtheta (k, 2, P)."""
        v = self.values(theta)
        a, b, c, t = (v["clamp_angle"], v["frame_rotation"], v["clamp_position"],
                      v["frame_offset"])
        Ra, Rb = rotation(a), rotation(b)
        x = np.atleast_2d(np.asarray(x_mm, float))
        world = c + x @ Ra.T
        m = t + world @ Rb.T
        d = np.zeros(x.shape + (self.size,))
        d += np.einsum("kc,p->kcp", x @ (Rb @ rotation_derivative(a)).T,
                       self.column("clamp.angle"))
        d += np.einsum("kc,p->kcp", world @ rotation_derivative(b).T,
                       self.column("frame.rotation"))
        for i, axis in enumerate("xy"):
            d += np.einsum("c,p->cp", Rb[:, i], self.column(f"clamp.position.{axis}"))[None]
            d[:, i, :] += self.column(f"frame.offset.{axis}")[None]
        return m, Rb @ Ra, d
