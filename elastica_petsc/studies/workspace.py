"""Workspace maps (paper Sec. 4.3, Eqs. (18)-(22), Figs. 4-5), sampled over MPI.

The grid of samples is cut into *chunks* (short runs of neighbouring points
along a grid row) fixed by the grid alone.  Within a chunk each sample is
warm-started from the previous one; each chunk starts from the straight arm.
So every sample's result depends on the grid only — never on the number of
ranks or on the order in which chunks are handed out — and a run equals its
interrupted-and-resumed twin.

Distribution: chunks are handed out dynamically through an MPI one-sided
atomic counter (``Fetch_and_op`` on rank 0's window), so a rank that drew
slow chunks simply takes fewer; no rank is reserved as a master.  Every
sample's PETSc/TAO/SLEPc objects live on ``COMM_SELF``.

Output: ranks send finished chunks to rank 0 (non-blocking sends, so a
rank never waits for rank 0 to finish its own chunk), which holds the
results and writes the whole file aside and renames it into place (a
checkpoint) every few seconds and at the end.  A chunk is marked done only
when all its samples are stored, so the file on disk is always valid.

Stop protocol (SIGINT/SIGTERM to any rank, to mpiexec or to its process
group; :func:`run`): the stopped rank exhausts the shared chunk counter
(one-sided, no rank waits), every rank sees it at its next sample, or inside
a long one at its next load or continuation step (core/interrupt.py), and
leaves its chunk; rank 0 writes a checkpoint at once (Open MPI's mpiexec kills the
ranks about 2 s after forwarding a signal), receives until every rank has
said it finished, and writes the last one.  No collective is entered unless
every rank is known to reach it, so no rank is left in MPI_Waitall or in
PETSc's finalisation.  A rank still busy ``STOP_GRACE`` seconds after a stop
(one sample too slow) makes rank 0 return ``stranded``; the command line
then exits without MPI finalisation and mpiexec ends the rest.  A rank
killed outright loses at most the chunks finished since the previous
checkpoint (the MPI launcher ends the job: Open MPI's mpiexec does; with
srun use ``--kill-on-bad-exit=1``).  While a run owns its output file it
holds a lock beside it (:class:`~elastica_petsc.io.hdf5.OutputLock`).
``resume`` recomputes only chunks not done, and refuses a file made with
another grid, arm, element count, version or result-changing PETSc options.
Gathering to one writer instead of parallel HDF5 (mpio) was chosen because
the data are tiny (a few hundred bytes per sample) and an atomic rename is
the only way to keep the file valid when a process dies mid-write; the
measured I/O share is reported in the file (``timing`` attributes:
``seconds_wall`` and ``seconds_io`` up to the start of the last write, which
cannot time itself; ``ranks``).

Checkpoint interval: 2 s by default; the environment variable
``ELASTICA_PETSC_CHECKPOINT_SECONDS`` overrides it (0: after every chunk,
as the interruption tests use; larger on a cluster with big grids, where
each checkpoint rewrites the whole file).

Errors in the input (a bad grid, a file to resume made for another grid or
arm) are agreed on by all ranks before any work starts and raised on every
rank as :class:`CollectiveInputError`, so the command line can report one
line and exit with status 2 without ``MPI_Abort``.
"""
from __future__ import annotations

import json
import os
import signal
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..core import interrupt
from ..core.errors import InputError

TAG_RESULT, TAG_FINISHED = 11, 12
CHECKPOINT_ENV = "ELASTICA_PETSC_CHECKPOINT_SECONDS"
STOP_GRACE = 5.0          # s rank 0 waits, after a stop, for the other ranks' last samples

# status codes of a sample.  With the global search (the default, sampler
# "global-search"), a target is REACHED, UNDECIDED (not reached after the global
# search: no proof either way), BEYOND_REACH (|x_d| > l: proven) or OUTSIDE_BOUNDARY
# (outside the traced boundary of W_0, docs/model.md §9.1: proven).  NEEDS_NEGATIVE
# and NOT_CONVERGED are the local verdicts of sampler "local" (``global_search=False``
# and files written before the global search).  With a pretension floor P_min
# (``--min-tension-N``) REACHED means reached with every P_i >= P_min (W_0(P_min),
# docs/model.md §9.3), and BELOW_FLOOR: reached with P >= 0 (in W_0), but no tension
# set with every P_i >= P_min was found (not a proof that there is none);
# UNIQUE_BELOW_FLOOR (two tendons): the tensions found are below the floor and they
# are the target's only ones (a face of the traced boundary with one preimage): proven.
(NOT_DONE, REACHED, NEEDS_NEGATIVE, NOT_CONVERGED, UNDECIDED, BEYOND_REACH,
 OUTSIDE_BOUNDARY, BELOW_FLOOR, UNIQUE_BELOW_FLOOR) = 0, 1, 2, 3, 4, 5, 6, 7, 8
STATUS_NAMES = {NOT_DONE: "not computed", REACHED: "reached with P >= 0",
                NEEDS_NEGATIVE: "tip control ended on P_i = 0 (would need a negative tension locally; not a proof of outside W_0)",
                NOT_CONVERGED: "not converged",
                UNDECIDED: "not reached after the global search (undecided: not proven outside W_0)",
                BEYOND_REACH: "beyond reach |x| > l (proven unreachable)",
                OUTSIDE_BOUNDARY: "outside the traced W_0 boundary (proven unreachable, "
                                  "docs/model.md §9.1)",
                BELOW_FLOOR: "reached with P >= 0, but no tensions >= the floor found "
                             "(undecided for W_0(P_min): not a proof, docs/model.md §9.3)",
                UNIQUE_BELOW_FLOOR: "reached with P >= 0 by the only tensions that reach it, "
                                    "below the floor (proven outside W_0(P_min), two tendons, "
                                    "docs/model.md §9.3)"}
# the sampler attribute of a file (part of what a resume must match); files
# written before it existed were made by the local sampler (targets) or by
# forward solves (tensions)
SAMPLERS = {"targets": ("global-search", "local"), "tensions": ("forward",),
            "design-sweep": ("design-sweep",)}


def reason_counts(reasons: np.ndarray) -> str:
    """'REASON count, ...' of the byte-string ``reason`` values of some samples,
    most frequent first."""
    names, counts = np.unique(reasons, return_counts=True)
    order = np.argsort(-counts, kind="stable")
    return ", ".join(f"{names[k].decode()} {counts[k]}" for k in order)


class CollectiveInputError(InputError):
    """An input error raised on every rank alike (see :func:`agree`)."""


def agree(comm, error: str | None) -> None:
    """Collective: raise :class:`CollectiveInputError` on every rank if any rank
    found an input error (the first one by rank), so no rank is left waiting."""
    errors = comm.allgather(error)
    first = next((e for e in errors if e), None)
    if first is not None:
        raise CollectiveInputError(first)


def checkpoint_interval() -> float:
    """Seconds between checkpoints: ``$ELASTICA_PETSC_CHECKPOINT_SECONDS`` or 2."""
    value = os.environ.get(CHECKPOINT_ENV, "2")
    try:
        seconds = float(value)
    except ValueError:
        seconds = float("nan")
    if not seconds >= 0:
        raise InputError(f"{CHECKPOINT_ENV}={value!r}: expected seconds >= 0")
    return seconds


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


@dataclass(frozen=True)
class Grid:
    """Sample points and their fixed chunks.

    ``points`` are targets in mm (mode ``targets``) or tensions p (mode
    ``tensions``); ``chunks`` lists index arrays in warm-start order.
    """

    mode: str
    points: np.ndarray
    chunks: tuple[np.ndarray, ...]
    meta: dict = field(default_factory=dict)

    @property
    def size(self) -> int:
        return len(self.points)


def _rows_to_chunks(rows: list[np.ndarray], chunk: int) -> tuple[np.ndarray, ...]:
    out = []
    for row in rows:
        for start in range(0, len(row), chunk):
            out.append(row[start:start + chunk])
    return tuple(out)


MAX_SAMPLES = 2_000_000        # ~0.4 GB of results on rank 0; the paper's map has 4201


def _check_size(count: float, what: str) -> None:
    if not count <= MAX_SAMPLES:
        raise InputError(f"{what} would give {count:.3g} samples; at most {MAX_SAMPLES:,} "
                         "(use a larger spacing)")


def target_grid(length_mm: float, spacing_mm: float, box=None, chunk: int = 24) -> Grid:
    """Targets on a square lattice of ``spacing_mm``: by default the half-plane
    y >= 0 within the arm's reach |x| <= l (paper Fig. 4), else ``box`` =
    (xmin, xmax, ymin, ymax) in mm.  Rows of constant y, cut into chunks."""
    if not (spacing_mm > 0 and np.isfinite(spacing_mm)):
        raise InputError(f"--spacing must be a positive number of mm, got {spacing_mm}")
    if box is not None and not np.all(np.isfinite(np.asarray(box, float))):
        raise InputError(f"--box {tuple(box)}: expected four finite numbers of mm")
    if box is None:
        _check_size(2 * (length_mm / spacing_mm + 1) ** 2, f"--spacing {spacing_mm:g}")
    else:
        _check_size((abs(box[1] - box[0]) / spacing_mm + 1) * (abs(box[3] - box[2]) / spacing_mm
                                                                + 1), f"--spacing {spacing_mm:g}")
    if box is None:
        reach = length_mm
        xs = np.arange(-np.floor(reach / spacing_mm), np.floor(reach / spacing_mm) + 1) * spacing_mm
        ys = np.arange(0, np.floor(reach / spacing_mm) + 1) * spacing_mm
        inside = lambda x, y: x * x + y * y <= reach * reach * (1 + 1e-12)
        region = f"half-disc y >= 0, |x| <= l = {length_mm:g} mm"
    else:
        xmin, xmax, ymin, ymax = map(float, box)
        if not (xmax > xmin and ymax > ymin):
            raise InputError(f"--box {box}: need xmin < xmax and ymin < ymax")
        xs = xmin + np.arange(0, np.floor((xmax - xmin) / spacing_mm + 1e-9) + 1) * spacing_mm
        ys = ymin + np.arange(0, np.floor((ymax - ymin) / spacing_mm + 1e-9) + 1) * spacing_mm
        inside = lambda x, y: np.ones_like(x, dtype=bool)
        region = f"box x in [{xmin:g}, {xmax:g}], y in [{ymin:g}, {ymax:g}] mm"
    points, rows = [], []
    for j, y in enumerate(ys):
        row_x = xs[inside(xs, np.full_like(xs, y))]
        if j % 2:                                     # serpentine: neighbours stay neighbours
            row_x = row_x[::-1]
        rows.append(np.arange(len(points), len(points) + len(row_x)))
        points.extend((x, y) for x in row_x)
    if not points:
        raise InputError("the sampling region holds no grid point; use a smaller --spacing")
    meta = {"spacing": spacing_mm, "region": region, "chunk": chunk}
    return Grid("targets", np.array(points, float), _rows_to_chunks(rows, chunk), meta)


def tension_grid(n_tendons: int, spacing: float, p_max: float, chunk: int = 24) -> Grid:
    """Tensions on a lattice 0 <= p_i <= p_max (non-dimensional), serpentine
    along the last tendon's axis."""
    if not (spacing > 0 and p_max > 0 and np.isfinite(spacing) and np.isfinite(p_max)):
        raise InputError("--tension-spacing and --tension-max must be positive numbers")
    _check_size((p_max / spacing + 1) ** n_tendons, f"--tension-spacing {spacing:g}")
    axis = np.arange(0, np.floor(p_max / spacing + 1e-9) + 1) * spacing
    mesh = np.stack(np.meshgrid(*([axis] * n_tendons), indexing="ij"), -1).reshape(-1, n_tendons)
    rows, points = [], []
    for j, start in enumerate(range(0, len(mesh), len(axis))):
        row = mesh[start:start + len(axis)]
        if j % 2:
            row = row[::-1]
        rows.append(np.arange(len(points), len(points) + len(row)))
        points.extend(row)
    meta = {"spacing": spacing, "region": f"0 <= p_i <= {p_max:g}", "chunk": chunk}
    return Grid("tensions", np.array(points, float), _rows_to_chunks(rows, chunk), meta)


def empty_fields(schema: dict, count: int) -> dict[str, np.ndarray]:
    """Arrays for ``count`` samples of every field of ``schema`` (:func:`fields`):
    NaN for floats, 0 for integers, b"" for strings (not computed yet)."""
    out = {}
    for name, (shape, dtype, _, _) in schema.items():
        fill = b"" if dtype.startswith("S") else (0 if dtype[0] in "i?" else np.nan)
        out[name] = np.full((count,) + shape, fill, dtype=dtype)
    return out


class Results:
    """All samples' fields in memory (rank 0), with per-chunk done flags."""

    def __init__(self, grid: Grid, n_tendons: int, schema: dict | None = None):
        self.grid = grid
        self.schema = fields(n_tendons) if schema is None else schema
        self.data = empty_fields(self.schema, grid.size)
        self.chunk_done = np.zeros(len(grid.chunks), bool)
        self.stranded = False            # other ranks still busy after a stop (see run)
        self.write_error = None          # why a checkpoint could not be written (see run)

    def store(self, chunk: int, values: dict) -> None:
        index = self.grid.chunks[chunk]
        for name, array in values.items():
            self.data[name][index] = array
        self.chunk_done[chunk] = True

    def write(self, path: Path, attrs: dict, limits: dict, timing: dict) -> None:
        """One checkpoint (:func:`write_results`); other studies' results override it."""
        write_results(path, self, attrs, limits, timing)

    @property
    def samples_done(self) -> int:
        return int(sum(len(self.grid.chunks[c]) for c in np.flatnonzero(self.chunk_done)))

    def masks(self, limits: dict) -> dict[str, np.ndarray]:
        """Admissibility masks W_0, W_Y, W_S, W_E, W_P (Eqs. (18)-(22)) of the samples,
        and W_C: every cable clear of the arm."""
        d = self.data
        w0 = d["status"] == REACHED
        with np.errstate(invalid="ignore"):
            wy = w0 & (d["kappa_max"] < limits["kappa_limit"])
            ws = w0 & (d["lambda_min"] > 0)
            we = w0 & (d["strain_energy"] < limits["strain_energy_max"])
            p_max = limits.get("max_tension")
            wp = w0 & (np.all(d["tensions"] < p_max, axis=1) if p_max is not None else True)
        wc = w0 & np.all(d["cable_clear"], axis=1)
        return {"W0": w0, "WY": wy, "WS": ws, "WE": we, "WP": wp, "WC": wc}


# what must be equal for a resume: everything that changes a sample's result
GRID_ATTRS = ("mode", "config_json", "elements", "grid_json", "petsc_options",
              "elastica_petsc_version", "sampler", "share", "min_tension_N")
OPTIONAL_FIELDS = ("strategy", "shared")   # absent from files written before the global
#                                            search / before tension sharing
# attributes of files written before they existed (and of other studies' files)
ATTR_DEFAULTS = {"share": "none", "min_tension_N": 0.0}


def share_of(attrs) -> tuple[str, float]:
    """(share, min_tension_N) of a file's root ``attrs``: the tension sharing of a
    target map ('none', 0.0 for files written before sharing existed)."""
    share = attrs.get("share", ATTR_DEFAULTS["share"])
    share = share.decode() if isinstance(share, bytes) else str(share)
    return share, float(attrs.get("min_tension_N", ATTR_DEFAULTS["min_tension_N"]))


def sampler_of(attrs, mode: str) -> str:
    """The ``sampler`` attribute of a file's root ``attrs`` (:data:`SAMPLERS`);
    files written before it existed: the local sampler (the only one then)."""
    stored = attrs.get("sampler")
    if isinstance(stored, bytes):
        stored = stored.decode()
    return str(stored) if stored else SAMPLERS[mode][-1]


def _read_samples(fh, results: "Results") -> None:
    """Every per-sample field of ``results`` from an open file; the optional ones
    an older file lacks keep their empty values."""
    for name in results.schema:
        if name in OPTIONAL_FIELDS and name not in fh["samples"]:
            continue
        results.data[name][...] = fh["samples"][name][()]


def lattice_index(grid: Grid) -> tuple[np.ndarray, list[np.ndarray]]:
    """Integer lattice coordinates (S, d) of the samples along each coordinate
    of ``grid.points`` (targets: x then y; tensions: p_1, p_2, ...) and the
    lattice axes, so a 2-D map is ``A[index[:, 1], index[:, 0]] = field``."""
    origin = grid.points.min(axis=0)
    spacing = float(grid.meta["spacing"])
    index = np.rint((grid.points - origin) / spacing).astype(np.int64)
    axes = [origin[d] + spacing * np.arange(index[:, d].max() + 1) for d in range(index.shape[1])]
    return index, axes


def write_results(path: Path, results: Results, attrs: dict, limits: dict, timing: dict) -> None:
    """Write the whole file aside and rename it into place (always valid)."""
    from ..io.hdf5 import atomic_h5, put, write_attrs

    with atomic_h5(path, overwrite=True) as fh:
        write_attrs(fh, attrs)
        fh.attrs["complete"] = bool(results.chunk_done.all())
        fh.attrs["samples_done"] = results.samples_done
        fh.attrs["samples_total"] = results.grid.size
        grid = fh.create_group("grid")
        put(grid, "points", results.grid.points, "mm" if results.grid.mode == "targets"
            else "P l^2/B", "sample points: targets (mm) or tensions (P l^2/B)")
        bounds = np.cumsum([0] + [len(c) for c in results.grid.chunks])
        put(grid, "chunk_order", np.concatenate(results.grid.chunks), "1",
            "sample indices in chunk order; chunk c is chunk_order[chunk_bounds[c]:chunk_bounds[c+1]]")
        put(grid, "chunk_bounds", bounds, "1", "offsets of the chunks in chunk_order")
        put(grid, "chunk_done", results.chunk_done, "1", "chunk finished and stored")
        index, axes = lattice_index(results.grid)
        put(grid, "index", index, "1", "lattice indices of each sample along each coordinate of "
            "points: a 2-D map is A[index[:, 1], index[:, 0]] = samples/FIELD")
        for d, axis in enumerate(axes):
            put(grid, f"axis_{d}", axis, "mm" if results.grid.mode == "targets" else "P l^2/B",
                f"lattice coordinates along coordinate {d} of points (index[:, {d}])")
        samples = fh.create_group("samples")
        done = np.zeros(results.grid.size, bool)
        for c in np.flatnonzero(results.chunk_done):
            done[results.grid.chunks[c]] = True
        put(samples, "done", done, "1", "sample finished and stored")
        for name, (_, _, units, description) in results.schema.items():
            put(samples, name, results.data[name], units, description)
        masks = fh.create_group("masks")
        descriptions = {"W0": "reached with non-negative tensions (Eq. (18))",
                        "WY": "W0 and l*kappa_max below the strain limit (Eq. (19))",
                        "WS": "W0 and stable: lambda_min > 0 (Eq. (20))",
                        "WE": "W0 and strain energy below SE_max (Eq. (21))",
                        "WP": "W0 and all tensions below P_crit (Eq. (22))",
                        "WC": "W0 and every cable clear of the arm (no cable segment crosses "
                              "the arm, core/clearance.py)"}
        for name, mask in results.masks(limits).items():
            put(masks, name, mask, "1", descriptions[name])
        write_attrs(masks, {k: v for k, v in limits.items() if v is not None})
        write_attrs(fh.create_group("timing"), timing)


def read_results(path: Path, grid: Grid, n_tendons: int, attrs: dict,
                 results: Results | None = None) -> Results:
    """Load a partial file for ``resume`` into ``results`` (default: a workspace
    map's); refuse one made for another grid or arm."""
    import h5py

    results = Results(grid, n_tendons) if results is None else results
    try:
        with h5py.File(path, "r") as fh:
            for key in GRID_ATTRS:
                stored = fh.attrs.get(key, ATTR_DEFAULTS.get(key))
                if isinstance(stored, bytes):
                    stored = stored.decode()
                if key == "sampler":
                    stored = sampler_of(fh.attrs, attrs["mode"])
                now = attrs.get(key, ATTR_DEFAULTS.get(key))
                if stored != now:
                    raise InputError(f"{path}: cannot resume: it was made with "
                                     f"{_difference(key, stored, now)}")
            results.chunk_done[:] = fh["grid/chunk_done"][()]
            _read_samples(fh, results)
    except InputError:
        raise                                   # a mismatch found above, already in words
    except OSError as err:
        raise InputError(f"{path}: cannot resume from this file: {err}") from None
    except (KeyError, ValueError, TypeError) as err:
        raise InputError(f"{path}: cannot resume: not a complete workspace file "
                         f"(missing or malformed {err})") from None
    return results


def _difference(key: str, stored, now) -> str:
    """What differs between a file's grid attribute and this run's, in words."""
    if key == "grid_json":
        try:
            a, b = json.loads(stored), json.loads(now)
            diff = [f"{k} {a.get(k)!r} (now {b.get(k)!r})" for k in sorted(set(a) | set(b))
                    if a.get(k) != b.get(k)]
            return "another grid: " + "; ".join(diff)
        except (TypeError, ValueError):
            pass
    if key == "config_json":
        return "another arm configuration (--config/--elements)"
    if key == "sampler":
        return (f"the {stored!r} sampler (now {now!r}): its unreached samples are "
                + ("local verdicts" if stored == "local" else "searched globally")
                + "; start a new file, or resume it with the same sampler"
                + (" (--local-only)" if stored == "local" else ""))
    if key in ATTR_DEFAULTS:
        option, what = (("--share", "the sharing rule") if key == "share" else
                        ("--min-tension-N", "the tension floor [N]"))
        return (f"{what} {option} {stored} (now {now}): its samples hold other tensions; "
                f"start a new file, or resume it with the same {option}")
    if key == "petsc_options":
        return f"other PETSc options: {stored or '(none)'} (now {now or '(none)'})"
    return f"another {key}: {stored!r} (now {now!r})"


class _Stop:
    """The stop request of a run: SIGINT/SIGTERM on this rank, or any rank's
    (seen through the shared chunk counter, which a stopping rank exhausts).

    Calling it returns True once a stop was requested; work stops at the next
    sample boundary.  The signal handler only sets a flag (no MPI call in a
    handler); the first call that sees it exhausts the counter, so the other
    ranks take no new chunk and leave their current one at its next sample.
    """

    POLL = 0.01                       # s between looks at the shared counter

    def __init__(self):
        self.counter = None           # attached by run() once the counter exists
        self.signalled = False
        self._old = {}
        self._next_poll = 0.0

    def __enter__(self):
        for sig in (signal.SIGINT, signal.SIGTERM):
            self._old[sig] = signal.signal(sig, self._handle)
        return self

    def _handle(self, signum, frame):
        self.signalled = True

    def __exit__(self, *exc):
        for sig, handler in self._old.items():
            signal.signal(sig, handler)

    def __call__(self) -> bool:
        if self.counter is None:
            return self.signalled
        if self.signalled:
            self.counter.exhaust()
            return True
        if self.counter.exhausted:
            return True
        now = time.monotonic()
        if now >= self._next_poll:
            self._next_poll = now + self.POLL
            self.counter.peek()
        return self.counter.exhausted


class _NoProgress:
    def update(self, done: int) -> None:
        pass

    close = update


class ChunkCounter:
    """Shared counter for dynamic scheduling: an atomic fetch-and-add on rank 0.

    ``exhaust()`` (any rank, on a stop) pushes it past any chunk index, so no
    rank takes a new chunk; ``peek()`` lets a busy rank see that.  Every
    operation is one-sided (passive target): no rank waits for another."""

    EXHAUSTED = 2 ** 60

    def __init__(self, comm):
        from mpi4py import MPI
        self.MPI = MPI
        self.win = MPI.Win.Allocate(8 if comm.rank == 0 else 0, 8, comm=comm)
        if comm.rank == 0:
            self.win.Lock(0)
            self.win.Put(np.zeros(1, "i8"), 0)
            self.win.Unlock(0)
        comm.Barrier()
        self._one, self._got = np.ones(1, "i8"), np.zeros(1, "i8")
        self._zero = np.zeros(1, "i8")
        self.exhausted = False

    def _add(self, value, op=None) -> int:
        self.win.Lock(0, self.MPI.LOCK_SHARED)
        self.win.Fetch_and_op(value, self._got, 0, 0, op or self.MPI.SUM)
        self.win.Unlock(0)
        k = int(self._got[0])
        if k >= self.EXHAUSTED:
            self.exhausted = True
        return k

    def next(self) -> int:
        return self._add(self._one)

    def peek(self) -> int:
        return self._add(self._zero, self.MPI.NO_OP)

    def exhaust(self) -> None:
        if not self.exhausted:
            self._add(np.full(1, self.EXHAUSTED, "i8"))
            self.exhausted = True

    def free(self) -> None:
        self.win.Free()


class _Collector:
    """Rank 0's side: stores chunks (its own and those other ranks send), writes
    checkpoints, and knows how many ranks have finished."""

    def __init__(self, comm, counter, results: Results, out, attrs, limits, checkpoint_seconds,
                 bar):
        self.comm, self.counter, self.results, self.out = comm, counter, results, out
        self.attrs, self.limits, self.bar = attrs, limits, bar
        self.checkpoint_seconds = checkpoint_seconds
        self.finished = 1                                  # rank 0 itself, once done
        self.timing = {"ranks": comm.size, "seconds_io": 0.0}
        self.t_start = self.last_write = time.perf_counter()

    def checkpoint(self) -> None:
        """Write the file; a failed write (full disk) stops the run like a signal:
        the file keeps its previous checkpoint, the error is reported at the end."""
        if self.out is None or self.results.write_error is not None:
            return
        t0 = time.perf_counter()
        self.timing["seconds_wall"] = t0 - self.t_start
        try:
            self.results.write(self.out, self.attrs, self.limits, self.timing)
        except InputError as err:
            self.results.write_error = str(err)
            self.counter.exhaust()
        self.last_write = time.perf_counter()
        self.timing["seconds_io"] += self.last_write - t0

    def store(self, chunk: int, values: dict) -> None:
        self.results.store(chunk, values)
        self.drain()
        if time.perf_counter() - self.last_write > self.checkpoint_seconds:
            self.checkpoint()

    def drain(self) -> None:
        """Store every chunk other ranks have sent so far (no waiting)."""
        from mpi4py import MPI

        status = MPI.Status()
        while self.comm.iprobe(source=MPI.ANY_SOURCE, tag=MPI.ANY_TAG, status=status):
            message = self.comm.recv(source=status.Get_source(), tag=status.Get_tag())
            if status.Get_tag() == TAG_FINISHED:
                self.finished += 1
            else:
                self.results.store(*message)
        self.bar.update(self.results.samples_done)

    def wait_for_ranks(self, stop) -> bool:
        """Receive until every rank has finished; after a stop at most ``STOP_GRACE``
        seconds (a stopped rank ends within one sample).  True if all finished."""
        deadline = None
        while True:
            self.drain()
            if self.finished >= self.comm.size:
                return True
            if stop():
                deadline = deadline or time.monotonic() + STOP_GRACE
                if time.monotonic() > deadline:
                    return False
            time.sleep(0.002)


def _work(grid: Grid, sampler, todo: np.ndarray, counter: ChunkCounter, stop, deliver) -> None:
    """Take chunks from the shared counter until none is left or a stop; hand each
    finished chunk to ``deliver(chunk, values)``."""
    while not stop():
        k = counter.next()
        if k >= len(todo):
            return
        chunk = int(todo[k])
        try:
            with interrupt.watching(stop):     # a stop inside a long sample, too
                values = sampler.solve_chunk(grid.points[grid.chunks[chunk]], stop)
        except interrupt.Stopped:
            values = None
        if values is None:
            return
        deliver(chunk, values)


def _continue_provenance(out: Path, attrs: dict) -> None:
    """A resumed file keeps its first command line and creation time and lists
    the command lines of every resume (``resumed_command_lines``, JSON)."""
    import h5py

    with h5py.File(out, "r") as fh:
        first = {key: fh.attrs[key] for key in ("command_line", "created_utc") if key in fh.attrs}
        resumed = json.loads(fh.attrs.get("resumed_command_lines", "[]"))
    resumed.append(attrs.get("command_line", ""))
    attrs.update(first, resumed_command_lines=json.dumps(resumed))


def _load(grid: Grid, out, attrs: dict, resume: bool, comm, new_results=None) -> Results | None:
    """Rank 0 reads the file to resume (or starts afresh); every rank learns which
    chunks are done.  A file that cannot be resumed raises on every rank.
    ``new_results()``: empty results of another study (default a workspace map's)."""
    results = chunk_done = error = None
    if comm.rank == 0:
        try:
            fresh = (new_results or (lambda: Results(grid, attrs["n_tendons"])))()
            results = (read_results(out, grid, attrs["n_tendons"], attrs, fresh)
                       if resume and out is not None and out.exists() else fresh)
            chunk_done = results.chunk_done
            if out is not None and resume and out.exists():
                _continue_provenance(out, attrs)
        except InputError as err:
            error = str(err)
    error, chunk_done = comm.bcast((error, chunk_done), root=0)
    if error is not None:
        raise CollectiveInputError(error)
    return results, np.flatnonzero(~chunk_done)


def run(grid: Grid, sampler, out: Path | None, attrs: dict, limits: dict, *, comm, resume: bool,
        checkpoint_seconds: float | None = None, progress=None,
        progress_label: str = "workspace", stop: "_Stop | None" = None,
        new_results=None) -> Results | None:
    """Sample the whole grid over the ranks of ``comm`` (stop protocol below).

    ``sampler.solve_chunk(points, stop) -> dict of per-sample arrays`` (or
    None when ``stop()`` became true mid-chunk) is called on every rank.
    Returns the results on rank 0 (None elsewhere); ``results.chunk_done.all()``
    is False after an interruption, and ``results.stranded`` is True when other
    ranks did not finish within ``STOP_GRACE`` of a stop (the caller must then
    end the process without MPI finalisation, e.g. ``os._exit``).

    Stop protocol: a stopped rank exhausts the shared counter (one-sided), so
    every rank leaves its chunk at the next sample; rank 0 writes a checkpoint
    at once (a launcher kills the ranks ~2 s after forwarding a signal), then
    receives until every rank has finished, then writes the last one.  No
    collective is entered unless every rank is known to reach it.  ``stop``: a
    :class:`_Stop` already catching signals (:func:`run_map` installs it before
    its set-up, so a signal there stops the run at its first sample).
    ``new_results``: a callable returning empty :class:`Results` of another
    study (its own schema and file layout: ``design --sweep``); default a map's.
    """
    if stop is None:
        with _Stop() as stop:
            return run(grid, sampler, out, attrs, limits, comm=comm, resume=resume,
                       checkpoint_seconds=checkpoint_seconds, progress=progress,
                       progress_label=progress_label, stop=stop, new_results=new_results)
    from ..core.progress import Progress

    if checkpoint_seconds is None:
        checkpoint_seconds = checkpoint_interval()
    results, todo = _load(grid, out, attrs, resume, comm, new_results)
    counter = stop.counter = ChunkCounter(comm)
    if comm.rank == 0:
        bar = (Progress(grid.size, progress_label, already=results.samples_done)
               if progress is None else progress if progress else _NoProgress())
        rank0 = _Collector(comm, counter, results, out, attrs, limits, checkpoint_seconds,
                           bar)
        _work(grid, sampler, todo, counter, stop, rank0.store)
        if stop():
            rank0.drain()
            rank0.checkpoint()                         # before a launcher can kill us
        all_done = rank0.wait_for_ranks(stop)
        rank0.checkpoint()
        bar.close(results.samples_done)
        results.stranded = not all_done
        if not all_done:
            return results                             # no collective: a peer is busy
    else:
        sends = []                                     # results on their way to rank 0
        # non-blocking: a chunk's results exceed the eager limit of shared-memory MPI,
        # and a blocking send would wait until rank 0 ends its own chunk (measured:
        # 23% of a worker's time); rank 0 receives until this rank says FINISHED
        _work(grid, sampler, todo, counter, stop,
              lambda chunk, values: sends.append(
                  comm.isend((chunk, values), dest=0, tag=TAG_RESULT)))
        from mpi4py import MPI
        MPI.Request.waitall(sends)
        comm.send(None, dest=0, tag=TAG_FINISHED)
    counter.free()                      # collective: every rank finished (rank 0 saw it)
    return results


# --- the library entry point ------------------------------------------------------------------
STATUS_KEYS = {NOT_DONE: "NOT_COMPUTED", REACHED: "REACHED", NEEDS_NEGATIVE: "NEEDS_NEGATIVE",
               NOT_CONVERGED: "NOT_CONVERGED", UNDECIDED: "UNDECIDED",
               BEYOND_REACH: "BEYOND_REACH", OUTSIDE_BOUNDARY: "OUTSIDE_BOUNDARY",
               BELOW_FLOOR: "BELOW_FLOOR", UNIQUE_BELOW_FLOOR: "UNIQUE_BELOW_FLOOR"}


def _frozen(array: np.ndarray) -> np.ndarray:
    array = np.array(array)
    array.flags.writeable = False
    return array


@dataclass(frozen=True)
class WorkspaceMap:
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
    def from_results(cls, results: "Results", limits: dict, ranks: int, file=None,
                     sampler: str = "", share: tuple[str, float] = ("none", 0.0)):
        samples = {name: _frozen(values) for name, values in results.data.items()}
        masks = {name: _frozen(mask) for name, mask in results.masks(limits).items()}
        return cls(results.grid.mode, _frozen(results.grid.points),
                   _frozen(results.chunk_done), samples, masks, dict(limits),
                   dict(results.grid.meta), ranks, None if file is None else Path(file),
                   results.stranded, sampler, share[0], float(share[1]))

    @property
    def complete(self) -> bool:
        return bool(self.chunk_done.all())

    @property
    def samples_total(self) -> int:
        return len(self.points)

    @property
    def done(self) -> np.ndarray:
        """Per sample: computed and stored."""
        return self.samples["status"] != NOT_DONE

    @property
    def samples_done(self) -> int:
        return int(self.done.sum())

    @property
    def status(self) -> np.ndarray:
        """Per sample: REACHED; UNDECIDED (not reached after the global search:
        not proven outside W_0), BEYOND_REACH (|x_d| > l, proven) or
        OUTSIDE_BOUNDARY (outside the traced boundary of W_0, proven: docs/model.md
        §9.1) with the global search (``sampler`` "global-search"); with a floor
        (``min_tension_N`` > 0) BELOW_FLOOR: reached with P >= 0 but no tensions
        >= the floor found (not a proof, docs/model.md §9.3), and UNIQUE_BELOW_FLOOR:
        two tendons, the target's only tensions are below the floor (proven);
        NEEDS_NEGATIVE (the local
        tip-control solve ended on a bound P_i = 0: a local verdict, not a proof
        that the target is outside W_0) or NOT_CONVERGED with the local sampler
        ("local"); NOT_COMPUTED.  `elastica-petsc boundary` gives the edge of
        W_0 by continuation."""
        return np.array([STATUS_KEYS[int(k)] for k in self.samples["status"]])

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
        if k == REACHED and self.min_tension_N > 0:
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
                              if k == REACHED or (k != NOT_DONE and np.any(status == k))},
            "masks": {name: int(m.sum()) for name, m in self.masks.items()},
            "lambda_min_raw_min": float(np.nanmin(self.samples["lambda_min_raw"])) if w0 else None,
            "kappa_max_max": float(np.nanmax(self.samples["kappa_max"])) if w0 else None,
        }


def read_map(path) -> WorkspaceMap:
    """A workspace file written by :func:`run_map` (or ``workspace --out``), complete
    or partial, back into a :class:`WorkspaceMap`."""
    import h5py

    try:
        with h5py.File(path, "r") as fh:
            order, bounds = fh["grid/chunk_order"][()], fh["grid/chunk_bounds"][()]
            chunks = tuple(order[bounds[c]:bounds[c + 1]] for c in range(len(bounds) - 1))
            mode = fh.attrs["mode"]
            mode = mode.decode() if isinstance(mode, bytes) else str(mode)
            grid = Grid(mode, fh["grid/points"][()], chunks,
                        json.loads(fh.attrs.get("grid_json", "{}")))
            results = Results(grid, int(fh.attrs["n_tendons"]))
            results.chunk_done[:] = fh["grid/chunk_done"][()]
            _read_samples(fh, results)
            sampler = sampler_of(fh.attrs, mode)
            share = share_of(fh.attrs)
            limits = {key: fh["masks"].attrs.get(key) for key in
                      ("kappa_limit", "strain_energy_max", "max_tension")}
            ranks = int(fh["timing"].attrs.get("ranks", 1))
    except OSError as err:
        raise InputError(f"{path}: cannot read it as HDF5: {err}") from None
    except (KeyError, ValueError) as err:
        raise InputError(f"{path}: not a workspace file (missing or malformed {err})") from None
    return WorkspaceMap.from_results(results, limits, ranks, path, sampler, share)


def limits_of(arm) -> dict:
    """The admissibility limits of Eqs. (19), (21), (22) in non-dimensional form."""
    return {"kappa_limit": arm.kappa_limit,
            "strain_energy_max": arm.limits.strain_energy_max_SE0,
            "max_tension": arm.max_tension}


def make_grid(arm, disc, mode: str, spacing_mm: float, box_mm, tension_spacing: float,
              tension_max: float, chunk: int) -> Grid:
    """The sample grid of :func:`run_map`; :class:`InputError` for a bad request."""
    if mode not in ("targets", "tensions"):
        raise InputError(f"mode {mode!r}: expected 'targets' or 'tensions'")
    if not isinstance(chunk, (int, np.integer)) or chunk < 1:
        raise InputError(f"--chunk must be at least 1, got {chunk}")
    if mode == "targets":
        if disc.n_tendons < 2:
            raise InputError("mode targets needs at least 2 tendons (a 2-D workspace); "
                             "use --mode tensions")
        return target_grid(arm.length_mm, spacing_mm, None if box_mm is None else tuple(box_mm),
                           chunk)
    return tension_grid(disc.n_tendons, tension_spacing, tension_max, chunk)


def run_map(arm, disc, *, mode: str = "targets", spacing_mm: float = 20.0, box_mm=None,
            tension_spacing: float = 2.0, tension_max: float = 40.0, chunk: int = 24,
            comm=None, out=None, resume: bool = False, overwrite: bool = False,
            progress=None, checkpoint_seconds: float | None = None,
            provenance: dict | None = None, global_search: bool = True,
            share: str | None = None, min_tension_N: float = 0.0) -> WorkspaceMap:
    """Sample the workspace W_0 of ``arm`` (Eq. (18), Fig. 4) and its restrictions
    W_Y, W_S, W_E, W_P (Eqs. (19)-(22), Fig. 5) on ``disc``.

    Mode ``targets``: tip control (Eqs. (10)-(12)) to every target of a square
    lattice of ``spacing_mm`` mm over the half-disc y >= 0 within reach l, or
    over ``box_mm`` = (xmin, xmax, ymin, ymax) in mm.  Mode ``tensions``:
    forward solves (Eq. (9)) on the lattice 0 <= p_i <= ``tension_max`` of
    step ``tension_spacing`` (non-dimensional p = P l^2/B).  W_0 means: tips
    of stable equilibria connected to the straight arm by quasi-static loading
    with all P_i >= 0.

    ``global_search`` (mode targets): a target local tip control does not
    reach goes through the global search (seeds over every loading order,
    reached chunk neighbours; :class:`~elastica_petsc.studies.sampling.TargetSampler`)
    and is classed REACHED, UNDECIDED (no proof either way) or BEYOND_REACH
    (|x_d| > l, proven); False keeps the local classes NEEDS_NEGATIVE (ended
    on P_i = 0, a local verdict) and NOT_CONVERGED, at the old cost.

    ``share`` ('min-norm', 'min-energy', 'none'; None: 'min-norm' with a floor,
    else 'none') and ``min_tension_N`` (the floor P_min in N; mode targets):
    the stored tensions of a reached target are the sharing rule's
    (:class:`~elastica_petsc.solvers.share.TensionSharer`; with two tendons
    they are unique on the branch found and only checked against the floor),
    so the rule changes which tensions are stored, not which targets are
    reached; with a floor the map samples W_0(P_min) = tips of stable
    equilibria with every P_i >= P_min connected to the straight arm by
    quasi-static loading with all P_i >= 0 (docs/model.md §9.3), and a target
    reached with P >= 0 for which no tensions >= P_min are found is
    BELOW_FLOOR (not a proof), or UNIQUE_BELOW_FLOOR with two tendons where
    the traced boundary shows its tensions are its only ones (proven).  Both
    are file attributes (``share``,
    ``min_tension_N``, N; ``min_tension``, P l^2/B) that a resume must match.

    Collective over ``comm`` (default ``MPI.COMM_WORLD``; one rank runs
    serially).  With ``out`` (an ``.h5`` path) the results are checkpointed
    there every ``checkpoint_seconds`` (default
    ``$ELASTICA_PETSC_CHECKPOINT_SECONDS`` or 2 s) and at the end; ``resume``
    continues the chunks not yet done in ``out`` (and starts the run if
    ``out`` does not exist); an existing ``out`` needs ``overwrite`` otherwise.
    ``progress``: None (a bar on a terminal), False (none), or an object with
    ``update(done)`` and ``close(done)``.  ``provenance``: root attributes
    added to the file (e.g. ``command_line``).

    Returns the :class:`WorkspaceMap` on every rank; ``complete`` is False after
    an interruption (SIGINT/SIGTERM on any rank stops all of them within one
    sample; the file then holds every finished chunk).  Only if other ranks do
    not finish within ``STOP_GRACE`` seconds of a stop does rank 0 return alone
    with ``stranded`` True: the process must then end without MPI finalisation
    (``os._exit``), which makes the launcher end the others.  Bad input raises
    :class:`CollectiveInputError` on every rank before any computation.
    """
    from mpi4py import MPI

    comm = MPI.COMM_WORLD if comm is None else comm
    lock = None
    with _Stop() as stop:             # from here a signal stops the run at its first sample
        try:
            try:
                grid = make_grid(arm, disc, mode, spacing_mm, box_mm, tension_spacing,
                                 tension_max, chunk)
                if checkpoint_seconds is None:
                    checkpoint_seconds = checkpoint_interval()
                share_attrs = _share_attrs(arm, grid.mode, share, min_tension_N)
                path = None if out is None else _check_out(out, resume, overwrite)
                if path is not None and comm.rank == 0:
                    from ..io.hdf5 import OutputLock
                    lock = OutputLock(path)            # one run per output file
                error = None
            except InputError as err:
                error = str(err)
            agree(comm, error)
            sampler = SAMPLERS[grid.mode][0 if global_search else -1]
            results = _sample(arm, disc, grid, path, comm, resume, checkpoint_seconds,
                              progress, dict(provenance or {}, sampler=sampler, **share_attrs),
                              stop)
        finally:
            if lock is not None:
                lock.release()
    limits = limits_of(arm)
    ws = None
    if comm.rank == 0:
        ws = WorkspaceMap.from_results(results, limits, comm.size, path, sampler,
                                       (share_attrs["share"], share_attrs["min_tension_N"]))
        if ws.stranded:
            return ws                                # no collective: a peer is still busy
    ws, error = comm.bcast((ws, None if comm.rank else results.write_error), root=0)
    if error is not None:                            # a checkpoint failed (full disk, ...)
        raise CollectiveInputError(error)
    return ws


def _sample(arm, disc, grid: Grid, path, comm, resume: bool, checkpoint_seconds: float,
            progress, provenance: dict | None, stop: _Stop) -> "Results":
    """The sampler of ``grid.mode`` over the ranks (:func:`run`)."""
    from .sampling import TargetSampler, TensionSampler

    attrs = _attrs(arm, disc, grid, provenance)
    sampler = (TargetSampler(arm, disc, global_search=attrs["sampler"] == "global-search",
                             share=attrs["share"], min_tension=attrs["min_tension"])
               if grid.mode == "targets" else TensionSampler(arm, disc))
    try:
        return run(grid, sampler, path, attrs, limits_of(arm), comm=comm, resume=resume,
                   checkpoint_seconds=checkpoint_seconds, progress=progress,
                   progress_label=f"workspace ({grid.mode}, {comm.size} rank(s))", stop=stop)
    finally:
        sampler.destroy()


def _share_attrs(arm, mode: str, share: str | None, min_tension_N: float) -> dict:
    """The root attributes of the tension sharing of a map (:func:`run_map`);
    :class:`InputError` for a bad request."""
    from ..solvers.share import share_rule

    rule = share_rule(share, float(min_tension_N))
    if mode != "targets" and rule != "none":
        raise InputError("--share/--min-tension-N apply to mode targets (tip control); "
                         "mode tensions prescribes the tensions")
    p_min = float(arm.tensions_from_N(min_tension_N))
    if arm.max_tension is not None and p_min >= arm.max_tension:
        raise InputError(f"--min-tension-N {min_tension_N:g} is not below the motor limit "
                         f"{arm.motor.max_tension_N:g} N")
    return {"share": rule, "min_tension_N": float(min_tension_N), "min_tension": p_min}


def _check_out(out, resume: bool, overwrite: bool) -> Path:
    from ..io.hdf5 import check_output_path

    path = Path(out)
    if resume and path.exists():
        check_output_path(path, overwrite=True)
        return path
    return check_output_path(path, overwrite)


def _attrs(arm, disc, grid: Grid, extra: dict | None) -> dict:
    """Root attributes of a workspace file: provenance and what defines its grid."""
    from ..core.config import arm_to_dict
    from ..io.hdf5 import provenance

    attrs = provenance(arm, "workspace")
    attrs.update(mode=grid.mode, elements=disc.n_elements, n_tendons=disc.n_tendons,
                 config_json=json.dumps(arm_to_dict(arm)), grid_json=json.dumps(grid.meta))
    attrs.update(extra or {})
    return attrs
