"""Where ``reproduce`` places the paper's experiments on an arm (issue 24).

On the paper's arm the experiments use the paper's numbers: the Fig. 2 target,
the Fig. 8 cable lengths, and our choice of centres for the Fig. 3 drawings.
Those are coordinates of the paper's 600 mm arm; on a user arm (another length,
cables through guides, weight) they can lie far outside its workspace, and the
report would compare nothing.  A user arm therefore gets the experiments at
its own state 1 of Fig. 8: the equilibrium reached by loading p = (25.2, 10.8)
(non-dimensional, the paper's tensions) tendon 2 first.  Its tip is the Fig. 2
target; its cable lengths are the Fig. 8 lengths (so state 1 is found again
under length control, with any other state sharing them).  The Fig. 3
drawings are centred at the reached sample of the workspace map (computed
first) farthest from any sample not reached, scaled by l / 600 mm or less, so
that the circumcircle keeps within that clearance.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.model import Arm

PAPER_LENGTH_MM = 600.0


@dataclass(frozen=True)
class Placement:
    fig2_target_mm: np.ndarray
    triangle_center_mm: tuple
    curve_center_mm: tuple
    size: float                      # drawing sizes relative to the paper's arm
    fig8_lengths_mm: np.ndarray
    note: str = ""                   # empty on the paper's arm


def is_paper_arm(arm: Arm) -> bool:
    """The paper's arm (any element count)."""
    import dataclasses
    paper = Arm.paper()
    return dataclasses.replace(arm, elements=paper.elements) == paper


def interior_target(targets_mm, reached, reach_mm: float | None = None
                    ) -> tuple[np.ndarray, float] | None:
    """The reached sample of a workspace map farthest from every sample not reached
    and from the edge of the sampled region (the reach circle |x| = ``reach_mm`` and,
    for a map in y >= 0, the line y = 0), less half a lattice spacing (where the
    boundary may lie between samples), and that clearance (mm): where a drawing fits
    inside the sampled W_0."""
    targets_mm, reached = np.asarray(targets_mm, float), np.asarray(reached, bool)
    if not reached.any() or reached.all():
        return None
    inside, outside = targets_mm[reached], targets_mm[~reached]
    clearance = np.min(np.linalg.norm(inside[:, None] - outside[None], axis=2), axis=1)
    if reach_mm is not None:
        clearance = np.minimum(clearance, reach_mm - np.linalg.norm(inside, axis=1))
    if np.min(targets_mm[:, 1]) >= 0.0:
        clearance = np.minimum(clearance, inside[:, 1])
    gaps = np.linalg.norm(np.diff(targets_mm, axis=0), axis=1)
    clearance = clearance - 0.5 * np.min(gaps[gaps > 0]) if np.any(gaps > 0) else clearance
    best = int(np.argmax(clearance))
    if clearance[best] <= 0.0:
        return None
    return inside[best], float(clearance[best])


def placement(arm: Arm, paper: Placement, tensions, targets_mm=None,
              reached=None) -> Placement:
    """``paper`` on the paper's arm; else the experiments about the arm's own state 1
    at the non-dimensional ``tensions`` (module docstring), the Fig. 3 drawings at
    the most interior reached sample of the workspace map (``targets_mm``,
    ``reached``) if there is one, sized to fit (circumradius 0.9 of its clearance)."""
    if is_paper_arm(arm):
        return paper
    from ..core.fem import Discretisation
    from ..solvers.equilibrium import EquilibriumSolver

    with EquilibriumSolver(Discretisation.from_arm(arm)) as solver:
        state = solver.solve(np.asarray(tensions, float), order=(2, 1))
    l_mm = arm.length_mm
    tip = state.tip * l_mm
    target = (round(float(tip[0]), 1), round(float(tip[1]), 1))
    centre, size = target, l_mm / PAPER_LENGTH_MM
    where = f"about the tip {target} mm"
    inner = None if targets_mm is None else interior_target(targets_mm, reached, l_mm)
    if inner is not None:
        centre = (round(float(inner[0][0]), 1), round(float(inner[0][1]), 1))
        size = min(size, 0.9 * inner[1] / 80.0)
        where = (f"at the tip {target} mm (Fig. 2) and the workspace map's most interior "
                 f"reached sample {centre} mm (Fig. 3)")
    return Placement(np.array(target), centre, centre, size,
                     state.cable_lengths * l_mm,
                     f"a user arm: the experiments are placed {where} of its Fig. 8 state 1 "
                     f"(p = {tuple(float(v) for v in tensions)}, tendon 2 first), drawings "
                     f"scaled by {size:.3g}; the paper's values are those of the paper's arm, "
                     "for comparison of magnitudes only")
