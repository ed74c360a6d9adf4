"""Read the files the tool writes back into result objects.

Every file carries its ``kind`` and the resolved configuration
(``config_json``) as root attributes (see :mod:`elastica_petsc.io.hdf5`), so
the arm and, where the file holds one, the solved state can be rebuilt
exactly: the bordered state follows from the stored nodal angles.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..core.model import arm_from_dict
from ..core.errors import InputError
from ..core.fem import Discretisation
from ..core.model import Arm
from ..solvers.equilibrium import Equilibrium


def open_h5(path: str | Path):
    """An h5py.File open for reading, or one line saying why it cannot be."""
    import h5py

    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    try:
        return h5py.File(path, "r")
    except OSError:
        raise InputError(f"{path}: not an HDF5 file written by elastica-petsc") from None


def file_arm(fh) -> Arm:
    """The arm a file was computed for (its ``config_json`` attribute)."""
    if "config_json" not in fh.attrs:
        raise InputError(f"{fh.filename}: no config_json attribute: not written by elastica-petsc")
    return arm_from_dict(json.loads(fh.attrs["config_json"]))


def equilibrium_from_group(group, arm: Arm) -> Equilibrium:
    """The Equilibrium stored by ``hdf5.write_equilibrium`` under ``group``."""
    theta = group["state/theta"][()]
    disc = Discretisation.from_arm(arm, len(theta) - 1)
    solver = group["solver"].attrs
    return Equilibrium(disc=disc, p=np.asarray(group["tendons/tensions"][()], float),
                       u=disc.consistent_state(theta), converged=bool(solver["converged"]),
                       reason=str(solver["reason"]), iterations=int(solver["iterations"]),
                       load_steps=int(solver["load_steps"]), message=str(solver["message"]),
                       unstable_modes=int(solver["unstable_modes"]),
                       bifurcations=bifurcations_of(group["solver"]))


def bifurcations_of(solver) -> tuple:
    """The symmetric bifurcations a stored state crossed (``hdf5.write_equilibrium``)."""
    from ..solvers.bifurcation import Bifurcation

    if "bifurcation_tensions" not in solver:
        return ()
    return tuple(Bifurcation(p, str(side), str(rule)) for p, side, rule in zip(
        solver["bifurcation_tensions"][()], solver.attrs["bifurcation_sides"],
        solver.attrs["bifurcation_rules"]))


def loading_of(fh) -> str:
    """How the stored state was reached from the straight arm."""
    order = str(fh.attrs.get("loading_order", "proportional"))
    return "proportional" if order in ("", "proportional") else f"order {order}"


def datasets(fh) -> dict:
    """Every dataset of a file as ``{"group/name": array}``."""
    import h5py

    out = {}
    fh.visititems(lambda name, obj: out.__setitem__(name, obj[()])
                  if isinstance(obj, h5py.Dataset) else None)
    return out


def read_file(path: str | Path, state_type):
    """A ``state_type(arm, equilibrium, loading)`` for files holding one solved
    state at their root (solve, control, stability); otherwise ``{"kind", "arm", "attrs", "data"}``."""
    with open_h5(path) as fh:
        kind = str(fh.attrs.get("kind", ""))
        arm = file_arm(fh)
        if "state/theta" in fh and "solver" in fh:
            return state_type(arm, equilibrium_from_group(fh, arm), loading_of(fh))
        return {"kind": kind, "arm": arm, "attrs": dict(fh.attrs), "data": datasets(fh)}


def file_kind(path: str | Path) -> str:
    """The ``kind`` root attribute of a file the tool wrote."""
    with open_h5(path) as fh:
        return str(fh.attrs.get("kind", ""))
