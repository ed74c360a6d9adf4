"""What a calibration has determined: uncertainties, identifiability,
cross-validation and the next measurements to make (docs/model.md §14).

With the weighted Jacobian J_w = W^(1/2) J at the fit and the column scales
D (typical changes of each parameter), J_w D = U S V^T.  Singular values
below ``RANK_TOL`` s_max are combinations the data cannot determine: each is
named from its right singular vector.  The Gauss-Newton covariance on the
determined subspace, scaled by the residual variance
s^2 = |W^(1/2) r|^2 / (M - rank), is

    C = s^2 D V_r S_r^-2 V_r^T D;

a parameter with a component of more than ``UNDETERMINED_SHARE`` in the
undetermined directions gets no standard deviation (None).  After a Huber
fit (some weights < 1) s is the robust scale 1.4826 median |r| instead (the
down-weighted rows would inflate s^2).  D-optimal
design: for candidate commands c with tip Jacobians J_c (2 x P), the gain of
adding c is log det(F + J_c^T J_c / s^2) - log det F, F = J_w^T J_w / s^2
(on the determined subspace); commands are picked greedily.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..core.calibration_data import CalibrationData
from ..core.calibration_params import ParameterModel
from ..core.model import Arm
from ..core.results import Result
from .calibrate import CalibrationProblem, Fit, fit

RANK_TOL = 1e-6
# sigma = 1.4826 median |r| for Gaussian residuals (the robust scale of a Huber fit)
MAD_TO_SIGMA = 1.4826
UNDETERMINED_SHARE = 0.1


def _words(model, v, scale) -> str:
    """A null direction (scaled components v) in words."""
    big = [j for j in np.argsort(-np.abs(v)) if abs(v[j]) >= 0.2]
    groups = {model.params[j].group for j in big}
    if len(groups) == 1 and next(iter(groups)).endswith(".route") and len(big) == 2:
        group = next(iter(groups))
        k = int(group[6:group.index(".")])
        step = np.array([v[model.index[f"{group}.x"]], v[model.index[f"{group}.y"]]])
        tendon = model.arm0.tendons[k - 1]
        cable = np.array(tendon.route_mm) - np.array([tendon.attach_mm, 0.0])
        cos = abs(step @ cable) / (np.linalg.norm(step) * np.linalg.norm(cable))
        where = ("along its cable (straight arm)" if cos > 0.95 else
                 "across its cable (straight arm)" if cos < 0.3 else
                 f"in the direction ({step[0]:.2f}, {step[1]:.2f})")
        return f"routing point {k} ({group}) {where}"
    if len(big) == 1:
        return f"{model.params[big[0]].name} alone"
    return " ".join(f"{v[j] * scale[j]:+.3g} {model.params[j].unit} {model.params[j].name}"
                    for j in big) + " (together)"


def uncertainty(problem: CalibrationProblem, result: Fit) -> dict:
    """Standard deviations, correlations, singular values and undetermined
    combinations of a fit (module docstring)."""
    model, ev = problem.model, result.evaluation
    scale = model.scales()
    sqrt_w = np.sqrt(result.weights)
    Js = sqrt_w[:, None] * ev.jacobian * scale[None, :]
    U, S, Vt = np.linalg.svd(Js, full_matrices=False)
    tol = RANK_TOL * (S[0] if len(S) and S[0] > 0 else 1.0)
    rank = int(np.sum(S > tol))
    M = len(ev.residual)
    dof = max(M - rank, 1)
    s2 = float(np.sum((sqrt_w * ev.residual) ** 2)) / dof
    if np.any(result.weights < 1.0):        # Huber: a robust scale, not the outliers'
        s2 = (MAD_TO_SIGMA * float(np.median(np.abs(ev.residual)))) ** 2
    Vr, Vn = Vt[:rank].T, Vt[rank:].T
    cov_scaled = Vr @ np.diag(1.0 / S[:rank] ** 2) @ Vr.T * s2
    cov = cov_scaled * np.outer(scale, scale)
    share = np.sqrt(np.sum(Vn ** 2, axis=1)) if Vn.size else np.zeros(model.size)
    undetermined = share > UNDETERMINED_SHARE
    sd = np.sqrt(np.maximum(np.diag(cov), 0.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(sd, sd)
    corr[undetermined, :] = np.nan
    corr[:, undetermined] = np.nan
    # the Gauss-Newton step still to go, in standard deviations: converged if tiny
    step = -(Vr @ ((U[:, :rank].T @ (sqrt_w * ev.residual)) / S[:rank])) * scale
    sd_det = np.where(undetermined | (sd == 0), np.inf, sd)
    null_words = [_words(model, Vt[k], scale) for k in range(rank, len(S))]
    if len(S) < model.size:
        null_words.append("more parameters than measured coordinates")
    return {"sigma": [None if u else float(v) for u, v in zip(undetermined, sd)],
            "covariance": cov, "correlation": corr, "singular_values": S,
            "rank": rank, "undetermined": [model.params[j].name
                                           for j in np.flatnonzero(undetermined)],
            "undetermined_combinations": null_words, "residual_variance_mm2": s2,
            "dof": dof,
            "remaining_step_sigma": float(np.max(np.abs(step) / sd_det)) if model.size else 0.0,
            "remaining_step_scaled": float(np.max(np.abs(step) / scale)) if model.size else 0.0,
            "fisher_scaled": Js.T @ Js / s2 if s2 > 0 else Js.T @ Js}


def residual_stats(problem: CalibrationProblem, result: Fit) -> dict:
    """RMS and max of the point errors [mm], and per row the largest."""
    pairs = result.evaluation.residual.reshape(-1, 2)
    dist = np.hypot(pairs[:, 0], pairs[:, 1])
    per_row = np.zeros(problem.data.n_rows)
    np.maximum.at(per_row, problem.row_of[::2], dist)
    return {"rms_mm": float(np.sqrt(np.mean(dist ** 2))), "max_mm": float(dist.max()),
            "per_row_mm": per_row,
            "coordinate_rms_mm": float(np.sqrt(np.mean(result.evaluation.residual ** 2)))}


def cross_validate(problem: CalibrationProblem, result: Fit, folds: int = 5,
                   huber_mm: float | None = None, progress=None) -> dict:
    """k-fold cross-validation: fit on k - 1 folds (rows r with r % k != j),
    from the full fit, and predict the left-out rows [mm]."""
    data = problem.data
    folds = min(folds, data.n_rows)
    errors = np.full(data.n_rows, np.nan)
    for j in range(folds):
        test = np.arange(j, data.n_rows, folds)
        train = np.setdiff1d(np.arange(data.n_rows), test)
        sub = _sub_problem(problem, train)
        try:
            part = fit(sub, result.theta, huber_mm=huber_mm)
        except Exception as err:                   # noqa: BLE001 (reported, not hidden)
            return {"folds": folds, "error": f"fold {j + 1}: {err}"}
        held = _sub_problem(problem, test)
        ev = held.evaluate(part.theta, jacobian=False)
        pairs = ev.residual.reshape(-1, 2)
        per = np.zeros(len(test))
        np.maximum.at(per, held.row_of[::2], np.hypot(pairs[:, 0], pairs[:, 1]))
        errors[test] = per
        if progress is not None:
            progress(j + 1, f"cross-validation fold {j + 1} of {folds}")
    return {"folds": folds, "rms_mm": float(np.sqrt(np.nanmean(errors ** 2))),
            "max_mm": float(np.nanmax(errors)), "per_row_mm": errors}


def _sub_problem(problem: CalibrationProblem, rows) -> CalibrationProblem:
    """The rows ``rows`` of a problem, with their branches and warm starts."""
    sub = CalibrationProblem.__new__(CalibrationProblem)
    sub.__dict__.update(problem.__dict__)
    sub.data = problem.data.subset(rows)
    sub.observed, sub.measured = problem.observed[rows], problem.measured[rows]
    sub.states = [problem.states[r] for r in rows]
    sub.orders = [problem.orders[r] for r in rows]
    sub.matched = [False] * len(rows)
    sub.row_of = np.repeat(np.nonzero(sub.observed)[0], 2)
    sub.evaluations = 0
    return sub


def next_measurements(problem: CalibrationProblem, result: Fit, report: dict,
                      candidates: CalibrationData, count: int = 5) -> list[dict]:
    """Greedy D-optimal choice of ``count`` candidate commands (module docstring):
    each with the gain in log det of the Fisher information."""
    shaped = CalibrationData(candidates.kinds, candidates.inputs,
                             np.zeros((candidates.n_rows, 2)), np.zeros(0),
                             np.zeros((candidates.n_rows, 0, 2)), candidates.loading,
                             candidates.lines, candidates.source)
    cand = _sub_problem(problem, np.arange(0))
    cand.data, cand.measured = shaped, shaped.points_mm()
    cand.observed = shaped.observed()
    cand.states, cand.orders = [None] * shaped.n_rows, list(shaped.loading)
    cand.row_of = np.repeat(np.arange(shaped.n_rows), 2)
    J = cand.evaluate(result.theta).jacobian * problem.model.scales()[None, :]
    s2 = max(report["residual_variance_mm2"], 1e-300)
    F = report["fisher_scaled"].copy()
    ridge = 1e-12 * max(np.trace(F), 1e-300) * np.eye(len(F))
    chosen, out = [], []
    for _ in range(min(count, shaped.n_rows)):
        base = np.linalg.slogdet(F + ridge)[1]
        gains = [np.linalg.slogdet(F + ridge + J[2 * c:2 * c + 2].T @ J[2 * c:2 * c + 2] / s2)[1]
                 - base if c not in chosen else -np.inf for c in range(shaped.n_rows)]
        c = int(np.argmax(gains))
        chosen.append(c)
        F = F + J[2 * c:2 * c + 2].T @ J[2 * c:2 * c + 2] / s2
        out.append({"line": shaped.lines[c], "kind": str(shaped.kinds[c]),
                    "inputs": shaped.inputs[c].tolist(), "log_det_gain": float(gains[c])})
    return out


@dataclass(frozen=True, repr=False)
class CalibrationResult(Result):
    """Everything a calibration produced (mm, N, N m^2, degrees); ``save(path)``
    writes ``calibrate --h5``'s layout and ``elastica_petsc.read`` returns it."""

    start_arm: Arm                          # the arm the parameters start from
    vary: tuple                             # the varied groups (ParameterModel)
    bounds: dict                            # {parameter: (lower, upper)}, physical units
    data: CalibrationData
    elements: int | None
    fit: Fit
    report: dict
    stats: dict
    cross_validation: dict | None
    tip_covariance_mm2: np.ndarray          # (m, 2, 2): predicted tips' covariance
    next_measurements: list | None = None
    failed_trials: int = 0                  # trial points with a row out of reach
    ranks: int = 1                          # MPI ranks the rows were dealt to
    attachments: object = None              # AttachmentSearch (studies/calibrate_attach.py)

    @cached_property
    def model(self) -> ParameterModel:
        return ParameterModel(self.start_arm, self.vary, self.bounds)

    @property
    def arm(self):
        """The fitted arm in its own frame (what the TOML holds)."""
        return self.model.arm(self.fit.theta)

    @property
    def converged(self) -> bool:
        """The Gauss-Newton step still to go is below 0.01 standard deviations,
        or below 1e-6 of every parameter's scale (noise-free data, where the
        deviations themselves are round-off)."""
        return self.report["remaining_step_sigma"] < 1e-2 or \
            self.report["remaining_step_scaled"] < 1e-6

    def parameters(self) -> list[dict]:
        start = self.model.start()
        return [{"name": p.name, "unit": p.unit, "start": float(s), "value": float(v),
                 "sigma": sd, "lower": p.lower, "upper": p.upper}
                for p, s, v, sd in zip(self.model.params, start, self.fit.theta,
                                       self.report["sigma"])]

    def summary(self) -> dict:
        """JSON-ready summary."""
        rep, cv = self.report, self.cross_validation
        corr = np.where(np.isfinite(rep["correlation"]), rep["correlation"], np.nan)
        data = self.data
        return {
            "parameters": self.parameters(),
            "correlation": [[None if not np.isfinite(c) else round(float(c), 6) for c in row]
                            for row in corr],
            "singular_values_scaled": [float(s) for s in rep["singular_values"]],
            "undetermined": rep["undetermined"],
            "undetermined_combinations": rep["undetermined_combinations"],
            "residual": {"rms_mm": self.stats["rms_mm"], "max_mm": self.stats["max_mm"],
                         "sigma_mm": float(np.sqrt(rep["residual_variance_mm2"])),
                         "dof": rep["dof"]},
            "rows": [{"line": data.lines[r], "kind": str(data.kinds[r]),
                      "branch": self.fit.branches[r],
                      "error_mm": float(self.stats["per_row_mm"][r]),
                      "weight": float(self.fit.row_weights[r]),
                      "taut": self.fit.evaluation.taut[r].tolist()}
                     for r in range(data.n_rows)],
            "down_weighted_lines": [data.lines[r] for r in
                                    np.flatnonzero(self.fit.row_weights < 1.0)],
            "cross_validation": None if cv is None else
            {k: v for k, v in cv.items() if k != "per_row_mm"},
            "solver": {"method": self.fit.method, "tao_reason": self.fit.reason, "iterations": self.fit.iterations,
                       "evaluations": self.fit.evaluations, "seconds": self.fit.seconds,
                       "remaining_step_sigma": rep["remaining_step_sigma"],
                       "remaining_step_scaled": rep["remaining_step_scaled"],
                       "failed_trial_points": self.failed_trials,
                       "converged": self.converged},
            "next_measurements": self.next_measurements,
            **({"attachments": self.attachments.summary()} if self.attachments else {}),
        }


def tip_covariance(problem: CalibrationProblem, result: Fit, cov) -> np.ndarray:
    """Covariance [mm^2] of every predicted tip from the parameters' covariance."""
    J = result.evaluation.jacobian
    obs = problem.observed
    starts = np.concatenate(([0], np.cumsum(obs.sum(axis=1))[:-1])) * 2
    out = np.empty((problem.data.n_rows, 2, 2))
    for r, s in enumerate(starts):
        Jt = J[s:s + 2]
        out[r] = Jt @ cov @ Jt.T
    return out


def calibrate(model, data: CalibrationData, *, elements: int | None = None,
              huber_mm: float | None = None, folds: int = 5, candidates=None,
              next_count: int = 5, progress=None, comm=None,
              method: str = "brgn") -> CalibrationResult:
    """Fit ``model``'s parameters to ``data`` and report (module docstring);
    ``comm``: rows over its ranks (:class:`CalibrationProblem`)."""
    problem = CalibrationProblem(model, data, elements, comm)
    if progress is not None:
        progress(0, "fitting")
    result = fit(problem, huber_mm=huber_mm, method=method)
    report = uncertainty(problem, result)
    stats = residual_stats(problem, result)
    cov = np.where(np.isfinite(report["covariance"]), report["covariance"], 0.0)
    tips = tip_covariance(problem, result, cov)
    cv = cross_validate(problem, result, folds, huber_mm, progress) if folds >= 2 else None
    nxt = (next_measurements(problem, result, report, candidates, next_count)
           if candidates is not None else None)
    return CalibrationResult(model.arm0, tuple(model.groups),
                             {p.name: (p.lower, p.upper) for p in model.params}, data,
                             elements, result, report, stats, cv, tips, nxt,
                             problem.failed_trials, problem.ranks)
