"""Calibration: the parameters that make the model explain measured states
(issue 23; docs/model.md §14).

Residuals, one pair (x, y) per measured point (tip, markers) and row [mm]:

    r(theta) = m(x(z_row(theta); theta); theta) - measured

with the row's equilibrium z_row (load or length control, branch of its
loading order) and the measurement map m of
:mod:`elastica_petsc.core.calibration_params`.  Its Jacobian is exact: the
row derivatives of :mod:`elastica_petsc.solvers.calibration` (implicit
function theorem on the bordered tangent) chained with d rho/d theta and
d drive/d theta.  TAO BRGN (bounded regularised Gauss-Newton, prefix
``calib_``; TAO POUNDERS, derivative-free, as a check) minimises |W^(1/2) r|^2 / 2 in scaled variables
X = (theta - theta_0) / scale within the bounds; its proximal regulariser
lambda |X - X_k|^2 / 2 vanishes at convergence and keeps directions the data
cannot determine where they are.  Robust loss (``huber_mm`` = delta): the
weights W of a row's points are w = min(1, delta / |e|) of the row's largest
point error |e| (iteratively reweighted, Huber's M-estimator); rows with
w < 1 are reported.

Rows without a ``loading`` order are matched, at the start parameters, to
the loading path from the straight arm (proportional or any order) whose
equilibrium explains them best; the match is reported and kept.
"""
from __future__ import annotations

import itertools
import time
from dataclasses import dataclass, field

import numpy as np

from ..core.calibration_data import CalibrationData
from ..core.calibration_params import ParameterModel, has_weight
from ..core.errors import InputError
from ..solvers.calibration import RowError, RowSolver, RowState
from ..solvers.lengths import SAME_SHAPE_TOL
from ..solvers.least_squares import METHODS, bounded_least_squares

# Convergence: no scaled parameter moved by more in one Gauss-Newton iteration.
STEP_TOL = 1e-7


class CalibrationError(InputError):
    """A calibration that cannot be carried out as asked (one line)."""


def order_label(order) -> str:
    return "proportional" if order is None else "order " + ",".join(map(str, order))


@dataclass(frozen=True)
class Evaluation:
    """Residuals [mm] (M,), Jacobian [mm per parameter unit] (M, P) or None,
    predicted points (m, 1 + k, 2) [mm], and per row the taut cables."""

    residual: np.ndarray
    jacobian: np.ndarray | None
    points_mm: np.ndarray
    taut: np.ndarray


class CalibrationProblem:
    """Rows of ``data`` and the parameters of ``model``: residuals and their
    Jacobian at any theta, with each row warm-started from its last state.
    With ``comm`` (mpi4py) the rows are dealt round-robin to its ranks (each
    keeps its rows' states) and the results shared with every rank, which all
    run the same (small) TAO iteration on identical data."""

    def __init__(self, model: ParameterModel, data: CalibrationData,
                 elements: int | None = None, comm=None):
        if data.n_tendons != model.arm0.n_tendons:
            raise CalibrationError(f"the data have {data.n_tendons} tendons, the arm "
                                   f"{model.arm0.n_tendons}")
        self.model, self.data, self.elements = model, data, elements
        self.observed = data.observed()
        self.measured = data.points_mm()
        n_obs = int(self.observed.sum()) * 2
        if n_obs <= model.size:
            raise CalibrationError(f"{data.n_rows} rows give {n_obs} measured coordinates for "
                                   f"{model.size} parameters: need more coordinates than "
                                   "parameters")
        if has_weight(model.arm0) and "steps" in set(data.kinds):
            line = data.lines[list(data.kinds).index("steps")]
            raise CalibrationError(f"line {line}: motor steps on an arm with weight are not "
                                   "supported (the steps count from the straight unloaded "
                                   "arm, and an arm under its weight is not straight); give "
                                   "the cable lengths (length_K_mm columns)")
        self.weight_column = has_weight(model.arm0) and "bending_stiffness" in model.index
        self.states: list[RowState | None] = [None] * data.n_rows
        self.recent: list = []              # (scaled theta, states) of the last evaluations
        self.orders = list(data.loading)
        self.matched = [order is None for order in data.loading]
        self.row_of = np.repeat(np.nonzero(self.observed)[0], 2)
        self.evaluations = 0
        self.failed_trials = 0              # trial points with a row out of reach
        self.comm = comm                    # mpi4py communicator: rows dealt to its ranks
        self.rank, self.ranks = (0, 1) if comm is None else (comm.rank, comm.size)

    # --- rows --------------------------------------------------------------------------
    def _drive(self, theta, r: int):
        kind, inputs = self.data.kinds[r], self.data.inputs[r]
        if kind == "tension":
            return "tension", *self.model.tensions(theta, inputs), None
        L, dL = self.model.lengths(theta, kind, inputs)
        if np.any(L <= 0):
            raise CalibrationError(f"line {self.data.lines[r]}: a cable length <= 0 at these "
                                   "parameters (check the motor offsets and spool radius)")
        l_mm = self.model.arm0.length_mm
        return "length", L / l_mm, dL, L / l_mm

    def _over_rows(self, arm, work) -> dict:
        """{row: work(rs, row)} for every row; rows are dealt round-robin to the
        ranks of ``comm`` and the results shared (an error on any rank is
        raised on every rank)."""
        results, error = {}, None
        with RowSolver(arm, self.elements) as rs:
            try:
                for r in range(self.rank, self.data.n_rows, self.ranks):
                    results[r] = work(rs, r)
            except (RowError, CalibrationError) as err:
                error = err
        if self.comm is not None and self.ranks > 1:
            gathered = self.comm.allgather((results, error))
            errors = [e for _, e in gathered if e is not None]
            error = errors[0] if errors else None
            results = {r: v for part, _ in gathered for r, v in part.items()}
        if error is not None:
            raise error
        return results

    def match_branches(self, theta) -> list[str]:
        """Fix the loading order of every row without one (module docstring);
        returns one label per row ("given: order 2,1", "matched: proportional")."""
        arm = self.model.arm(theta)
        n, N = arm.n_tendons, self.elements or arm.elements
        candidates = [None] + (list(itertools.permutations(range(1, n + 1))) if n <= 3 else [])

        def match(rs, r):
            if not self.matched[r]:
                return self.orders[r], self.states[r]
            mode, drive, _, _ = self._drive(theta, r)
            best = None
            for order in candidates:
                state = rs.solve(mode, drive, order)
                if not state.converged:
                    continue
                pts = self.model.measure(theta, rs.points_mm(state.u, self.data.marker_s_mm))[0]
                err = float(np.sum(((pts - self.measured[r]) ** 2)[self.observed[r]]))
                if best is None or (err < best[0] and np.max(np.abs(
                        state.u - best[2].u)[:N]) > SAME_SHAPE_TOL):
                    best = (err, order, state)
            if best is None:
                raise CalibrationError(f"line {self.data.lines[r]}: no loading path from "
                                       "the straight arm reaches this row's equilibrium")
            return best[1], best[2]

        for r, (order, state) in self._over_rows(arm, match).items():
            self.orders[r] = order
            if r % self.ranks == self.rank:
                self.states[r] = state
        self.recent = []                  # states of other orders are no warm starts now
        return [("matched: " if m else "given: ") + order_label(o)
                for m, o in zip(self.matched, self.orders)]

    # A row whose lengths admit several equilibria can come back on another branch when
    # warm-started from a trial point's state; warm-starting every row from the states of
    # the nearest recent evaluation (in scaled parameters) returns the same states at a
    # theta evaluated before (docs/model.md §19.2).
    RECENT = 8

    def _nearest_states(self, theta) -> list:
        if not self.recent:
            return list(self.states)
        x = (np.asarray(theta, float) - self.model.start()) / self.model.scales()
        return min(self.recent, key=lambda item: float(np.sum((item[0] - x) ** 2)))[1]

    def _remember(self, theta) -> None:
        x = (np.asarray(theta, float) - self.model.start()) / self.model.scales()
        self.recent = (self.recent + [(x, list(self.states))])[-self.RECENT:]

    def evaluate(self, theta, jacobian: bool = True) -> Evaluation:
        """Residuals and (optionally) the exact Jacobian at theta."""
        model, data = self.model, self.data
        theta = np.asarray(theta, float)
        self.evaluations += 1
        try:
            arm = model.arm(theta)
        except InputError as err:
            raise CalibrationError(f"the parameters left the valid arms: {err}") from None
        rho_d = model.arm_routes(theta)[1].reshape(-1, model.size)
        n = arm.n_tendons
        d_weight = -model.column("bending_stiffness")[None, :] / arm.bending_stiffness_Nm2
        warm = self._nearest_states(theta)

        def row(rs, r):
            mode, drive, d_drive, L = self._drive(theta, r)
            state = rs.solve(mode, drive, self.orders[r], warm=warm[r])
            if not state.converged:
                raise RowError(f"line {data.lines[r]}: equilibrium not reached "
                               f"({state.message})")
            self.states[r] = state
            m, A, explicit = model.measure(theta, rs.points_mm(state.u, data.marker_s_mm))
            if not jacobian:
                return m, None, state.p > 1e-8
            dq = rs.derivatives(mode, state, L, data.marker_s_mm, weight=self.weight_column)
            dx = dq[:, :, : 2 * n] @ rho_d + dq[:, :, 2 * n:3 * n] @ d_drive
            if self.weight_column:        # q ~ 1/B: the weight's factor moves by -dB/B
                dx += dq[:, :, 3 * n:] @ d_weight
            return m, (np.einsum("ab,kbp->kap", A, dx) + explicit)[self.observed[r]], \
                state.p > 1e-8

        rows = self._over_rows(arm, row)
        self._remember(theta)
        pts_all = np.array([rows[r][0] for r in range(data.n_rows)])
        taut = np.array([rows[r][2] for r in range(data.n_rows)])
        residual = (pts_all - self.measured)[self.observed].ravel()
        jac = (np.concatenate([rows[r][1] for r in range(data.n_rows)]).reshape(-1, model.size)
               if jacobian else None)
        return Evaluation(residual, jac, pts_all, taut)


# --- the least-squares solve ------------------------------------------------------------------
def least_squares(problem: CalibrationProblem, theta0, weights, *, method: str = "brgn",
                  max_iterations: int = 50, step_tol: float = STEP_TOL,
                  prefix: str = "calib_") -> tuple[np.ndarray, str, int]:
    """TAO on X = (theta - theta0) / scale within the bounds; ``weights`` (M,)
    multiply the squared residuals.  ``method`` "brgn": bounded regularised
    Gauss-Newton with the exact Jacobian, converged (CONVERGED_USER) when an
    iteration of its subsolver moves no scaled parameter by more than
    ``step_tol`` or lowers the objective by less than F_RTOL of itself (the
    gradient cannot fall below the round-off of the equilibria, residuals
    ~1e-8 mm).  "pounders": derivative-free (residuals only, a check of the
    Jacobian's optimum), converged on its model gradient (POUNDERS_GATOL).
    A trial point whose rows cannot be solved gets residuals of
    FAILED_RESIDUAL (mm), so the step is refused; all by
    :func:`~elastica_petsc.solvers.least_squares.bounded_least_squares`.
    Returns (theta, TAO's reason, iterations)."""
    if method not in METHODS:
        raise CalibrationError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    model = problem.model
    scale = model.scales()
    lo, hi = model.bounds()
    sqrt_w = np.sqrt(weights)

    def evaluate(X, jacobian):
        ev = problem.evaluate(theta0 + scale * X, jacobian=jacobian)
        return sqrt_w * ev.residual, (None if ev.jacobian is None
                                      else sqrt_w[:, None] * ev.jacobian * scale[None, :])

    def failed() -> None:
        problem.failed_trials += 1

    X, reason, iterations = bounded_least_squares(
        evaluate, model.size, len(weights), (lo - theta0) / scale, (hi - theta0) / scale,
        method=method, max_iterations=max_iterations, step_tol=step_tol,
        failures=(RowError, CalibrationError), on_failure=failed, prefix=prefix)
    return theta0 + scale * X, reason, iterations


def huber_weights(problem: CalibrationProblem, residual, delta_mm: float | None):
    """Per-coordinate weights (M,) and per-row weights (m,) of Huber's loss."""
    rows = np.ones(problem.data.n_rows)
    if delta_mm is not None:
        pairs = np.asarray(residual).reshape(-1, 2)
        errors = np.zeros(problem.data.n_rows)
        np.maximum.at(errors, problem.row_of[::2], np.hypot(pairs[:, 0], pairs[:, 1]))
        rows = np.where(errors > delta_mm, delta_mm / np.maximum(errors, 1e-300), 1.0)
    return rows[problem.row_of], rows


@dataclass(frozen=True)
class Fit:
    """The fitted parameters and what the fit did."""

    theta: np.ndarray
    evaluation: Evaluation
    weights: np.ndarray            # per coordinate (M,)
    row_weights: np.ndarray        # per row (m,): < 1: down-weighted by the Huber loss
    reason: str
    iterations: int
    evaluations: int
    seconds: float
    branches: list = field(default_factory=list)
    method: str = "brgn"


def fit(problem: CalibrationProblem, theta0=None, *, huber_mm: float | None = None,
        method: str = "brgn", max_iterations: int = 50, reweightings: int = 8,
        prefix: str = "calib_") -> Fit:
    """Least-squares fit from ``theta0`` (default: the model's start), branches
    matched first, by :func:`least_squares` (``method``); with ``huber_mm``
    iteratively reweighted until the row weights settle (at most
    ``reweightings`` fits)."""
    t0 = time.perf_counter()
    theta = problem.model.start() if theta0 is None else np.asarray(theta0, float)
    branches = problem.match_branches(theta)
    ev = problem.evaluate(theta, jacobian=False)
    weights, rows = huber_weights(problem, ev.residual, huber_mm)
    iterations, reason = 0, ""
    for _ in range(reweightings if huber_mm is not None else 1):
        theta, reason, its = least_squares(problem, theta, weights, method=method,
                                           max_iterations=max_iterations, prefix=prefix)
        iterations += its
        ev = problem.evaluate(theta)
        new_weights, new_rows = huber_weights(problem, ev.residual, huber_mm)
        settled = np.allclose(new_rows, rows, rtol=1e-6, atol=1e-9)
        weights, rows = new_weights, new_rows
        if settled:
            break
    return Fit(theta, ev, weights, rows, reason, iterations, problem.evaluations,
               time.perf_counter() - t0, branches, method)
