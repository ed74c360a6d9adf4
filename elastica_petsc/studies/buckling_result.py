"""The result of the Fig. 7 scenario (:func:`elastica_petsc.studies.buckling.fig7`):
its fields (the module docstring of :mod:`elastica_petsc.studies.buckling`
explains each), a JSON-ready summary and a text report."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..solvers.equilibrium import Equilibrium
from ..solvers.lengths import LengthEquilibrium

PAPER = "Handral & Rangarajan (2019), Sec. 4.6, Fig. 7"


@dataclass(frozen=True)
class Fig7Result:
    """The Fig. 7 scenario (:mod:`elastica_petsc.studies.buckling`).  Lengths in mm where named
    ``*_mm``; segment deviations signed (positive to the left of the chord
    x_1 -> tip); tensions non-dimensional, p = P l^2/B; eigenvalues lambda of
    K v = lambda h v on null(C^T), non-dimensional like K."""

    length_mm: float                  # arm length l
    segment_length_mm: float          # a = s_2 - s_1
    p1_star: float                    # p_1 of the critical configuration (p_2 = 0)
    critical: Equilibrium             # load-controlled state at (p_1*, 0)
    L0_mm: np.ndarray                 # its cable lengths (cable 2 just taut)
    # the aligned family ("perfect column"), first entry dL_2 = 0 (critical state at L0)
    aligned_shortenings_mm: np.ndarray
    aligned: tuple                    # LengthEquilibrium per shortening
    aligned_lambda: np.ndarray        # constrained eigenvalue nearest zero
    # the crossing lambda = 0, linear interpolation in the bracketing interval
    bracket: tuple                    # (index of the last stable, first unstable) aligned state
    dL2_cr_mm: float
    L_cr_mm: np.ndarray
    p2_cr: float
    ka_clamped: float                 # clamped-column estimate: k a and p = k^2
    p_clamped: float
    # continuation (LengthSolver.path) along the aligned lengths from the critical state
    path: tuple                       # LengthEquilibrium per aligned point reached
    path_deviation_mm: np.ndarray     # their segment deviations (buckled: not ~0)
    event_L_mm: np.ndarray | None     # lengths where the path lost stability (instability)
    event_kind: str | None            # "bifurcation" or "limit point" (lengths.instability_kind)
    event_dL2_mm: float | None
    jump_L_mm: np.ndarray | None      # lengths at which it jumped to a buckled state
    jumped: LengthEquilibrium | None  # the path's state at the point of the jump
    # post-buckling at dL_2 = post_dL2_mm on the aligned lengths
    post_dL2_mm: float
    post_L_mm: np.ndarray
    post_buckling: tuple              # stable buckled states, by increasing deviation
    post_deviation_mm: np.ndarray
    post_p2: np.ndarray
    straight: LengthEquilibrium       # the straight (perfect) column there, unstable
    straight_deviation_mm: float
    # the paper's experiment: L_1 = L0_1 held, L_2 = L0_2 - dL_2 (imperfect column)
    experiment_shortenings_mm: np.ndarray
    experiment: tuple                 # LengthEquilibrium per point reached
    experiment_deviation_mm: np.ndarray
    experiment_p2: np.ndarray
    seconds: float = math.nan         # wall time of fig7()

    @property
    def aligned_p2(self) -> np.ndarray:
        return np.array([s.p[1] for s in self.aligned])

    @property
    def aligned_L_mm(self) -> np.ndarray:
        return np.array([s.lengths_requested for s in self.aligned]) * self.length_mm

    @property
    def straight_p2(self) -> float:
        return float(self.straight.p[1])

    @property
    def load_ratio(self) -> float:
        """p_2,cr / p_clamped (< 1: the base x_1 is not a clamp)."""
        return self.p2_cr / self.p_clamped

    def summary(self, arm=None) -> dict:
        """Plain data (JSON-friendly); tensions also in N when ``arm`` is given."""
        def r(v, d=6):
            return np.round(np.asarray(v, float), d).tolist()

        def N(p):
            return None if arm is None else r(arm.tensions_to_N(p))

        return {
            "reference": PAPER,
            "p1_star": r(self.p1_star), "p1_star_N": N(self.p1_star),
            "L0_mm": r(self.L0_mm),
            "aligned": [{"dL2_mm": r(d), "lengths_mm": r(L), "tensions": r(s.p),
                         "constrained_eigenvalue": r(lam),
                         "unstable_modes_load": int(s.unstable_modes),
                         "unstable_modes_length": int(s.length_unstable_modes)}
                        for d, L, s, lam in zip(self.aligned_shortenings_mm, self.aligned_L_mm,
                                                self.aligned, self.aligned_lambda)],
            "critical_dL2_mm": r(self.dL2_cr_mm), "critical_lengths_mm": r(self.L_cr_mm),
            "critical_p2": r(self.p2_cr), "critical_p2_N": N(self.p2_cr),
            "clamped_column_ka": r(self.ka_clamped), "clamped_column_p2": r(self.p_clamped),
            "clamped_column_p2_N": N(self.p_clamped), "load_ratio": r(self.load_ratio),
            "continuation_instability_mm": None if self.event_L_mm is None else
            r(self.event_L_mm),
            "continuation_instability_kind": self.event_kind,
            "continuation_instability_dL2_mm": None if self.event_dL2_mm is None else
            r(self.event_dL2_mm),
            "continuation_jump_mm": None if self.jump_L_mm is None else r(self.jump_L_mm),
            "post_buckling_dL2_mm": r(self.post_dL2_mm), "post_buckling_lengths_mm":
            r(self.post_L_mm),
            "post_buckling": [{"deviation_mm": r(d), "tensions": r(s.p),
                               "tip_mm": r(s.tip * self.length_mm),
                               "unstable_modes_load": int(s.unstable_modes),
                               "unstable_modes_length": int(s.length_unstable_modes)}
                              for d, s in zip(self.post_deviation_mm, self.post_buckling)],
            "straight_column": {"deviation_mm": r(self.straight_deviation_mm),
                                "tensions": r(self.straight.p),
                                "unstable_modes_length": int(self.straight.length_unstable_modes)},
            "experiment_L1_held": [{"dL2_mm": r(d), "deviation_mm": r(w), "p2": r(p),
                                    "unstable_modes_load": int(s.unstable_modes),
                                    "unstable_modes_length": int(s.length_unstable_modes)}
                                   for d, w, p, s in zip(self.experiment_shortenings_mm,
                                                         self.experiment_deviation_mm,
                                                         self.experiment_p2, self.experiment)],
            "seconds": r(self.seconds, 3),
        }

    def report(self) -> str:
        """A few lines of text with the headline numbers."""
        lines = [
            f"Fig. 7 ({PAPER}): buckling of the straight segment under length control",
            f"  critical configuration: p1* = {self.p1_star:.6f}, p2 = 0, L0 = "
            f"({self.L0_mm[0]:.3f}, {self.L0_mm[1]:.3f}) mm",
            "  aligned family (perfect column): dL2 [mm] / L1 [mm] / p2 / lambda_min = "
            + "; ".join(f"{d:g}/{L[0]:.3f}/{s.p[1]:.3f}/{lam:.3g}" for d, L, s, lam in
                        zip(self.aligned_shortenings_mm, self.aligned_L_mm, self.aligned,
                            self.aligned_lambda)),
            f"  critical: dL2 = {self.dL2_cr_mm:.4f} mm, L = ({self.L_cr_mm[0]:.3f}, "
            f"{self.L_cr_mm[1]:.3f}) mm, p2 = {self.p2_cr:.4f}; clamped-column estimate "
            f"p2 = {self.p_clamped:.4f} (k a = {self.ka_clamped:.4f}), ratio "
            f"{self.load_ratio:.3f}",
        ]
        if self.event_dL2_mm is not None:
            lines.append(f"  continuation: lost stability at dL2 = {self.event_dL2_mm:.4f} mm"
                         f" ({self.event_kind})"
                         + ("" if self.jump_L_mm is None else
                            f", switched to a stable branch at L = ({self.jump_L_mm[0]:.3f}, "
                            f"{self.jump_L_mm[1]:.3f}) mm"))
        elif len(self.path):
            lines.append(f"  continuation: no instability reported up to dL2 = "
                         f"{self.aligned_shortenings_mm[len(self.path)]:g} mm; final segment "
                         f"deviation {self.path_deviation_mm[-1]:+.3f} mm")
        lines.append(f"  post-buckling at dL2 = {self.post_dL2_mm:.3f} mm: "
                     + ", ".join(f"deviation {w:+.3f} mm (p2 = {s.p[1]:.3f})"
                                 for w, s in zip(self.post_deviation_mm, self.post_buckling))
                     + f"; straight column p2 = {self.straight_p2:.3f} (unstable)")
        if len(self.experiment):
            lines.append(f"  paper's experiment (L1 held): at dL2 = "
                         f"{self.experiment_shortenings_mm[len(self.experiment) - 1]:g} mm "
                         f"deviation {self.experiment_deviation_mm[-1]:+.3f} mm, p2 = "
                         f"{self.experiment_p2[-1]:.3f}")
        return "\n".join(lines)
