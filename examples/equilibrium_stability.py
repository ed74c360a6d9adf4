"""An equilibrium of the paper's arm and its stability (Fig. 8, state 1).

Run: python examples/equilibrium_stability.py
"""
import elastica_petsc as ep

arm = ep.Arm.paper()
# Tendon 2 tensioned before tendon 1 selects the paper's state 1 (Fig. 8).
state = ep.solve(arm, tensions_N=[14.0, 6.0], order=(2, 1))
print("tip [mm]:", state.tip_mm.round(3))
print("cable lengths [mm]:", state.cable_lengths_mm.round(2), "(paper: 147.1, 472.5)")
modes = ep.stability(state, modes=3)
print("lowest eigenvalues [lambda l^2/B]:", modes.eigenvalues.round(4))
print("stable under load control:", modes.stable)
