"""Guide offsets as design variables of the path and area objectives (issue 24;
§11.7).

A variable is ``tendonK.offset`` (one common offset delta of every guide and the
end point of tendon K: the spacer disks' hole radius; the tendon's points must
share one offset to start with) or ``tendonK.guideJ.offset`` (guide J of tendon
K alone, J from 1 at the motor end).  Offsets are in mm along the arm's left
normal.  The residual depends on an offset delta_a through the moment of the
cable's pull about the centreline and the chords of the two segments at point
a, dF/ddelta_a (:meth:`GuidedDiscretisation.offset_derivative`); at fixed
tensions the tip moves by d x_t/d delta = one more right-hand side of the
bordered tangent (J du = -dF/ddelta, :meth:`SensitivitySolver.parameter_derivative`),
so Danskin's gradient of the path misfit (studies/design.py) gains the term
(x_t - x_k) . d x_t/d delta.  A common offset sums dF/ddelta_a over its points.
"""
from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass

import numpy as np

from ..core.errors import InputError
from ..core.model import Arm, guide_radius_mm

NAME = re.compile(r"tendon(\d+)\.(?:guide(\d+)\.)?offset$")


class OffsetVariableError(InputError):
    """A guide-offset design variable that the arm does not have (one line)."""


@dataclass(frozen=True)
class OffsetVariable:
    """Tendon ``tendon`` (0-based); ``guide`` (0-based) or None: every point of the tendon."""

    tendon: int
    guide: int | None = None

    @property
    def name(self) -> str:
        part = "" if self.guide is None else f"guide{self.guide + 1}."
        return f"tendon{self.tendon + 1}.{part}offset"

    def points(self, arm: Arm) -> list[int]:
        """Indices a of the arm points (:class:`GuidedDiscretisation` order) it moves."""
        start = sum(len(t.guides) + 1 for t in arm.tendons[:self.tendon])
        count = len(arm.tendons[self.tendon].guides) + 1
        return [start + self.guide] if self.guide is not None else list(range(start,
                                                                             start + count))

    def value_mm(self, arm: Arm) -> float:
        t = arm.tendons[self.tendon]
        if self.guide is not None:
            return t.guides[self.guide].offset_mm
        return t.attach_offset_mm


def split_offset_names(names, arm: Arm) -> tuple[list[str], list[OffsetVariable]]:
    """(the other names, the offset variables) of ``names`` in order, checked."""
    rest, chosen = [], []
    for name in names:
        match = NAME.match(name)
        if match is None:
            rest.append(name)
            continue
        k, j = int(match.group(1)), match.group(2)
        if not 1 <= k <= arm.n_tendons:
            raise OffsetVariableError(f"vary {name!r}: the arm has tendons 1..{arm.n_tendons}")
        t = arm.tendons[k - 1]
        if j is not None and not 1 <= int(j) <= len(t.guides):
            raise OffsetVariableError(f"vary {name!r}: tendon {k} has "
                                      + (f"guides 1..{len(t.guides)}" if t.guides else "no guides"))
        var = OffsetVariable(k - 1, None if j is None else int(j) - 1)
        if var.guide is None:
            values = {g.offset_mm for g in t.guides} | {t.attach_offset_mm}
            if len(values) > 1:
                raise OffsetVariableError(
                    f"vary {name!r}: tendon {k}'s guides and end are at different offsets "
                    f"({', '.join(f'{v:g}' for v in sorted(values))} mm); vary them one by one "
                    f"(tendon{k}.guideJ.offset)")
        if not arm.has_paths:
            raise OffsetVariableError(f"vary {name!r}: the arm has no cable through guides or "
                                      "offset end (the paper's straight cables); give the "
                                      "tendon its guides in the config first")
        if any(set(var.points(arm)) & set(v.points(arm)) for v in chosen):
            raise OffsetVariableError(f"vary {name!r}: overlaps another offset variable")
        chosen.append(var)
    return rest, chosen


def with_offsets(arm: Arm, variables, values_mm) -> Arm:
    """The arm with the offsets of ``variables`` set to ``values_mm``."""
    tendons = list(arm.tendons)
    for var, v in zip(variables, values_mm):
        t = tendons[var.tendon]
        if var.guide is None:
            t = dataclasses.replace(t, attach_offset_mm=float(v), guides=tuple(
                dataclasses.replace(g, offset_mm=float(v)) for g in t.guides))
        else:
            guides = list(t.guides)
            guides[var.guide] = dataclasses.replace(guides[var.guide], offset_mm=float(v))
            t = dataclasses.replace(t, guides=tuple(guides))
        tendons[var.tendon] = t
    return dataclasses.replace(arm, tendons=tuple(tendons))


def offset_bounds(arm: Arm, variables, reach_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """Each offset within +- reach_mm of its start and within the guides' extent
    (+- arm.guide_radius_mm)."""
    radius = guide_radius_mm(arm)
    start = np.array([v.value_mm(arm) for v in variables], float)
    return np.maximum(start - reach_mm, -radius), np.minimum(start + reach_mm, radius)


def offset_residual_derivative(disc, u: np.ndarray, p, var: OffsetVariable, arm: Arm):
    """dF/ddelta (size,) of one variable, delta in units of l (a common offset: the
    sum over its points)."""
    return sum(disc.offset_derivative(u, p, a) for a in var.points(arm))
