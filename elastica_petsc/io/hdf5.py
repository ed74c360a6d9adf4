"""HDF5 output: layout, units and provenance.

Every file carries, as root attributes, ``kind`` (what it holds), the
resolved configuration (``config_json``), the package, PETSc and SLEPc
versions, the command line and the creation time.  Every dataset carries a
``units`` attribute and a ``description``.  Files are written aside and
renamed into place, so the target path never holds a half-written file.

Layout of an equilibrium group (``write_equilibrium``)::

    mesh/s                 (N+1,)   mm      arc length of the nodes
    state/theta            (N+1,)   rad     tangent angle at the nodes
    state/x                (N+1, 2) mm      centreline at the nodes (Eq. (2))
    state/curvature        (N,)     1       l * theta' per element
    state/tip              (2,)     mm
    state/strain_energy    ()       B/(2l)  (Eq. (21));  strain_energy_J: J
    state/kappa_max        ()       1       max l|theta'|
    tendons/attach_s       (n,)     mm      attachment arc lengths
    tendons/routes         (n, 2)   mm      routing points r_i
    tendons/attachments    (n, 2)   mm      x_i
    tendons/directions     (n, 2)   1       d_i (Eq. (3))
    tendons/cable_lengths  (n,)     mm      |r_i - x_i|
    tendons/tensions       (n,)     P l^2/B
    tendons/tensions_N     (n,)     N
    tendons/cable_clear    (n,)     bool    cable segment does not cross the arm
    guides/...             (P,...)          cables through guides only (io/guides.py)
    solver (attributes)    converged, reason, message, iterations, load_steps,
                           unstable_modes, stable; after a symmetric bifurcation
                           bifurcation_sides, bifurcation_rules and the dataset
                           solver/bifurcation_tensions (k, n) P l^2/B
"""
from __future__ import annotations

import contextlib
import datetime
import os
import platform
import sys
from pathlib import Path

import numpy as np

from ..core import jsontext
from .. import __version__
from ..core.clearance import state_cable_clear
from ..core.config import arm_to_dict
from ..solvers.equilibrium import Equilibrium
from ..core.errors import InputError
from ..core.model import Arm
from .dims import put  # noqa: F401 - re-exported: every writer's dataset helper
from .exclusive import OutputLock, replace_file  # noqa: F401 - OutputLock: re-exported


H5_SUFFIXES = (".h5", ".hdf5")
PLOT_SUFFIXES = (".png", ".pdf", ".svg")


class OutputError(InputError):
    """An output location that cannot be written (reported like bad input)."""


def check_output_path(path: str | Path, overwrite: bool, suffixes=None,
                      option: str = "--out") -> Path:
    """Refuse, before any computation, an output file that could not be written:
    an empty name, a folder (or a name ending in '/'), an unknown extension
    (``suffixes``), a folder that does not exist or cannot be written to, and an
    existing file without ``overwrite`` (or one that cannot be replaced)."""
    text = str(path)
    if not text.strip():
        raise OutputError(f"{option}: empty file name")
    path = Path(text)
    if text.endswith(("/", os.sep)) or path.is_dir():
        raise OutputError(f"{option} {text}: is a folder; give a file name")
    if suffixes and path.suffix.lower() not in suffixes:
        raise OutputError(f"{option} {text}: unknown extension {path.suffix or '(none)'!r}; "
                          f"expected {' or '.join(suffixes)}")
    if path.exists() and not overwrite:
        raise OutputError(f"{path} exists; pass --overwrite to replace it")
    folder = path.parent
    if not folder.is_dir():
        raise OutputError(f"{folder}: no such directory for the output file")
    probe_writable(folder, path)
    return path


def probe_writable(folder: Path, path: Path) -> None:
    """Create and remove a file beside ``path`` (root ignores permission bits, so
    only trying tells a read-only mount); an existing file must be replaceable."""
    probe = folder / f".{path.name}.probe-{os.getpid()}"
    try:
        fd = os.open(probe, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o600)
        os.close(fd)
        os.unlink(probe)
    except OSError as err:
        raise OutputError(f"{folder}: cannot write there ({err.strerror})") from None
    if path.exists() and not os.access(path, os.W_OK):
        raise OutputError(f"{path}: cannot be replaced (read-only or immutable)")


def check_distinct(paths: dict) -> None:
    """Refuse two outputs of one command that name the same file ({option: path})."""
    seen = {}
    for option, path in paths.items():
        if not path:
            continue
        key = os.path.realpath(path)
        if key in seen:
            raise OutputError(f"{seen[key]} and {option} name the same file {path}")
        seen[key] = option


def remove_orphans(path: Path) -> None:
    """Remove temporaries of ``path`` left by writers that died (their pid is gone)."""
    for tmp in path.parent.glob(f".{path.name}.tmp-*"):
        try:
            pid = int(tmp.name.rsplit("-", 1)[1])
            os.kill(pid, 0)
        except ValueError:
            continue
        except ProcessLookupError:
            with contextlib.suppress(OSError):
                tmp.unlink()
        except PermissionError:
            pass


@contextlib.contextmanager
def atomic_h5(path: str | Path, overwrite: bool = False):
    """An h5py.File to fill, built in memory and written to a temporary name,
    synced and renamed to ``path``.  HDF5 itself never writes to the disk, so a
    full disk is one ``OSError`` of a plain write, raised as
    :class:`OutputError`, and any earlier file at ``path`` stays as it was."""
    import io

    import h5py

    path = check_output_path(path, overwrite)
    remove_orphans(path)
    buffer = io.BytesIO()
    with h5py.File(buffer, "w") as fh:
        yield fh
    try:
        replace_file(path, buffer.getbuffer())
    except InputError:
        raise
    except OSError as err:
        raise OutputError(f"cannot write {path}: {err.strerror or err}") from None


# PETSc options that change no number (monitors, viewers, logging): not part of a result
NEUTRAL_OPTIONS = ("monitor", "view", "log", "info", "options_left", "help", "malloc",
                   "signal_handler", "error_output")


def petsc_options() -> str:
    """The PETSc options in force that can change results, ``name=value`` sorted
    and space-separated ('' if none)."""
    from petsc4py import PETSc

    items = PETSc.Options().getAll().items()
    return " ".join(f"{k}={v}" for k, v in sorted(items)
                    if not any(word in k for word in NEUTRAL_OPTIONS))


def provenance(arm: Arm, kind: str) -> dict:
    """Root attributes: what, from which config, by which software, how, when."""
    from petsc4py import PETSc

    info = {
        "kind": kind,
        "config_json": jsontext.dumps(arm_to_dict(arm)),
        "elastica_petsc_version": __version__,
        "petsc_version": "%d.%d.%d" % PETSc.Sys.getVersion(),
        "python_version": platform.python_version(),
        "command_line": " ".join(sys.argv),
        "petsc_options": petsc_options(),
        "created_utc": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "length_unit": "mm",
        "tension_unit": "P l^2/B (non-dimensional); *_N datasets in newtons",
        "force_scale_N": arm.force_scale_N,
        "energy_scale_J": arm.energy_scale_J,
    }
    try:
        from slepc4py import SLEPc
        info["slepc_version"] = "%d.%d.%d" % SLEPc.Sys.getVersion()
    except ImportError:
        pass
    return info


def write_attrs(obj, attrs: dict) -> None:
    for key, value in attrs.items():
        obj.attrs[key] = value


def write_equilibrium(group, arm: Arm, eq: Equilibrium) -> None:
    """One solved state under ``group`` (layout in the module docstring)."""
    l_mm = arm.length_mm
    mesh = group.create_group("mesh")
    put(mesh, "s", np.linspace(0.0, l_mm, eq.disc.n_elements + 1), "mm", "arc length of nodes",
        ("node",))
    state = group.create_group("state")
    put(state, "theta", eq.theta, "rad", "tangent angle at the nodes (P1)", ("node",))
    put(state, "x", eq.x * l_mm, "mm", "centreline position at the nodes (Eq. (2))",
        ("node", "component"))
    put(state, "curvature", eq.curvature, "1", "l * dtheta/ds per element", ("element",))
    put(state, "tip", eq.tip * l_mm, "mm", "tip position x(l)", ("component",))
    put(state, "strain_energy", eq.strain_energy, "B/(2l)", "strain energy (Eq. (21)) / SE_0")
    put(state, "strain_energy_J", eq.strain_energy * arm.energy_scale_J, "J", "strain energy")
    put(state, "kappa_max", eq.kappa_max, "1", "max over s of l*|theta'| (Fig. 5a)")
    tendons = group.create_group("tendons")
    put(tendons, "attach_s", [t.attach_mm for t in arm.tendons], "mm", "attachment arc length s_i",
        ("tendon",))
    put(tendons, "routes", arm.routes() * l_mm, "mm", "routing points r_i", ("tendon", "component"))
    put(tendons, "attachments", eq.attachments * l_mm, "mm", "attachment points x_i",
        ("tendon", "component"))
    put(tendons, "directions", eq.directions, "1", "unit cable directions d_i (Eq. (3))",
        ("tendon", "component"))
    put(tendons, "cable_lengths", eq.cable_lengths * l_mm, "mm", "cable lengths |r_i - x_i|",
        ("tendon",))
    put(tendons, "tensions", eq.p, "P l^2/B", "non-dimensional tensions p_i", ("tendon",))
    put(tendons, "tensions_N", arm.tensions_to_N(eq.p), "N", "tensions P_i", ("tendon",))
    put(tendons, "cable_clear", state_cable_clear(eq), "1",
        "the straight cable [x_i, r_i] does not cross the arm (HDF5 boolean)", ("tendon",))
    from .guides import has_guides, write_guides
    if has_guides(eq.disc):              # cables through guides (io/guides.py)
        write_guides(group, arm, eq)
    solver = group.create_group("solver")
    write_attrs(solver, {"converged": bool(eq.converged), "reason": eq.reason,
                         "message": eq.message, "iterations": int(eq.iterations),
                         "load_steps": int(eq.load_steps), "stable": bool(eq.stable),
                         "unstable_modes": int(eq.unstable_modes)})
    if eq.bifurcations:
        put(solver, "bifurcation_tensions", np.array([b.p_critical for b in eq.bifurcations]),
            "P l^2/B", "critical tensions of the symmetric bifurcations crossed, in order",
            ("bifurcation", "tendon"))
        write_attrs(solver, {"bifurcation_sides": [b.side for b in eq.bifurcations],
                             "bifurcation_rules": [b.rule for b in eq.bifurcations]})


def write_control(group, arm: Arm, result) -> None:
    """A tip-control solve (Eqs. (10)-(12)): final state plus the iteration history."""
    l_mm = arm.length_mm
    write_equilibrium(group, arm, result.equilibrium)
    ctl = group.create_group("control")
    put(ctl, "target", result.target * l_mm, "mm", "desired tip position x_d", ("component",))
    put(ctl, "tip_error", result.tip_error * l_mm, "mm", "|x_t - x_d|")
    put(ctl, "tip_sensitivity", result.sensitivity.tip * l_mm, "mm per (P l^2/B)",
        "d x_t / d p_i (Eq. (13)), one row per tendon", ("tendon", "component"))
    put(ctl, "history_tensions", result.history_p, "P l^2/B", "tensions at iterations 0..k",
        ("iteration", "tendon"))
    put(ctl, "history_tip", result.history_tip * l_mm, "mm", "tip at iterations 0..k",
        ("iteration", "component"))
    put(ctl, "history_E", result.history_E * l_mm ** 2, "mm^2",
        "objective E = |x_d - x_t|^2 / 2 at iterations 0..k (Eq. (10))", ("iteration",))
    write_attrs(ctl, {"converged": bool(result.converged),
                      "reachable": str(result.reachable), "reason": result.reason,
                      "tao_reason": result.tao_reason, "method": result.method,
                      "iterations": int(result.iterations),
                      "evaluations": int(result.evaluations), "message": result.message,
                      "evidence": result.evidence, "strategy": result.strategy})
    write_loading(group, result.loading)


def write_trace(group, arm: Arm, trace, schedule) -> None:
    """A traced path (Sec. 4.2): per point k targets, tips, tensions, cable
    lengths, shapes, sensitivities, and the motor schedule.

    Layout (K points, n tendons, N elements): path/target (K,2) mm, path/tip
    (K,2) mm, path/tensions (K,n) P l^2/B, path/tensions_N (K,n) N,
    path/cable_lengths (K,n) mm, path/theta (K,N+1) rad, path/curvature (K,N),
    path/tip_sensitivity (K,n,2) mm per unit p, path/iterations (K,),
    path/converged (K,), path/tip_error (K,) mm, path/cable_clear (K,n) bool,
    path/loading_node (K,) (the point's loading path in the tree /loading,
    :func:`write_loading_tree`); schedule/ the timed motor
    schedule (:func:`write_schedule`: R >= K rows, the approach first).
    """
    l_mm = arm.length_mm
    results = trace.results
    path = group.create_group("path")
    P2, PT = ("point", "component"), ("point", "tendon")
    put(path, "target", trace.targets_mm, "mm", "target tip positions, in tracing order", P2)
    put(path, "tip", trace.tips_mm, "mm", "tip positions reached", P2)
    put(path, "tip_error", trace.tip_errors_mm, "mm", "|tip - target|", ("point",))
    put(path, "tensions", trace.p, "P l^2/B", "non-dimensional tensions", PT)
    put(path, "tensions_N", trace.tensions_N, "N", "tensions", PT)
    put(path, "cable_lengths", trace.cable_lengths_mm, "mm", "cable lengths |r_i - x_i|", PT)
    put(path, "theta", np.array([r.equilibrium.theta for r in results]), "rad",
        "nodal tangent angles of each equilibrium", ("point", "node"))
    put(path, "curvature", np.array([r.equilibrium.curvature for r in results]), "1",
        "l * theta' per element, each point", ("point", "element"))
    put(path, "tip_sensitivity", np.array([r.sensitivity.tip for r in results]) * l_mm,
        "mm per (P l^2/B)", "d x_t / d p_i (Eq. (13)): [point, tendon, component]",
        ("point", "tendon", "component"))
    put(path, "iterations", trace.iterations, "1", "optimiser iterations per point", ("point",))
    put(path, "converged", trace.converged, "1", "tip within tolerance of the target", ("point",))
    put(path, "cable_clear", np.array([state_cable_clear(r.equilibrium) for r in results],
                                      dtype=bool).reshape(len(results), -1), "1",
        "per point and tendon: the straight cable does not cross the arm (HDF5 boolean)", PT)
    from .guides import has_guides, write_trace_guides
    if results and has_guides(results[0].equilibrium.disc):
        write_trace_guides(path, arm, [r.equilibrium for r in results])
    ends = write_loading_tree(group, [r.loading for r in results])
    put(path, "loading_node", ends, "1",
        "per point: last vertex of its loading path in /loading (-1: p = 0, -2: unknown)",
        ("point",))
    write_schedule(group.create_group("schedule"), schedule)


def write_schedule(sched, schedule) -> None:
    """The timed motor schedule (:mod:`elastica_petsc.core.schedule`), the
    same rows and columns as its CSV: R rows (approach, then path), n tendons."""
    R, RT, RC = ("row",), ("row", "tendon"), ("row", "component")
    put(sched, "phase", schedule.phase.astype(str), "1", "approach or path", R)
    put(sched, "point", schedule.point, "1", "index within the phase (path: index of path/)", R)
    put(sched, "time", schedule.time_s, "s",
        "time of the row: the tip speed, re-timed under the motor limits (NaN: untimed)", R)
    put(sched, "duration", schedule.durations_s, "s", "duration of the move into the row", R)
    put(sched, "limited_by", schedule.limited_by.astype(str), "1",
        "what sets that duration: tip_speed, speed_I, accel_I (motor I), none; start at row 0", R)
    put(sched, "reached", schedule.reached.astype(bool), "1", "tip within tolerance of the target",
        R)
    put(sched, "target", schedule.targets_mm, "mm", "target tip position", RC)
    put(sched, "tip", schedule.tips_mm, "mm", "tip position of the planned state", RC)
    put(sched, "tensions", schedule.p, "P l^2/B", "non-dimensional tensions p_i", RT)
    put(sched, "tensions_N", schedule.tensions_N, "N", "tensions P_i", RT)
    put(sched, "cable_lengths", schedule.lengths_mm, "mm", "cable lengths L_i", RT)
    put(sched, "revolutions", schedule.revolutions, "rev", "spool revolutions from row 0", RT)
    put(sched, "steps", schedule.steps, "microsteps",
        "motor microsteps from row 0 (> 0: cable paid out, < 0: reeled in)", RT)
    put(sched, "step_increments", schedule.step_increments, "microsteps",
        "microsteps from the previous row", RT)
    put(sched, "rounding_error", schedule.rounding_error_mm, "mm",
        "imposed minus requested cable length change (integer steps)", RT)
    write_attrs(sched, {"spool_radius_mm": schedule.spool_radius_mm,
                        "steps_per_revolution": schedule.steps_per_revolution,
                        "speed_mm_s": schedule.speed_mm_s})


# --- loading paths (how a state is reached from the straight arm) -----------------------
def write_loading(group, loading) -> None:
    """``loading/vertices`` (k, n) P l^2/B: the loading path of
    :class:`~elastica_petsc.core.loading.Loading` from p = 0, each segment followed
    by continuation; attributes ``kind`` (proportional, order, path, unknown),
    ``order`` ("2,1" or "") and ``description``.  ``loading`` None: kind unknown."""
    g = group.create_group("loading")
    if loading is None:
        write_attrs(g, {"kind": "unknown", "order": "", "description": "not recorded"})
        return
    info = loading.to_json()
    put(g, "vertices", loading.vertices(), "P l^2/B",
        "tension vertices after p = 0 (straight arm), each reached by continuation")
    write_attrs(g, {"kind": info["kind"], "order": ",".join(map(str, info["order"] or ())),
                    "description": info["description"]})


def write_loading_tree(group, loadings) -> np.ndarray:
    """Many loading paths sharing their history (a trace): ``loading/vertices``
    (M, n) and ``loading/parent`` (M,) (index of the previous vertex, -1: p = 0);
    returns each path's last vertex index (-1: the straight arm; -2: unknown)."""
    index, vertices, parents, ends = {}, [], [], []
    for loading in loadings:
        if loading is None:
            ends.append(-2)
            continue
        chain, node = [], loading
        while node.parent is not None and id(node) not in index:
            chain.append(node)
            node = node.parent
        for item in reversed(chain):
            up = item.parent
            parents.append(-1 if up.parent is None else index[id(up)])
            index[id(item)] = len(vertices)
            vertices.append(item.p)
        ends.append(-1 if loading.parent is None else index[id(loading)])
    n = next((len(v) for v in vertices), 0)
    g = group.create_group("loading")
    put(g, "vertices", np.array(vertices).reshape(-1, n) if vertices else np.zeros((0, 0)),
        "P l^2/B", "tension vertices of the loading paths (a tree rooted at p = 0)")
    put(g, "parent", np.array(parents, dtype=np.int64), "1",
        "index of the previous vertex on the path (-1: p = 0, the straight arm)")
    write_attrs(g, {"kind": "tree"})
    return np.array(ends, dtype=np.int64)


def read_loading(fh, node: int | None = None):
    """The :class:`~elastica_petsc.core.loading.Loading` stored by
    :func:`write_loading` (``node`` None) or path ``node`` of a
    :func:`write_loading_tree`; None if not recorded."""
    from ..core.loading import Loading

    if "loading" not in fh:
        return None
    g = fh["loading"]
    if node is None:
        if "vertices" not in g:
            return None
        return Loading.from_vertices(g["vertices"][()])
    if node == -2:
        return None
    vertices, parents = g["vertices"][()], g["parent"][()]
    chain = []
    while node >= 0:
        chain.append(vertices[node])
        node = int(parents[node])
    n = vertices.shape[1] if vertices.ndim == 2 and vertices.shape[1] else None
    if not chain:
        return Loading.straight(n) if n else None
    return Loading.from_vertices(np.array(chain[::-1]))
