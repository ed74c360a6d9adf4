"""One writer per result the command line saves (layouts in :mod:`.hdf5`):
each opens the file aside, writes provenance and the result, and renames it
into place; :func:`save_result` writes any result (``elastica_petsc.save``)."""
from __future__ import annotations

import dataclasses
from pathlib import Path

from ..core.errors import InputError
from ..core.model import Arm
from ..solvers.equilibrium import Equilibrium
from .hdf5 import (atomic_h5, provenance, put, write_attrs, write_control, write_equilibrium,
                   write_loading, write_trace)
from .boundary import write_boundary_layout
from .calibration import calibration_layout
from .simulation import simulation_layout
from .friction import friction_layout
from .records import RESULT_GROUP, encode


def save_state(path, arm: Arm, eq: Equilibrium, *, overwrite: bool = False,
               loading: str = "proportional", kind: str = "equilibrium",
               loading_path=None) -> None:
    """A solved state (``solve --out``); ``loading`` is how it was reached; with
    ``loading_path`` (a :class:`~elastica_petsc.core.loading.Loading`) the path
    is written too (group ``loading``, read back by ``solve --from``)."""
    with atomic_h5(path, overwrite) as fh:
        write_attrs(fh, provenance(arm, kind))
        fh.attrs["loading_order"] = loading
        write_equilibrium(fh, arm, eq)
        if loading_path is not None:
            write_loading(fh, loading_path)


def save_stability(path, arm: Arm, eq: Equilibrium, result, freqs: dict | None, *,
                   overwrite: bool = False, loading: str = "proportional") -> None:
    """A state and its stability (``stability --out``): eigenvalues, modes,
    the paper's raw lambda_min, the asymmetry of K and natural frequencies."""
    with atomic_h5(path, overwrite) as fh:
        write_attrs(fh, provenance(arm, "stability"))
        fh.attrs["loading_order"] = loading
        write_equilibrium(fh, arm, eq)
        g = fh.create_group("stability")
        put(g, "eigenvalues", result.eigenvalues, "B/l^2", "lambda l^2/B, smallest first")
        put(g, "modes", result.modes, "rad", "theta part of the eigenvectors (N+1 nodes)")
        put(g, "lambda_min_raw", result.raw_min, "B/l", "lambda_min(K) at this mesh")
        put(g, "asymmetry", result.asymmetry, "1", "||K - K^T|| / ||K|| (probe estimate)")
        for control, f in (freqs or {}).items():
            put(g, f"frequencies_{control}_hz", f.hz, "Hz", f"natural frequencies, control={control}")


def save_control(path, arm: Arm, result, *, overwrite: bool = False) -> None:
    """A tip-control result (``control --out``): the layout of :func:`.hdf5.write_control`
    and the whole :class:`~elastica_petsc.solvers.control.ControlResult` under
    ``/result`` (``elastica_petsc.read`` returns it)."""
    with atomic_h5(path, overwrite) as fh:
        write_attrs(fh, provenance(arm, "control"))
        write_control(fh, arm, result)
        encode(fh, RESULT_GROUP, result)


def save_trace(path, arm: Arm, planned, attrs: dict, *, overwrite: bool = False) -> None:
    """A traced path with its motor schedule (``trace --out``): root ``attrs``
    (elements, step, source, sharing), the layout of :func:`.hdf5.write_trace`
    and the whole :class:`~elastica_petsc.studies.schedule.TracedSchedule`
    under ``/result`` (``elastica_petsc.read`` returns it)."""
    with atomic_h5(path, overwrite) as fh:
        write_attrs(fh, provenance(arm, "trace"))
        write_attrs(fh, attrs)
        write_trace(fh, arm, planned.path, planned.schedule)
        encode(fh, RESULT_GROUP, planned)


def _state_layout(fh, state) -> None:
    """``solve --out``'s layout (:func:`~elastica_petsc.io.save.save_state`)."""
    fh.attrs["loading_order"] = state.loading
    write_equilibrium(fh, state.arm, state.equilibrium)


def _boundary_layout(fh, result) -> None:
    write_boundary_layout(fh, result)


# the command line's layout per result type (by class name: io sits below the api layer)
LAYOUTS = {"State": ("equilibrium", _state_layout),
           "BoundaryResult": ("boundary", _boundary_layout),
           "SimulationResult": ("simulation", simulation_layout),
           "CalibrationResult": ("calibration", calibration_layout),
           "FrictionResult": ("friction", friction_layout)}


def result_arm(result):
    """The arm a result was computed for, or None if it does not hold one."""
    for name in ("arm", "arm_after"):
        arm = getattr(result, name, None)
        if arm is not None:
            return arm
    return None


def save_result(path, result, *, overwrite: bool = False) -> Path:
    """Write ``result`` to ``path`` (.h5): provenance, the command line's
    layout where it has one (:data:`LAYOUTS`), and ``/result`` (the whole
    result, read back by :func:`read_result`).  Written aside and renamed."""
    from .. import __version__

    if not dataclasses.is_dataclass(result) or isinstance(result, type):
        raise InputError(f"cannot save a {type(result).__name__}: not a result")
    name = type(result).__name__
    kind, layout = LAYOUTS.get(name, (name, None))
    arm = result_arm(result)
    with atomic_h5(path, overwrite) as fh:
        if arm is not None:
            write_attrs(fh, provenance(arm, kind))
        else:
            write_attrs(fh, {"kind": kind, "elastica_petsc_version": __version__})
        if layout is not None:
            layout(fh, result)
        fh.attrs["kind"] = kind
        encode(fh, RESULT_GROUP, result)
        fh[RESULT_GROUP].attrs["description"] = (
            "the whole result object (elastica_petsc.io.records), read by elastica_petsc.read")
    return Path(path)
