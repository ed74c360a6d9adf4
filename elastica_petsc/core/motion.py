"""Motor speed and acceleration limits, and the fastest timing of a schedule under them.

docs/model.md, section "Motor-aware schedules".  A schedule's rows k = 0..K-1
hold each motor's planned position q_ik [microsteps] (cable length change /
mm per microstep, before rounding: the integer steps follow it within half a
microstep).  A controller plays the move into row k (k >= 1), of duration d_k,
at the constant rate

    r_ik = (q_ik - q_i,k-1) / d_k                         [microsteps/s]

and, passing row j, changes the rate from r_ij to r_i,j+1 over the time
between the two moves' midpoints, an acceleration

    a_ij = (r_i,j+1 - r_ij) / ((d_j + d_j+1) / 2)         [microsteps/s^2]

with the motors at rest before row 0 and after the last row (r_i0 = r_iK = 0,
d_0 = d_K = 0).  A schedule is playable if |r_ik| <= V_i and |a_ij| <= A_i for
every motor i.  :func:`check` recomputes both from any schedule;
:func:`retime` finds the shortest durations that satisfy them with the tip
no faster than a given speed along the same rows.

Retiming.  With u_k = 1/d_k the speed limits and the tip speed cap each u_k
(u_k <= min(V_i / |dq_ik|, v / |dtip_k|)); the acceleration limit between
moves k and m = k +- 1, on the side where move k's term is positive
(alpha = |dq_ik| > 0, beta = sign(dq_ik) dq_im), reads

    alpha u_k - A_i / (2 u_k) <= beta u_m + A_i / (2 u_m) = c

an upper bound u_k <= (c + sqrt(c^2 + 2 alpha A_i)) / (2 alpha).  A forward pass
applies it with m = k - 1 (acceleration into move k, from rest for k = 1:
c = 0), a backward pass with m = k + 1 (deceleration out of it); the passes
only lower u and repeat until nothing moves, so the result satisfies every
bound: the forward/backward velocity-profile algorithm of time-optimal path
following with per-axis speed and acceleration limits.  Each u_k is as large
as its own caps and its neighbours allow; the total time is compared with the
lower bound sum_k 1 / cap_k (speeds only) in tests/test_motion.py.  The bound
c grows as the neighbour slows (A_i / (2 u_m)), so slowing a short move can
let its neighbours run faster, which the passes (they only lower u) miss:
where an acceleration limit binds, :func:`.motion_chain.chain_speeds` finds
the shortest schedule over a grid of speeds by dynamic programming along the
chain of moves, and it replaces the passes' schedule when shorter.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .errors import InputError
from .motion_chain import chain_speeds

RELATIVE_TOLERANCE = 1e-9      # of a limit, for rates recomputed from rounded floats
_MAX_PASSES = 400
_FAST = 1e9                    # 1/s: a move that nothing bounds takes 1 ns


def per_tendon(value, n: int, name: str) -> np.ndarray:
    """A limit given once for every motor or once per tendon, as (n,) (inf: none)."""
    if value is None:
        return np.full(n, np.inf)
    values = np.atleast_1d(np.asarray(value, dtype=float))
    if values.size == 1:
        values = np.full(n, values[0])
    if values.shape != (n,):
        raise InputError(f"{name} must be one number or one per tendon ({n}), got {value!r}")
    if not np.all((values > 0) & np.isfinite(values)):
        raise InputError(f"{name} must be positive, got {value!r}")
    return values


@dataclass(frozen=True)
class MotorLimits:
    """Per motor (tendon) i: speed V_i [microsteps/s] and acceleration A_i
    [microsteps/s^2]; inf where the motor has no such limit."""

    speed_steps_s: np.ndarray
    accel_steps_s2: np.ndarray

    @classmethod
    def of(cls, motor, n: int) -> "MotorLimits | None":
        """The limits of a :class:`~elastica_petsc.core.model.Motor` ([motor]
        max_speed_steps_s, max_accel_steps_s2), None if it gives neither."""
        if motor.max_speed_steps_s is None and motor.max_accel_steps_s2 is None:
            return None
        return cls(per_tendon(motor.max_speed_steps_s, n, "motor.max_speed_steps_s"),
                   per_tendon(motor.max_accel_steps_s2, n, "motor.max_accel_steps_s2"))

    def to_json(self) -> dict:
        def listed(a):
            return [None if math.isinf(v) else float(v) for v in a]
        return {"max_speed_steps_s": listed(self.speed_steps_s),
                "max_accel_steps_s2": listed(self.accel_steps_s2)}


def rates_and_accelerations(positions_steps, durations_s):
    """r (K-1, n): rate of each move into rows 1..K-1; a (K, n): acceleration
    passing each row (rest before row 0 and after the last), as in the module
    docstring.  A move of zero duration and zero length has rate 0."""
    q = np.asarray(positions_steps, float)
    d = np.asarray(durations_s, float)
    dq = np.diff(q, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(dq == 0.0, 0.0, dq / d[:, None])
    padded = np.vstack([np.zeros((1, q.shape[1])), r, np.zeros((1, q.shape[1]))])
    span = 0.5 * (np.concatenate(([0.0], d)) + np.concatenate((d, [0.0])))
    with np.errstate(divide="ignore", invalid="ignore"):
        jump = np.diff(padded, axis=0)
        a = np.where(jump == 0.0, 0.0, jump / span[:, None])
    return r, a


@dataclass(frozen=True)
class Violation:
    """Row ``row`` asks motor ``motor`` (1-based) for ``value`` above ``limit``
    (``kind``: ``speed`` in microsteps/s, ``accel`` in microsteps/s^2)."""

    row: int
    motor: int
    kind: str
    value: float
    limit: float

    def to_json(self) -> dict:
        return {"row": self.row, "motor": self.motor, "kind": self.kind,
                "value": float(f"{self.value:.6g}"), "limit": self.limit}


def check(positions_steps, durations_s, limits: MotorLimits) -> list[Violation]:
    """Every (row, motor) whose rate or acceleration exceeds its limit (by more
    than RELATIVE_TOLERANCE of it), in row order."""
    r, a = rates_and_accelerations(positions_steps, durations_s)
    out = []
    for kind, values, limit, first_row in (("speed", r, limits.speed_steps_s, 1),
                                           ("accel", a, limits.accel_steps_s2, 0)):
        over = np.abs(values) > limit * (1 + RELATIVE_TOLERANCE)
        for k, i in zip(*np.nonzero(over)):
            out.append(Violation(int(k + first_row), int(i + 1), kind, float(values[k, i]),
                                 float(limit[i])))
    return sorted(out, key=lambda v: (v.row, v.motor, v.kind))


@dataclass(frozen=True)
class Timing:
    """Durations d_k of the moves into rows 1..K-1 and what bounds each one:
    ``tip_speed``, ``speed_I`` or ``accel_I`` (motor I, 1-based) or ``none``."""

    durations_s: np.ndarray
    limited_by: np.ndarray
    speed_bound_s: float       # sum_k 1 / cap_k: no schedule under the limits is shorter

    @property
    def time_s(self) -> np.ndarray:
        return np.concatenate(([0.0], np.cumsum(self.durations_s)))


def _caps(dq, dtip, limits, speed_mm_s):
    """Largest u_k from the speed limits and the tip speed, and which one binds."""
    K1, n = dq.shape
    with np.errstate(divide="ignore"):
        bounds = np.column_stack(
            [np.full(K1, np.inf) if speed_mm_s is None else speed_mm_s / dtip,
             limits.speed_steps_s[None, :] / np.abs(dq)])
    names = np.array(["tip_speed"] + [f"speed_{i}" for i in range(1, n + 1)], dtype=object)
    which = np.argmin(bounds, axis=1)
    caps = bounds[np.arange(K1), which]
    labels = np.where(np.isfinite(caps), names[which], "none").astype(object)
    return np.minimum(caps, _FAST), labels


def _pass(u, labels, dq, accel, order, step) -> bool:
    moved = False
    K1, n = dq.shape
    for k in order:
        m = k + step
        for i in range(n):
            if dq[k, i] == 0.0 or math.isinf(accel[i]):
                continue
            alpha = abs(dq[k, i])
            if 0 <= m < K1:
                c = math.copysign(1.0, dq[k, i]) * dq[m, i] * u[m] + accel[i] / (2.0 * u[m])
            else:
                c = 0.0                               # from or to rest
            bound = (c + math.sqrt(c * c + 2.0 * alpha * accel[i])) / (2.0 * alpha)
            if bound < u[k] * (1 - 1e-15):
                u[k], labels[k], moved = bound, f"accel_{i + 1}", True
    return moved


def retime(positions_steps, limits: MotorLimits, *, tips_mm=None,
           speed_mm_s: float | None = None) -> Timing:
    """The shortest durations of the moves between rows such that no motor
    exceeds ``limits`` and the tip (``tips_mm`` (K, 2)) moves no faster than
    ``speed_mm_s`` (module docstring)."""
    q = np.asarray(positions_steps, float)
    if q.ndim != 2 or len(q) < 2:
        raise InputError(f"a schedule to time needs at least two rows, got shape {q.shape}")
    dq = np.diff(q, axis=0)
    dtip = (np.zeros(len(dq)) if tips_mm is None
            else np.linalg.norm(np.diff(np.asarray(tips_mm, float), axis=0), axis=1))
    caps, cap_labels = _caps(dq, dtip, limits, speed_mm_s)
    speed_bound_s = float(np.sum(1.0 / caps))
    u, labels = caps.copy(), cap_labels.copy()
    forward, backward = range(len(u)), range(len(u) - 1, -1, -1)
    for _ in range(_MAX_PASSES):
        moved = _pass(u, labels, dq, limits.accel_steps_s2, forward, -1)
        moved = _pass(u, labels, dq, limits.accel_steps_s2, backward, +1) or moved
        if not moved:
            break
    if np.any(np.isfinite(limits.accel_steps_s2)) and np.any(u < caps * (1 - 1e-12)):
        chain = chain_speeds(dq, caps, u, limits.accel_steps_s2)   # motion_chain docstring
        shorter = np.sum(1.0 / chain) < np.sum(1.0 / u) * (1 - 1e-12)
        if shorter and not check(q, 1.0 / chain, limits):     # playable, checked again
            u = chain
            labels = np.where(u >= caps * (1 - 1e-9), cap_labels,
                              _binding_accel(dq, u, limits.accel_steps_s2)).astype(object)
    return Timing(1.0 / u, labels, speed_bound_s)


def _binding_accel(dq, u, accel) -> np.ndarray:
    """Per move, ``accel_I`` of the motor whose acceleration limit at either end
    of the move is nearest to binding (the move's speed is below its cap)."""
    r = dq * u[:, None]
    rates = np.vstack([np.zeros(dq.shape[1]), r, np.zeros(dq.shape[1])])
    span = 0.5 * (np.concatenate(([0.0], 1.0 / u)) + np.concatenate((1.0 / u, [0.0])))
    with np.errstate(divide="ignore", invalid="ignore"):
        use = np.abs(np.diff(rates, axis=0)) / span[:, None] / accel[None, :]
    use = np.nan_to_num(use, nan=0.0)
    worst = np.maximum(use[:-1], use[1:])                 # the two rows around each move
    return np.array([f"accel_{i + 1}" for i in np.argmax(worst, axis=1)], dtype=object)


def step_events(positions_steps, time_s, motor: int) -> np.ndarray:
    """The step/direction timing of one motor (0-based index): rows (time_s,
    direction, position_steps) with direction +1 (pay out) or -1 (reel in), one
    per microstep, at the times the planned position, moving at constant rate
    between rows, crosses a half-integer (so the position after each step is
    the rounded planned position, the schedule's ``steps`` column at rows)."""
    q = np.asarray(positions_steps, float)[:, motor]
    t = np.asarray(time_s, float)
    out = []
    for k in range(1, len(q)):
        q0, q1 = q[k - 1], q[k]
        n0, n1 = int(np.rint(q0)), int(np.rint(q1))
        if n1 == n0:
            continue
        direction = 1 if n1 > n0 else -1
        targets = np.arange(n0 + direction, n1 + direction, direction)
        crossing = targets - 0.5 * direction
        times = t[k - 1] + (crossing - q0) / (q1 - q0) * (t[k] - t[k - 1])
        out.append(np.column_stack([times, np.full(len(targets), direction), targets]))
    return np.vstack(out) if out else np.zeros((0, 3))
