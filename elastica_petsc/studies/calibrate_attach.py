"""Attachment arc lengths as calibration parameters (issue 23; docs/model.md §19.5).

An attachment sits on a mesh node (the kernels of §8 put the cable's force on a
node), so the residual is not differentiable in it and the Gauss-Newton fit of
:mod:`.calibrate` cannot move it.  ``tendonK.attach`` is therefore searched node
by node around the continuous fit: the objective of an attachment vector s is
the fitted one,

    f(s) = min_theta 1/2 |W^(1/2) r(theta; s)|^2      (a profile: theta refitted),

and a coordinate search moves one attachment by one element h at a time while
f decreases (each candidate warm-started from the current fit), until no
neighbour improves.  Its standard deviation comes from the profile's curvature
at the optimum, f(s +- h) - f(s) ~ c (ds)^2 / 2: sigma_s^2 = s2 / c with the fit's
residual variance s2 (the profile-likelihood form of the Gauss-Newton
covariance, correlations with theta included); a profile that does not curve
up (c <= 0) leaves sigma undetermined.  The resolution is the element length h:
a sigma far below h says the node is decided by the data (the attachment is
then known to the resolution, not to sigma); finer attachments need more
elements.  With ``comm`` (mpi4py) every fit of the search spreads its rows
over the ranks as the final calibration does (:class:`.CalibrationProblem`):
each rank solves its share of the rows, the residuals are gathered, and every
rank takes the same search steps on the same (gathered) objective values.
"""
from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass, field

import numpy as np

from ..core.calibration_params import ParameterError, ParameterModel, said
from ..core.errors import InputError
from ..core.model import Arm
from .calibrate import CalibrationProblem, fit

NAME = re.compile(r"^tendon(\d+)\.attach$")


def split_attach_names(vary, arm: Arm, names=None) -> tuple[list[str], list[int]]:
    """(the continuous parameters, the tendons whose attachment is searched, 0-based)."""
    vary = [vary] if isinstance(vary, str) else list(vary)
    rest, tendons = [], []
    for name in vary:
        m = NAME.match(name)
        if m is None:
            rest.append(name)
            continue
        k = int(m.group(1))
        if not 1 <= k <= arm.n_tendons:
            raise ParameterError(f"{said(names, 'vary', repr(name))}: the arm has tendons "
                                 f"1..{arm.n_tendons}")
        if k - 1 in tendons:
            raise ParameterError(f"{said(names, 'vary')}: {name!r} given twice")
        tendons.append(k - 1)
    if tendons and not rest:
        raise ParameterError(f"{said(names, 'vary')}: tendonK.attach is searched around a "
                             "fit of continuous parameters; name at least one of them too, "
                             "e.g. bending_stiffness")
    return rest, tendons


def with_attachments(arm: Arm, tendons, s_mm) -> Arm | None:
    """The arm with those attachments, or None if that arm is not valid (an end
    point on a guide, beyond the arm, ...)."""
    new = list(arm.tendons)
    for i, s in zip(tendons, s_mm):
        new[i] = dataclasses.replace(new[i], attach_mm=float(s))
    try:
        return dataclasses.replace(arm, tendons=tuple(new))
    except InputError:
        return None


@dataclass
class AttachmentSearch:
    """The searched attachments [mm], the profile's curvature c [mm^2/mm^2] at each
    (None: it does not curve up), the profile f(s) [mm^2] evaluated per tendon, the
    fits made and the element length (the resolution)."""

    tendons: list
    values_mm: list
    curvatures: list
    profiles: list = field(default_factory=list)     # per tendon: [(s_mm, f_mm2), ...]
    fits: int = 0
    element_mm: float = 0.0
    residual_variance_mm2: float = float("nan")      # of the final fit

    @property
    def sigma_mm(self) -> list:
        """sqrt(s2 / c) per attachment (module docstring); None where c <= 0."""
        return [None if c is None else float(np.sqrt(self.residual_variance_mm2 / c))
                for c in self.curvatures]

    def summary(self) -> list[dict]:
        return [{"name": f"tendon{i + 1}.attach", "value": v, "sigma": sd, "unit": "mm",
                 "resolution_mm": self.element_mm,
                 "profile_mm2": [[s, f] for s, f in sorted(prof)]}
                for i, v, sd, prof in zip(self.tendons, self.values_mm, self.sigma_mm,
                                          self.profiles)]


def search_attachments(arm: Arm, data, vary, tendons, *, elements: int, bounds=None,
                       names=None, huber_mm=None, method: str = "brgn", progress=None,
                       max_moves: int = 50, comm=None) -> tuple[Arm, AttachmentSearch]:
    """The arm with the attachments of ``tendons`` that minimise the fitted
    objective, and the search's record (module docstring); ``comm``: the rows
    of every fit over its ranks."""
    h = arm.length_mm / elements
    cache: dict = {}
    theta_of: dict = {}

    def objective(s_mm):
        key = tuple(round(float(s) / h) for s in s_mm)
        if key in cache:
            return cache[key]
        candidate = with_attachments(arm, tendons, [k * h for k in key])
        value, theta = np.inf, None
        if candidate is not None:
            try:
                model = ParameterModel(candidate, vary, bounds, names)
                problem = CalibrationProblem(model, data, elements, comm)
                start = theta_of.get("best")
                result = fit(problem, start, huber_mm=huber_mm, method=method)
                value = 0.5 * float(np.sum(result.weights * result.evaluation.residual ** 2))
                theta = result.theta
            except (InputError, RuntimeError):
                value = np.inf                    # no equilibrium or no valid arm there
        cache[key] = value
        if theta is not None:
            theta_of[key] = theta
        if progress is not None:
            progress(len(cache), f"attachment search: {len(cache)} fits")
        return value

    s = [arm.tendons[i].attach_mm for i in tendons]
    best = objective(s)
    if not np.isfinite(best):
        raise ParameterError("the attachment search cannot start: no fit at the given "
                             "attachments")
    theta_of["best"] = theta_of[tuple(round(v / h) for v in s)]
    moved, moves = True, 0
    while moved and moves < max_moves:
        moved = False
        for j in range(len(tendons)):
            for step in (+h, -h):
                trial = list(s)
                trial[j] += step
                while (value := objective(trial)) < best - 1e-12 * max(best, 1.0):
                    s, best, moved, moves = list(trial), value, True, moves + 1
                    theta_of["best"] = theta_of[tuple(round(v / h) for v in s)]
                    trial = list(s)
                    trial[j] += step
    curvatures, profiles = [], []
    for j in range(len(tendons)):
        side = []
        for step in (+h, -h):
            trial = list(s)
            trial[j] += step
            side.append(objective(trial))
        curvature = (side[0] + side[1] - 2.0 * best) / h ** 2
        curvatures.append(None if not np.isfinite(curvature) or curvature <= 0
                          else float(curvature))
        profiles.append([(k[j] * h, f) for k, f in cache.items()
                         if all(k[i] == round(s[i] / h) for i in range(len(tendons)) if i != j)
                         and np.isfinite(f)])
    final = with_attachments(arm, tendons, s)
    return final, AttachmentSearch(list(tendons), [float(v) for v in s], curvatures, profiles,
                                   len(cache), h)


def calibrate_with_attachments(arm: Arm, data, vary, *, bounds=None, names=None,
                               elements: int, huber_mm=None, method: str = "brgn",
                               progress=None, comm=None, **report):
    """:func:`~elastica_petsc.studies.calibrate_report.calibrate` of the continuous
    parameters of ``vary`` at the attachments searched for the ``tendonK.attach``
    names (none: the plain calibration); ``comm``: rows over its ranks, in the
    search and in the final fit; ``report``: the other keywords of
    :func:`~elastica_petsc.studies.calibrate_report.calibrate`."""
    from .calibrate_report import calibrate

    rest, tendons = split_attach_names(vary, arm, names)
    search = None
    if tendons:
        arm, search = search_attachments(arm, data, rest, tendons, elements=elements,
                                         bounds=bounds, names=names, huber_mm=huber_mm,
                                         method=method, progress=progress, comm=comm)
    model = ParameterModel(arm, rest, bounds, names)
    result = calibrate(model, data, elements=elements, huber_mm=huber_mm, method=method,
                       progress=progress, comm=comm, **report)
    if search is not None:
        search.residual_variance_mm2 = float(result.report["residual_variance_mm2"])
        result = dataclasses.replace(result, attachments=search)
    return result
