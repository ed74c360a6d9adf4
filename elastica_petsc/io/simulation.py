"""The file of ``elastica-petsc simulate --out`` (layout in :mod:`elastica_petsc.cli.simulate`)."""
from __future__ import annotations

import json

import numpy as np

from .hdf5 import atomic_h5, provenance, put, write_attrs
from .records import RESULT_GROUP, encode


def write_simulation(path, overwrite: bool, result) -> None:
    """Every accepted step of a run (a studies.simulate.SimulationResult), mm, N, s, J:
    provenance, :func:`simulation_layout` and the whole result under ``/result``
    (``elastica_petsc.read`` returns it)."""
    with atomic_h5(path, overwrite) as fh:
        write_attrs(fh, provenance(result.arm, "simulation"))
        simulation_layout(fh, result)
        encode(fh, RESULT_GROUP, result)


def simulation_layout(fh, result) -> None:
    """The datasets and attributes of ``simulate --out`` in the open file ``fh``."""
    write_attrs(fh, {"elements": int(result.elements), "input": result.input,
                     "completed": bool(result.completed), "reason": result.reason,
                     "steps": int(result.steps), "rejected": int(result.rejected),
                     "f1_hz": float(result.f1_hz), "wall_s": float(result.wall_s),
                     "summary_json": json.dumps(result.summary())})
    put(fh, "time_s", result.time_s, "s", "time of each accepted step", ("step",))
    put(fh, "tip_mm", result.tip_mm, "mm", "tip position x(l)", ("step", "component"))
    put(fh, "x_mm", result.x_mm, "mm", "node positions x_k, k = 0..N",
        ("step", "node", "component"))
    put(fh, "theta", result.theta, "rad", "nodal angles theta_0..theta_N", ("step", "node"))
    put(fh, "tensions_N", result.tensions_N, "N", "cable tensions P_i", ("step", "tendon"))
    put(fh, "cable_lengths_mm", result.cable_lengths_mm, "mm",
        "cable lengths |r_i - x(s_i)|", ("step", "tendon"))
    put(fh, "energy_J", result.energy_J, "J",
        "kinetic, strain, work done on the arm by the tensions, potential of the weight "
        "(columns; kinetic + strain - work + weight is conserved without damping)",
        ("step", "energy"), {"energy": ["kinetic", "strain", "work", "gravity"]})
    ev = result.events
    put(fh, "event_time_s", np.array([e[0] for e in ev], float), "s", "slack/taut events", ("event",))
    put(fh, "event_tendon", np.array([e[1] for e in ev], int), "1", "tendon of each event", ("event",))
    put(fh, "event_kind", np.array([e[2].encode() for e in ev], dtype="S8"), "1",
        "slack or taut", ("event",))
    if result.planned_tip_mm is not None:
        put(fh, "planned_tip_mm", result.planned_tip_mm, "mm",
            "quasi-static tip of the schedule at time_s", ("step", "component"))


def read_theta(path) -> np.ndarray:
    """The last shape (nodal angles theta_0..theta_N) stored in a file the tool wrote:
    the first dataset named ``theta`` found (a simulation's last step, a solved state,
    a trace's last point)."""
    from .reader import open_h5
    from ..core.errors import InputError

    with open_h5(path) as fh:
        found = []
        fh.visititems(lambda name, obj: found.append(obj[()])
                      if name.split("/")[-1] == "theta" and not found and hasattr(obj, "shape")
                      else None)
    if not found:
        raise InputError(f"{path}: has no dataset theta (nodal angles) to start from")
    theta = np.atleast_2d(np.asarray(found[0], float))[-1]
    if not np.all(np.isfinite(theta)) or abs(theta[0]) > 1e-12:
        raise InputError(f"{path}: its theta is not a clamped shape (theta_0 = 0, finite)")
    return theta
