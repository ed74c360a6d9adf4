"""What a workspace map holds (paper Sec. 4.3, Eqs. (18)-(22), Figs. 4-5): the
status of a sample, the per-sample fields with their units, the samples of a
run in memory (:class:`Results`) and the finished map (:class:`WorkspaceMap`)."""
from __future__ import annotations

import functools
from dataclasses import dataclass
from enum import IntEnum
from pathlib import Path

import numpy as np

from ...core.results import Result
from ...io.workspace import lattice_index, new_map_rows, write_results
from ..chunks import ChunkResults, Grid


class Status(IntEnum):
    """The status of a sample (the integers stored in ``samples/status``).

    With the global search (samplers "boundary-fill", the default, and "global-search"),
    a target is REACHED,
    UNDECIDED (not reached after the global search: no proof either way), BEYOND_REACH
    (|x_d| > l: proven) or OUTSIDE_BOUNDARY (outside the traced boundary of W_0,
    docs/model.md §9.1: proven).  NEEDS_NEGATIVE and NOT_CONVERGED are the local
    verdicts of sampler "local" (``global_search=False`` and files written before the
    global search).  With a pretension floor P_min (``--min-tension-N``) REACHED means
    reached with every P_i >= P_min (W_0(P_min), docs/model.md §9.3), and BELOW_FLOOR:
    reached with P >= 0 (in W_0), but no tension set with every P_i >= P_min was found
    (not a proof that there is none); UNIQUE_BELOW_FLOOR (two tendons): the tensions
    found are below the floor and they are the target's only ones (a face of the traced
    boundary with one preimage): proven."""

    NOT_COMPUTED = 0
    REACHED = 1
    NEEDS_NEGATIVE = 2
    NOT_CONVERGED = 3
    UNDECIDED = 4
    BEYOND_REACH = 5
    OUTSIDE_BOUNDARY = 6
    BELOW_FLOOR = 7
    UNIQUE_BELOW_FLOOR = 8


STATUS_NAMES = {Status.NOT_COMPUTED: "not computed", Status.REACHED: "reached with P >= 0",
                Status.NEEDS_NEGATIVE: "tip control ended on P_i = 0 (would need a negative "
                                       "tension locally; not a proof of outside W_0)",
                Status.NOT_CONVERGED: "not converged",
                Status.UNDECIDED: "not reached after the global search (undecided: not proven "
                                  "outside W_0)",
                Status.BEYOND_REACH: "beyond reach |x| > l (proven unreachable)",
                Status.OUTSIDE_BOUNDARY: "outside the traced W_0 boundary (proven unreachable, "
                                  "docs/model.md §9.1)",
                Status.BELOW_FLOOR: "reached with P >= 0, but no tensions >= the floor found "
                             "(undecided for W_0(P_min): not a proof, docs/model.md §9.3)",
                Status.UNIQUE_BELOW_FLOOR: "reached with P >= 0 by the only tensions that reach it, "
                                    "below the floor (proven outside W_0(P_min), two tendons, "
                                    "docs/model.md §9.3)"}


def reason_counts(reasons: np.ndarray) -> str:
    """'REASON count, ...' of the byte-string ``reason`` values of some samples,
    most frequent first."""
    names, counts = np.unique(reasons, return_counts=True)
    order = np.argsort(-counts, kind="stable")
    return ", ".join(f"{names[k].decode()} {counts[k]}" for k in order)


def fields(n_tendons: int) -> dict[str, tuple[tuple, str, str, str]]:
    """Per-sample datasets: name -> (shape per sample, dtype, units, description)."""
    n = (n_tendons,)
    return {
        "target": ((2,), "f8", "mm", "target tip position (NaN in tensions mode)"),
        "tip": ((2,), "f8", "mm", "tip position reached"),
        "tip_error": ((), "f8", "mm", "distance from tip to target (NaN in tensions mode)"),
        "tensions": (n, "f8", "P l^2/B", "cable tensions p_i"),
        "tensions_N": (n, "f8", "N", "cable tensions P_i"),
        "cable_lengths": (n, "f8", "mm", "cable lengths |r_i - x_i|"),
        "kappa_max": ((), "f8", "1", "max l*|theta'| (Fig. 5a, Eq. (19))"),
        "lambda_min": ((), "f8", "B/l^2", "smallest eigenvalue of K v = lambda M v, "
                       "lambda l^2/B (Fig. 5b, Eq. (20))"),
        "lambda_min_raw": ((), "f8", "B/l", "smallest eigenvalue of K itself at this mesh, "
                           "the paper's normalisation of Fig. 5b"),
        "strain_energy": ((), "f8", "B/(2l)", "strain energy / SE_0 (Fig. 5c, Eq. (21))"),
        "iterations": ((), "i4", "1", "optimiser iterations (targets) or Newton iterations"),
        "status": ((), "i1", "1", "; ".join(f"{k}: {v}" for k, v in STATUS_NAMES.items())),
        "reason": ((), "S48", "1", "why the solve stopped: TARGET_REACHED, STATIONARY, STALLED, "
                   "CABLE_COLLAPSE, ... (tip control, control.py; for a sample not reached, "
                   "how its local solve ended), BEYOND_REACH (no solve), or PETSc's SNES "
                   "reason (mode tensions)"),
        "strategy": ((), "S48", "1", "what reached the target: 'local' (warm-started tip "
                     "control along the chunk), 'seed ...' or 'neighbour of sample K (global "
                     "search)'; 'global search: not reached'; '' otherwise"),
        "seconds_control": ((), "f8", "s", "wall time of tip control / forward solve"),
        "seconds_eigen": ((), "f8", "s", "wall time of the eigenvalue solve"),
        "cable_clear": (n, "?", "1", "reached state: the straight cable [x_i, r_i] does not "
                        "cross the arm (core/clearance.py); False where not reached"),
        "shared": ((), "?", "1", "with --share/--min-tension-N (file attributes share, "
                   "min_tension_N): the stored tensions are the sharing rule's (KKT conditions "
                   "met, every P_i >= the floor; two tendons: the state's own tensions, unique "
                   "on its branch, checked against the floor); False otherwise"),
    }


def limits_of(arm) -> dict:
    """The admissibility limits of Eqs. (19), (21), (22) in non-dimensional form."""
    return {"kappa_limit": arm.kappa_limit,
            "strain_energy_max": arm.limits.strain_energy_max_SE0,
            "max_tension": arm.max_tension}


class Results(ChunkResults):
    """All samples' fields of a workspace map in memory (rank 0), with per-chunk
    done flags; its file is :func:`~elastica_petsc.io.workspace.write_results`'s."""

    MARKER = "status"     # NOT_COMPUTED (0) until every other field is on disk

    def __init__(self, grid: Grid, n_tendons: int):
        super().__init__(grid, fields(n_tendons))

    def write(self, path: Path, attrs: dict, limits: dict, timing: dict):
        """One checkpoint in full (:func:`~elastica_petsc.io.workspace.write_results`)."""
        return write_results(path, self, attrs, limits, timing)

    def extra_rows(self, samples: np.ndarray, limits: dict) -> list:
        """In-place rows of masks and map cells
        (:func:`~elastica_petsc.io.workspace.new_map_rows`)."""
        return new_map_rows(self, samples, limits)

    @functools.cached_property
    def lattice(self):
        """(index, axes) of :func:`~elastica_petsc.io.workspace.lattice_index`."""
        return lattice_index(self.grid)

    def masks(self, limits: dict, samples=None) -> dict[str, np.ndarray]:
        """Admissibility masks W_0, W_Y, W_S, W_E, W_P (Eqs. (18)-(22)) of the samples
        (or of the samples of index array ``samples``), and W_C: every cable clear
        of the arm."""
        d = self.data if samples is None else {
            name: self.data[name][samples] for name in
            ("status", "kappa_max", "lambda_min", "strain_energy", "tensions", "cable_clear")}
        w0 = d["status"] == Status.REACHED
        with np.errstate(invalid="ignore"):
            wy = w0 & (d["kappa_max"] < limits["kappa_limit"])
            ws = w0 & (d["lambda_min"] > 0)
            we = w0 & (d["strain_energy"] < limits["strain_energy_max"])
            p_max = limits.get("max_tension")
            wp = w0 & (np.all(d["tensions"] < p_max, axis=1) if p_max is not None else True)
        wc = w0 & np.all(d["cable_clear"], axis=1)
        return {"W0": w0, "WY": wy, "WS": ws, "WE": we, "WP": wp, "WC": wc}


def _frozen(array: np.ndarray) -> np.ndarray:
    array = np.array(array)
    array.flags.writeable = False
    return array


@dataclass(frozen=True, repr=False)
class WorkspaceMap(Result):
    """A sampled workspace (Eq. (18), Fig. 4) and its restrictions (Eqs. (19)-(22), Fig. 5).

    W_0 (the workspace) is the set of tips of stable equilibria connected to
    the straight arm by quasi-static loading with all P_i >= 0; here: the
    targets reached by tip control with non-negative tensions (``masks["W0"]``).
    With a pretension floor (``min_tension_N`` > 0) ``masks["W0"]`` samples
    W_0(P_min) instead: reached with every P_i >= P_min (docs/model.md §9.3).
    ``share``: how the tensions of a reached sample were chosen ('none': as tip
    control found them; 'min-norm'/'min-energy': the sharing rule's, where
    ``samples["shared"]``).
    Arrays are per sample, in grid order, read-only.  Units: ``points`` are
    targets in mm (mode ``targets``) or tensions p = P l^2/B (mode
    ``tensions``); ``samples`` holds every field of :func:`fields` under its
    name (target/tip/cable_lengths in mm, tensions in P l^2/B, tensions_N in
    N, kappa_max as l*kappa, lambda_min in B/l^2, strain_energy in B/(2l)).
    Samples not computed (an interrupted run) have status ``NOT_COMPUTED``.
    """

    mode: str
    points: np.ndarray
    chunk_done: np.ndarray
    samples: dict
    masks: dict
    limits: dict
    grid: dict
    ranks: int
    file: Path | None = None
    stranded: bool = False
    sampler: str = ""
    share: str = "none"
    min_tension_N: float = 0.0

    @classmethod
    def from_results(cls, results: Results, limits: dict, ranks: int, file=None,
                     sampler: str = "", share: tuple[str, float] = ("none", 0.0)):
        samples = {name: _frozen(values) for name, values in results.data.items()}
        masks = {name: _frozen(mask) for name, mask in results.masks(limits).items()}
        return cls(results.grid.mode, _frozen(results.grid.points),
                   _frozen(results.chunk_done), samples, masks, dict(limits),
                   dict(results.grid.meta), ranks, None if file is None else Path(file),
                   results.stranded, sampler, share[0], float(share[1]))

    def to_vtk(self, directory) -> Path:
        """The map as a ParaView file ``directory/workspace.vtu``, as ``workspace
        --vtk`` writes it; from the map's HDF5 file (run it with ``out=``)."""
        from ...core.errors import InputError
        from ...io.vtk import write_workspace_vtk

        if self.file is None:
            raise InputError("to_vtk needs the map's HDF5 file: run the workspace with out=")
        return write_workspace_vtk(directory, self.file)

    @property
    def complete(self) -> bool:
        return bool(self.chunk_done.all())

    def to_xarray(self):
        """The samples and masks as an ``xarray.Dataset`` (xarray optional), with
        the dimensions, CF units and long names of the file's ``samples/``."""
        from ...io.dims import xarray_dataset
        from ...io.workspace import sample_dims

        variables = {}
        for name, (shape, _, units, text) in fields(self.samples["tensions"].shape[1]).items():
            if name in self.samples:
                values = self.samples[name]
                values = values.astype(str) if values.dtype.kind == "S" else values
                variables[name] = (("sample",) + sample_dims(name, shape), values, units, text)
        for name, mask in self.masks.items():
            variables[name] = (("sample",), mask, "1", f"sample in the admissible set {name}")
        return xarray_dataset(variables, coords={"sample": np.arange(self.samples_total)},
                              attrs={"mode": self.mode, "share": self.share})

    @property
    def samples_total(self) -> int:
        return len(self.points)

    @property
    def done(self) -> np.ndarray:
        """Per sample: computed and stored."""
        return self.samples["status"] != Status.NOT_COMPUTED

    @property
    def samples_done(self) -> int:
        return int(self.done.sum())

    @property
    def status(self) -> np.ndarray:
        """Per sample: REACHED; UNDECIDED (not reached after the global search:
        not proven outside W_0), BEYOND_REACH (|x_d| > l, proven) or
        OUTSIDE_BOUNDARY (outside the traced boundary of W_0, proven: docs/model.md
        §9.1) with the global search (``sampler`` "boundary-fill" or
        "global-search"); with a floor
        (``min_tension_N`` > 0) BELOW_FLOOR: reached with P >= 0 but no tensions
        >= the floor found (not a proof, docs/model.md §9.3), and UNIQUE_BELOW_FLOOR:
        two tendons, the target's only tensions are below the floor (proven);
        NEEDS_NEGATIVE (the local
        tip-control solve ended on a bound P_i = 0: a local verdict, not a proof
        that the target is outside W_0) or NOT_CONVERGED with the local sampler
        ("local"); NOT_COMPUTED.  `elastica-petsc boundary` gives the edge of
        W_0 by continuation."""
        return np.array([Status(int(k)).name for k in self.samples["status"]])

    @property
    def reason(self) -> np.ndarray:
        """Per sample: why its solve stopped (TARGET_REACHED, CABLE_COLLAPSE, ...; '' if not done)."""
        return np.array([r.decode() for r in self.samples["reason"]])

    @property
    def strategy(self) -> np.ndarray:
        """Per sample: what reached it ('local', 'seed ...', 'neighbour of sample K
        (global search)'), 'global search: not reached', or ''."""
        return np.array([r.decode() for r in self.samples["strategy"]])

    @property
    def target_mm(self) -> np.ndarray:
        return self.samples["target"]

    @property
    def tip_mm(self) -> np.ndarray:
        return self.samples["tip"]

    @property
    def tensions(self) -> np.ndarray:
        """Non-dimensional tensions p_i = P_i l^2/B."""
        return self.samples["tensions"]

    @property
    def tensions_N(self) -> np.ndarray:
        return self.samples["tensions_N"]

    @property
    def cable_lengths_mm(self) -> np.ndarray:
        return self.samples["cable_lengths"]

    def _status_name(self, k: int) -> str:
        """:data:`STATUS_NAMES` in words, REACHED with the floor when there is one."""
        if k == Status.REACHED and self.min_tension_N > 0:
            return f"reached with every P >= {self.min_tension_N:g} N (W_0(P_min))"
        return STATUS_NAMES[k]

    def summary(self) -> dict:
        """Counts in words (what the command line prints), JSON-ready."""
        status = self.samples["status"]
        w0 = self.masks["W0"].any()
        return {
            "file": None if self.file is None else str(self.file),
            "complete": self.complete,
            "samples_total": self.samples_total,
            "samples_done": self.samples_done,
            "sampler": self.sampler,
            "share": self.share,
            "min_tension_floor_N": self.min_tension_N,
            "status_counts": {self._status_name(k): int(np.sum(status == k))
                              for k in STATUS_NAMES
                              if k == Status.REACHED
                              or (k != Status.NOT_COMPUTED and np.any(status == k))},
            "masks": {name: int(m.sum()) for name, m in self.masks.items()},
            "lambda_min_raw_min": float(np.nanmin(self.samples["lambda_min_raw"])) if w0 else None,
            "kappa_max_max": float(np.nanmax(self.samples["kappa_max"])) if w0 else None,
        }
