"""The file of ``elastica-petsc friction --out`` / ``FrictionResult.save`` (docs/model.md
§27): per row of the load path the motors, the tip, every segment's tension and every
guide's mode and wrap angle, in mm, N and degrees."""
from __future__ import annotations

import json

import numpy as np

from .hdf5 import put, write_attrs


def friction_layout(fh, result) -> None:
    """The datasets and attributes of a friction path in the open file ``fh``."""
    path = result.path
    write_attrs(fh, {"converged": bool(path.converged), "message": path.message,
                     "increments": int(path.increments),
                     "newton_iterations": int(path.iterations),
                     "cable_compliance": float(path.compliance),
                     "summary_json": json.dumps({k: v for k, v in result.summary().items()
                                                 if k in ("mu", "converged", "increments")})})
    put(fh, "mu", path.mu, "1", "Coulomb friction coefficient of each guide", ("guide",))
    put(fh, "length_control", path.length_control.astype(np.int8), "1",
        "1 where the tendon's motor held a cable length (else a tension)", ("tendon",))
    put(fh, "motor_tensions_N", result.motor_tensions_N, "N",
        "tension of each cable at its motor", ("row", "tendon"))
    put(fh, "cable_lengths_mm", result.cable_lengths_mm, "mm", "whole cable lengths",
        ("row", "tendon"))
    put(fh, "tip_mm", result.tip_mm, "mm", "tip position x(l)", ("row", "component"))
    put(fh, "segment_tensions_N", result.segment_tensions_N, "N",
        "tension of every cable segment, each cable from its motor", ("row", "segment"))
    put(fh, "modes", path.modes.astype(np.int8), "1",
        "per guide: -1 slip toward the motor, 0 stick, 1 slip toward the end", ("row", "guide"))
    put(fh, "wrap_deg", result.wrap_deg, "degree",
        "angle the cable turns through at each guide", ("row", "guide"))
