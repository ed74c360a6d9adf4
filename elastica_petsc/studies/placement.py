"""Where ``reproduce`` places the paper's experiments on an arm (issue 24).

On the paper's arm the experiments use the paper's numbers: the Fig. 2 target,
the Fig. 8 cable lengths, and our choice of centres for the Fig. 3 drawings.
Those are coordinates of the paper's 600 mm arm; on a user arm (another length,
cables through guides, weight) they can lie far outside its workspace, and the
report would compare nothing.  A user arm therefore gets the experiments at
its own state 1 of Fig. 8: the equilibrium reached by loading p = (25.2, 10.8)
(non-dimensional, the paper's tensions) tendon 2 first.  Its tip is the Fig. 2
target and the centre of the Fig. 3 drawings, whose sizes are scaled by
l / 600 mm; its cable lengths are the Fig. 8 lengths (so state 1 is found
again under length control, with any other state sharing them).
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


def placement(arm: Arm, paper: Placement, tensions) -> Placement:
    """``paper`` on the paper's arm; else the experiments about the arm's own state 1
    at the non-dimensional ``tensions`` (module docstring)."""
    if is_paper_arm(arm):
        return paper
    from ..core.fem import Discretisation
    from ..solvers.equilibrium import EquilibriumSolver

    with EquilibriumSolver(Discretisation.from_arm(arm)) as solver:
        state = solver.solve(np.asarray(tensions, float), order=(2, 1))
    l_mm = arm.length_mm
    tip = state.tip * l_mm
    centre = (round(float(tip[0]), 1), round(float(tip[1]), 1))
    return Placement(np.array(centre), centre, centre, l_mm / PAPER_LENGTH_MM,
                     np.round(state.cable_lengths * l_mm, 1),
                     f"a user arm: the experiments are placed about the tip {centre} mm of its "
                     f"Fig. 8 state 1 (p = {tuple(float(v) for v in tensions)}, tendon 2 first), "
                     f"drawings scaled by l/600 mm = {l_mm / PAPER_LENGTH_MM:.3g}; the paper's "
                     "values are those of the paper's arm, for comparison of magnitudes only")
