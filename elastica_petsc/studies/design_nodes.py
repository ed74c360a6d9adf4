"""Points of a cable on the arm's mesh nodes as design variables (issues 13, 24;
docs/model.md §33): the end attachment ``tendonK.attach`` and the arc length of
guide J, ``tendonK.guideJ.s`` (J from 1 at the motor end), in mm.

Both sit on mesh nodes (:meth:`Discretisation.from_arm`), so they are varied
by a pattern search node by node (``design --objective area``,
:func:`~.design_area.search_points`) or swept (``design --sweep``), never by
the gradient optimiser.  A point stays inside the arm and strictly between
its neighbours along the cable path: the previous guide (or the clamp, s = 0)
and the next guide or the end attachment (or the tip, s = l, for the end), so
the cable's points keep their order and two of them never share a node.
"""
from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass

from ..core.errors import InputError
from ..core.model import Arm

NAME = re.compile(r"tendon(\d+)\.(?:guide(\d+)\.s|attach)$")


class NodePointError(InputError):
    """A node-point design variable the arm does not have, or a value it cannot take."""


@dataclass(frozen=True)
class NodePoint:
    """Tendon ``tendon`` (0-based); ``guide`` (0-based), or None: the end attachment."""

    tendon: int
    guide: int | None = None

    @property
    def name(self) -> str:
        return f"tendon{self.tendon + 1}." + ("attach" if self.guide is None
                                              else f"guide{self.guide + 1}.s")

    def _path_s_mm(self, arm: Arm) -> list[float]:
        """Arc lengths of the tendon's points on the arm, motor end first."""
        t = arm.tendons[self.tendon]
        return [g.s_mm for g in t.guides] + [t.attach_mm]

    def _index(self, arm: Arm) -> int:
        return len(arm.tendons[self.tendon].guides) if self.guide is None else self.guide

    def value_mm(self, arm: Arm) -> float:
        return self._path_s_mm(arm)[self._index(arm)]

    def interval_mm(self, arm: Arm) -> tuple[float, float]:
        """(lo, hi): the point may take lo < s < hi, or s = hi = l for the last point."""
        s, a = self._path_s_mm(arm), self._index(arm)
        return (s[a - 1] if a > 0 else 0.0), (s[a + 1] if a + 1 < len(s) else arm.length_mm)

    def _is_end(self, arm: Arm) -> bool:
        return self._index(arm) == len(self._path_s_mm(arm)) - 1

    def admits(self, arm: Arm, s_mm: float) -> bool:
        """``s_mm`` keeps the point inside the arm and strictly between its neighbours."""
        lo, hi = self.interval_mm(arm)
        tol = 1e-9 * arm.length_mm
        return lo + tol < s_mm and (s_mm <= hi + tol if self._is_end(arm) else s_mm < hi - tol)

    def check(self, arm: Arm, s_mm: float, where: str) -> None:
        """One-line :class:`NodePointError` unless :meth:`admits`."""
        if not self.admits(arm, s_mm):
            lo, hi = self.interval_mm(arm)
            raise NodePointError(f"{where}: {self.name} = {s_mm:g} mm must lie in ({lo:g}, "
                                 f"{hi:g}{']' if self._is_end(arm) else ')'} mm, inside the "
                                 "arm and strictly between its neighbours on the cable path")

    def placed(self, arm: Arm, s_mm: float) -> Arm:
        """The arm with this point at arc length ``s_mm`` (its offset kept)."""
        t = arm.tendons[self.tendon]
        if self.guide is None:
            t = dataclasses.replace(t, attach_mm=float(s_mm))
        else:
            guides = list(t.guides)
            guides[self.guide] = dataclasses.replace(guides[self.guide], s_mm=float(s_mm))
            t = dataclasses.replace(t, guides=tuple(guides))
        tendons = list(arm.tendons)
        tendons[self.tendon] = t
        return dataclasses.replace(arm, tendons=tuple(tendons))


def node_point(name: str, arm: Arm, where: str) -> NodePoint | None:
    """``tendonK.attach`` / ``tendonK.guideJ.s`` -> NodePoint, None for other names;
    a one-line error for a tendon or guide the arm does not have, or a start
    whose neighbours are out of order along the cable path."""
    match = NAME.match(name)
    if match is None:
        return None
    k, j = int(match.group(1)), match.group(2)
    if not 1 <= k <= arm.n_tendons:
        raise NodePointError(f"{where} {name!r}: the arm has tendons 1..{arm.n_tendons}")
    guides = arm.tendons[k - 1].guides
    if j is not None and not 1 <= int(j) <= len(guides):
        raise NodePointError(f"{where} {name!r}: tendon {k} has "
                             + (f"guides 1..{len(guides)}" if guides else "no guides"))
    point = NodePoint(k - 1, None if j is None else int(j) - 1)
    if not point.admits(arm, point.value_mm(arm)):
        raise NodePointError(f"{where} {name!r}: tendon {k}'s guides and end are not in "
                             "increasing arc length along the cable path, so its points "
                             "cannot be moved in order")
    return point
