"""Reproduce the state recorded in an output file (``solve --from FILE``).

Load control selects its equilibrium by the loading history (Fig. 8), so the
tensions alone do not reproduce a state.  Files written by ``solve``,
``control`` and ``trace`` record the loading path from the straight arm
(:mod:`elastica_petsc.core.loading`, HDF5 group ``loading``);
:func:`state_from_file` replays it by continuation
(:func:`elastica_petsc.solvers.reach.replay`).  The state of a ``lengths`` /
``equilibria`` file (``equilibria/state_K``) was found by a search, not a
loading path: it is reproduced by Newton's method at its tensions from its
stored shape (``how`` says which).  Either way the reproduced state is
compared with the stored one (tip and angles).
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.model import arm_from_dict
from ..core.errors import InputError
from ..core.fem import Discretisation
from ..core.loading import Loading
from ..core.model import Arm
from ..io.hdf5 import read_loading
from ..solvers.equilibrium import Equilibrium, EquilibriumSolver, newton_converged
from ..solvers.reach import replay

LOADED_KINDS = ("equilibrium", "control", "trace")
SEARCHED_KINDS = ("length_equilibria", "load_equilibria")


@dataclass(frozen=True)
class RestoredState:
    """A reproduced state and how it compares with the file (mm)."""

    arm: Arm
    equilibrium: Equilibrium
    loading: Loading | None          # None: reproduced by Newton from the stored shape
    how: str                         # one line
    stored_tip_mm: np.ndarray
    tip_difference_mm: float         # |reproduced tip - stored tip|
    theta_difference: float          # max |reproduced theta - stored theta| [rad]
    source: str


def _attr(fh, name, default=None):
    value = fh.attrs.get(name, default)
    return value.decode() if isinstance(value, bytes) else value


def _open(path):
    import h5py

    p = Path(path)
    if not p.is_file():
        raise InputError(f"{p}: no such file")
    try:
        return h5py.File(p, "r")
    except OSError:
        raise InputError(f"{p}: not an HDF5 file (expected an --out file of solve, control, "
                         "trace, lengths or equilibria)") from None


def _arm(fh, p) -> Arm:
    if "config_json" not in fh.attrs:
        raise InputError(f"{p}: no attribute config_json (not written by elastica-petsc)")
    try:
        return arm_from_dict(json.loads(_attr(fh, "config_json")))
    except (ValueError, TypeError) as err:
        raise InputError(f"{p}: attribute config_json: {err}") from None


def _index(value, count: int, what: str, option: str, p) -> int:
    if value is None:
        raise InputError(f"{p} holds {count} {what}s: choose one with {option} "
                         f"(0..{count - 1})" if what == "point" else
                         f"{p} holds {count} {what}s: choose one with {option} (1..{count})")
    low, high = (0, count - 1) if what == "point" else (1, count)
    if not low <= value <= high:
        raise InputError(f"{option} {value} is out of range: {p} has {what}s {low}..{high}")
    return value


def _stored(fh, kind, p, point, state):
    """(theta, tip_mm, tensions, loading or None, label) of the stored state."""
    if kind == "trace":
        g = fh["path"]
        k = _index(point, len(g["tip"]), "point", "--point", p)
        if "loading_node" not in g:
            raise InputError(f"{p}: trace file without /path/loading_node (written before "
                             "loading paths were recorded: rerun the trace)")
        loading = read_loading(fh, int(g["loading_node"][k]))
        return g["theta"][k], g["tip"][k], g["tensions"][k], loading, f"point {k}"
    if kind in SEARCHED_KINDS:
        count = int(_attr(fh, "n_equilibria", len(fh["equilibria"])))
        k = _index(state, count, "state", "--state", p)
        g = fh[f"equilibria/state_{k}"]
        return (g["state/theta"][()], g["state/tip"][()], g["tendons/tensions"][()], None,
                f"state {k}")
    loading = read_loading(fh)
    if loading is None and kind == "equilibrium":
        order = _attr(fh, "loading_order", "proportional")
        p_end = fh["tendons/tensions"][()]
        loading = Loading.ordered(p_end, None if order == "proportional"
                                  else tuple(int(v) for v in order.split(",")))
    return fh["state/theta"][()], fh["state/tip"][()], fh["tendons/tensions"][()], loading, kind


def state_from_file(path, point: int | None = None, state: int | None = None) -> RestoredState:
    """Reproduce the equilibrium recorded in ``path`` (an HDF5 output of solve,
    control, trace with ``point`` (0-based row), lengths or equilibria with
    ``state`` (1-based, ``equilibria/state_K``)); same arm and mesh as the file."""
    p = Path(path)
    with _open(p) as fh:
        kind = _attr(fh, "kind")
        if kind not in LOADED_KINDS + SEARCHED_KINDS:
            raise InputError(f"{p}: kind {kind!r} holds no single state to reproduce (expected "
                             "one of " + ", ".join(LOADED_KINDS + SEARCHED_KINDS) + ")")
        if point is not None and kind != "trace":
            raise InputError(f"--point applies to trace files; {p} is a {kind} file")
        if state is not None and kind not in SEARCHED_KINDS:
            raise InputError(f"--state applies to lengths/equilibria files; {p} is a {kind} file")
        arm = _arm(fh, p)
        theta, tip_mm, tensions, loading, label = _stored(fh, kind, p, point, state)
    theta, tip_mm = np.asarray(theta, float), np.asarray(tip_mm, float)
    if kind in LOADED_KINDS and loading is None:
        raise InputError(f"{p} ({label}): the loading path was not recorded, so the branch "
                         "cannot be reproduced")
    disc = Discretisation.from_arm(arm, len(theta) - 1)
    with EquilibriumSolver(disc) as solver:
        if loading is not None:
            eq = replay(solver, loading)
            how = f"{loading.describe()} from the straight arm, by continuation"
        else:
            eq = _newton(solver, disc, theta, np.asarray(tensions, float))
            how = "Newton's method at the stored tensions from the stored shape"
    if eq is None:
        raise InputError(f"{p} ({label}): replaying its loading path failed")
    return RestoredState(
        arm=arm, equilibrium=eq, loading=loading, how=how, stored_tip_mm=tip_mm,
        tip_difference_mm=float(np.linalg.norm(eq.tip * arm.length_mm - tip_mm)),
        theta_difference=float(np.max(np.abs(eq.theta - theta))), source=f"{p} ({label})")


def _newton(solver: EquilibriumSolver, disc: Discretisation, theta, p) -> Equilibrium:
    u, its, reason = solver.newton(disc.consistent_state(theta), p)
    return Equilibrium(disc, p.copy(), u, converged=newton_converged(reason), reason=reason,
                       iterations=its, load_steps=0,
                       unstable_modes=solver.inertia.negative_eigenvalues(u, p))
