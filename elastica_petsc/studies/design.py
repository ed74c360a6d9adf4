"""Designing the arm for a task: routing points that make a path traceable (issue 13).

Objective ``path``: the targets x_k (mm) of a path must all be reachable,
i.e. lie in W_0 (tips of stable equilibria connected to the straight arm by
quasi-static loading with all P_i >= 0).  For routing points q (mm, two per
varied tendon) the path is traced as ``trace`` does (tip control, Eqs.
(10)-(12), each target warm-started from the previous one), and

    f(q) = sum_k E_k(q),    E_k = min_{p >= 0} |x_t(p; q) - x_k|^2 / 2   [mm^2]

is zero exactly when every target is reached.  Its gradient is exact
(Danskin's theorem: at the minimiser p_k* of each E_k, with the active bounds
fixed, the derivative of the minimum is the partial derivative at fixed p):

    dE_k/dq = (x_t - x_k) . d x_t/d q |_{p = p_k*}

and d x_t/d r_i at fixed tensions is one more right-hand side of the bordered
tangent: J du/dr_i = -dF/dr_i (:meth:`Manifold.route_derivative`, the
border columns of tendon i of the Jacobian with the sign changed).  The
derivative is verified by a Taylor test (tests/test_design.py).  TAO BLMVM
minimises f within bounds: every routing point stays in a box of
+- ``reach_mm`` about its start and ``clearance_mm`` off the arm's line y = 0
on its side (the cable never starts across the straight arm).  A margin: the
optimisation runs on a circle-like path scaled by ``margin`` about its
centroid (a path a little larger than the task), and stops when f = 0.

Attachments and guide arc lengths sit on mesh nodes: they are varied by the
area objective's pattern search and by sweeps (studies/design_nodes.py), not here.
"""
from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field

import numpy as np

from ..core.results import Result
from ..core.errors import InputError
from ..core.fem import Discretisation
from ..core.model import Arm
from ..solvers.continuation import CurveTracer, TensionBound
from ..solvers.control import TipController
from ..solvers.minimise import minimise_bounded


class DesignError(InputError):
    """A design request that cannot be carried out (one line for the user)."""


def parse_design_variables(names, n_tendons: int, arm: Arm | None = None
                           ) -> tuple[list[int], list]:
    """``tendonK.route`` -> route tendons (0-based), ``tendonK.attach`` /
    ``tendonK.guideJ.s`` -> points on mesh nodes (:class:`~.design_nodes.NodePoint`,
    checked against ``arm``), in order, no repeats."""
    from .design_nodes import NAME, node_point

    routes, points = [], []
    for name in names:
        head, _, what = name.partition(".")
        if not head.startswith("tendon") or not head[6:].isdigit() or (
                what != "route" and (NAME.match(name) is None or arm is None)):
            raise DesignError(f"--vary {name!r}: expected tendonK.route, tendonK.attach or "
                              "tendonK.guideJ.s (or a guide offset, tendonK.offset or "
                              "tendonK.guideJ.offset), e.g. tendon1.route")
        k = int(head[6:])
        if not 1 <= k <= n_tendons:
            raise DesignError(f"--vary {name!r}: the arm has tendons 1..{n_tendons}")
        chosen, item = (routes, k - 1) if what == "route" else (points,
                                                                node_point(name, arm, "--vary"))
        if item in chosen:
            raise DesignError(f"--vary {name!r} given twice")
        chosen.append(item)
    if not routes and not points:
        raise DesignError("--vary: name at least one design variable, e.g. tendon2.route")
    return routes, points


def parse_vary(names, n_tendons: int) -> list[int]:
    """Routing points only (the path objective): ``tendonK.route`` -> K-1."""
    from .design_nodes import NAME

    for name in names:
        if NAME.match(name):
            raise DesignError(f"--vary {name}: attachment points and guide positions sit on "
                              "mesh nodes, so the path objective's gradient optimiser does not "
                              f"vary them; use --objective area or --sweep {name}=START:STOP:STEP")
    return parse_design_variables(names, n_tendons)[0]


def with_attachment(arm: Arm, tendon: int, s_mm: float) -> Arm:
    """The arm with tendon ``tendon``'s attachment at arc length ``s_mm`` (guides kept)."""
    from .design_nodes import NodePoint

    return NodePoint(tendon).placed(arm, s_mm)


def with_routes(arm: Arm, tendons, q_mm) -> Arm:
    """The arm with the routing points of ``tendons`` set to q (mm, 2 per tendon)."""
    new = list(arm.tendons)
    for j, i in enumerate(tendons):
        new[i] = dataclasses.replace(new[i], route_mm=(float(q_mm[2 * j]), float(q_mm[2 * j + 1])))
    return dataclasses.replace(arm, tendons=tuple(new))


def route_bounds(arm: Arm, tendons, reach_mm: float, clearance_mm: float):
    """Lower and upper bounds (mm) of the design vector (module docstring)."""
    lo, hi = [], []
    for i in tendons:
        x, y = arm.tendons[i].route_mm
        lo.append(x - reach_mm); hi.append(x + reach_mm)
        if y < 0:
            lo.append(y - reach_mm); hi.append(min(y + reach_mm, -clearance_mm))
        else:
            lo.append(max(y - reach_mm, clearance_mm)); hi.append(y + reach_mm)
    lo, hi = np.array(lo), np.array(hi)
    if np.any(lo > hi):
        raise DesignError(f"a routing point lies within {clearance_mm:g} mm of the arm's line "
                          "y = 0: move it off the arm first")
    return lo, hi


def design_vector(arm: Arm, tendons, offsets, reach_mm: float, clearance_mm: float):
    """(q0, lo, hi, designed) of a design by routing points and offsets: the
    start q0 (mm: the routing points of ``tendons``, then the offsets of
    ``offsets``), its bounds (:func:`route_bounds`,
    :func:`~.design_offsets.offset_bounds`) and ``designed(q)``, the arm of a
    design vector."""
    from .design_offsets import offset_bounds, with_offsets

    n_routes = 2 * len(tendons)
    q0 = np.concatenate([np.asarray(arm.tendons[i].route_mm, float) for i in tendons]
                        + [[v.value_mm(arm) for v in offsets]])
    bounds = [route_bounds(arm, tendons, reach_mm, clearance_mm),
              offset_bounds(arm, offsets, reach_mm)]
    lo, hi = (np.concatenate([b[k] for b in bounds]) for k in (0, 1))

    def designed(q):
        return with_offsets(with_routes(arm, tendons, q[:n_routes]), offsets, q[n_routes:])

    return q0, lo, hi, designed


@dataclass
class PathMisfit:
    """f = sum_k E_k [mm^2] of a path for one design, its gradient [mm^2/mm] and
    the per-target outcome."""

    f: float
    gradient: np.ndarray
    reached: np.ndarray
    errors_mm: np.ndarray
    p: np.ndarray


def path_misfit(arm: Arm, tendons, targets_mm, elements: int | None = None,
                offsets=()) -> PathMisfit:
    """Trace the targets (warm-started tip control, from the straight arm with
    the sampler's head guess p = 2) and differentiate f (module docstring) with
    respect to the routing points of ``tendons`` and then the guide offsets
    ``offsets`` (studies/design_offsets.py)."""
    from contextlib import ExitStack
    from ..solvers.sensitivity import SensitivitySolver
    from .design_offsets import offset_residual_derivative

    disc = Discretisation.from_arm(arm, elements)
    targets = np.asarray(targets_mm, float)
    grad = np.zeros(2 * len(tendons) + len(offsets))
    f, reached, errors, tensions = 0.0, [], [], []
    with TipController(arm, n_elements=disc.n_elements) as ctl, CurveTracer(disc) as tracer, \
            ExitStack() as stack:
        sens = stack.enter_context(SensitivitySolver(disc)) if offsets else None
        start, p0 = None, np.full(disc.n_tendons, 2.0)
        for x_d in targets:
            res = ctl.solve_mm(x_d, p0=p0 if start is None else None, start=start)
            start = res.equilibrium
            reached.append(bool(res.converged))
            errors.append(res.tip_error_mm)
            tensions.append(res.p)
            if res.converged:
                continue
            residual_mm = res.tip_mm - x_d
            f += 0.5 * float(residual_mm @ residual_mm)
            w = np.concatenate((res.equilibrium.u, res.p))
            rows = [TensionBound(tracer.mf, j, res.p[j]) for j in range(2)]
            for j, i in enumerate(tendons):
                dw = tracer.route_velocity(w, rows, i)                 # per unit of l
                dtip = np.column_stack([tracer.mf.tip_velocity(w, dw[:, c]) for c in range(2)])
                grad[2 * j:2 * j + 2] += residual_mm @ dtip            # mm^2 per mm
            for j, var in enumerate(offsets, start=2 * len(tendons)):  # at fixed tensions
                eq = res.equilibrium
                dtip = sens.parameter_derivative(eq, offset_residual_derivative(
                    eq.disc, eq.u, eq.p, var, arm))[1]
                grad[j] += residual_mm @ dtip
    return PathMisfit(f, grad, np.array(reached), np.array(errors), np.array(tensions))


@dataclass(frozen=True, repr=False)
class DesignResult(Result):
    """History and outcome of a path design (mm, mm^2)."""

    arm_before: Arm
    arm_after: Arm
    tendons: list
    misfit_before: PathMisfit
    misfit_after: PathMisfit
    history: list = field(default_factory=list)
    reason: str = ""
    iterations: int = 0
    evaluations: int = 0
    seconds: float = 0.0
    offsets: list = field(default_factory=list)     # OffsetVariable (design_offsets.py)

    def summary(self) -> dict:
        """What ``design --json`` prints for a path (targets reached before/after)."""
        from ..io.summaries import path_design_summary

        return path_design_summary(self)


def scaled_path(targets_mm, margin: float) -> np.ndarray:
    """The path scaled by ``margin`` about its centroid (margin 1: unchanged)."""
    t = np.asarray(targets_mm, float)
    c = t.mean(axis=0)
    return c + margin * (t - c)


def design_for_path(arm: Arm, tendons, targets_mm, *, elements: int | None = None,
                    reach_mm: float = 100.0, clearance_mm: float = 10.0, margin: float = 1.1,
                    max_iterations: int = 20, scale_mm: float = 10.0,
                    options_prefix: str = "design_", progress=None,
                    offsets=(), stop=None) -> DesignResult:
    """Routing points (mm) of ``tendons`` (0-based) that make every target of the
    path reachable (f = 0 on the path scaled by ``margin``), by TAO BLMVM with
    the exact gradient of the module docstring.  Options prefix ``design_``.
    ``progress(traces, note)``, if given, is called after every path trace
    (one per objective evaluation; their number is not known in advance).
    ``stop()``, if given, is asked at every iteration: True ends the
    optimisation there (a time budget, core/budget.py)."""
    if margin < 1.0:
        raise DesignError(f"--margin must be at least 1, got {margin}")
    t0 = time.perf_counter()
    q0, lo, hi, designed = design_vector(arm, tendons, offsets, reach_mm, clearance_mm)
    design_path = scaled_path(targets_mm, margin)
    history, best = [], {}

    def objective(q):
        m = path_misfit(designed(q), tendons, design_path, elements, offsets)
        history.append({"q_mm": q.tolist(), "f_mm2": m.f, "reached": int(m.reached.sum()),
                        "gradient": m.gradient.tolist()})
        if not best or m.f < best["f"]:
            best.update(f=m.f, q=q.copy())
        if progress is not None:
            progress(len(history), f"TAO iteration {status.get('iteration', 0)} of at most "
                     f"{max_iterations}; misfit {m.f:.3g} mm^2, {history[-1]['reached']}/"
                     f"{len(design_path)} reached")
        return m.f, m.gradient

    status = {}
    reason, iterations = minimise_bounded(objective, q0, lo, hi, scale_mm=scale_mm,
                                          max_iterations=max_iterations,
                                          options_prefix=options_prefix,
                                          done=lambda: (bool(best) and best["f"] == 0.0)
                                          or (stop is not None and stop()),
                                          status=status)
    after = designed(best["q"])
    if progress is not None:
        progress(len(history), "tracing the task's path on the arm before and after")
    before_misfit = path_misfit(arm, tendons, targets_mm, elements)
    after_misfit = path_misfit(after, tendons, targets_mm, elements)
    return DesignResult(arm, after, list(tendons), before_misfit, after_misfit, history, reason,
                        iterations, len(history), time.perf_counter() - t0, list(offsets))
