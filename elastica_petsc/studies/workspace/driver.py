"""Workspace maps (paper Sec. 4.3, Eqs. (18)-(22), Figs. 4-5), sampled over MPI:
:func:`run_map` (a new or resumed map) and :func:`read_map` (a map's file).

The grid (:mod:`.grids`) is cut into chunks fixed by the grid alone; within a
chunk each sample is warm-started from the previous one and each chunk
starts from the straight arm, so every sample's result depends on the grid
only, never on the number of ranks, and a run equals its
interrupted-and-resumed twin.  The chunks are handed out, gathered,
checkpointed and stopped by the chunk engine
(:mod:`elastica_petsc.studies.chunks`, which describes the stop protocol);
every sample's PETSc/TAO/SLEPc objects live on ``COMM_SELF``.  The file
layout is :mod:`elastica_petsc.io.workspace`.  While a run owns its output
file it holds a lock beside it (:class:`~elastica_petsc.io.hdf5.OutputLock`).
``resume`` recomputes only chunks not done, and refuses a file made with
another grid, arm, element count, version, sampler or result-changing PETSc
options.
"""
from __future__ import annotations


from ...core import jsontext
from ...core.errors import InputError
from ...io.workspace import read_map_file
from ..chunks import (CollectiveInputError, Grid, Stop, agree, check_checkpoint_seconds,
                      check_out, run)
from .grids import make_grid
from .fill import BoundaryFillSampler
from .samplers import TargetSampler, TensionSampler
from .schema import Results, WorkspaceMap, limits_of
from .settings import SamplerSettings
from .shared_setup import share_fixed_costs


def read_map(path) -> WorkspaceMap:
    """A workspace file written by :func:`run_map` (or ``workspace --out``), complete
    or partial, back into a :class:`WorkspaceMap`."""
    results, limits, ranks, sampler, share = read_map_file(
        path, lambda mode, points, chunks, meta, n_tendons:
        Results(Grid(mode, points, chunks, meta), n_tendons))
    return WorkspaceMap.from_results(results, limits, ranks, path, sampler, share)


def run_map(arm, disc, *, mode: str = "targets", spacing_mm: float = 20.0, box_mm=None,
            tension_spacing: float = 2.0, tension_max: float = 40.0, chunk: int = 24,
            comm=None, out=None, resume: bool = False, overwrite: bool = False,
            progress=None, checkpoint_seconds: float | None = None,
            provenance: dict | None = None, global_search: bool = True,
            share: str | None = None, min_tension_N: float = 0.0,
            region: str = "half-disc", sampler: str | None = None) -> WorkspaceMap:
    """Sample the workspace W_0 of ``arm`` (Eq. (18), Fig. 4) and its restrictions
    W_Y, W_S, W_E, W_P (Eqs. (19)-(22), Fig. 5) on ``disc``.

    Mode ``targets``: tip control (Eqs. (10)-(12)) to every target of a square
    lattice of ``spacing_mm`` mm over the half-disc y >= 0 within reach l
    (``region`` "half-disc", the paper's), the whole disc ("disc"), or over
    ``box_mm`` = (xmin, xmax, ymin, ymax) in mm.  Mode ``tensions``:
    forward solves (Eq. (9)) on the lattice 0 <= p_i <= ``tension_max`` of
    step ``tension_spacing`` (non-dimensional p = P l^2/B).  W_0 means: tips
    of stable equilibria connected to the straight arm by quasi-static loading
    with all P_i >= 0.

    ``global_search`` (mode targets): a target local tip control does not
    reach goes through the global search (seeds over every loading order,
    reached chunk neighbours;
    :class:`~elastica_petsc.studies.workspace.samplers.TargetSampler`)
    and is classed REACHED, UNDECIDED (no proof either way) or BEYOND_REACH
    (|x_d| > l, proven); False keeps the local classes NEEDS_NEGATIVE (ended
    on P_i = 0, a local verdict) and NOT_CONVERGED, at the old cost.

    ``sampler`` (mode targets): "boundary-fill" (the default; None means it
    with ``global_search`` and "local" without): every target is first classed
    by the traced boundary of W_0 and the interior filled by Newton sweeps on
    the tip, the global search only for the targets they miss
    (:mod:`~elastica_petsc.studies.workspace.fill`, docs/model.md "Maps filled
    from the traced boundary"); "global-search": every target by tip control
    and the global search; "local": ``global_search=False``.  It overrides
    ``global_search``.

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

    Collective over ``comm`` (default ``MPI.COMM_SELF``: this process alone;
    pass ``MPI.COMM_WORLD`` to share the map among the ranks of ``mpiexec``).
    With ``out`` (an ``.h5`` path) the results are checkpointed
    there every ``checkpoint_seconds`` (default 2 s; the command line reads
    ``$ELASTICA_PETSC_CHECKPOINT_SECONDS``) and at the end; ``resume``
    continues the chunks not yet done in ``out`` (and starts the run if
    ``out`` does not exist); an existing ``out`` needs ``overwrite`` otherwise.
    ``progress``: True (a bar on a terminal, lines in logs), None/False
    (none), or an object with ``update(done)`` and ``close(done)``.  ``provenance``: root attributes
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

    comm = MPI.COMM_SELF if comm is None else comm
    lock = None
    with Stop() as stop:             # from here a signal stops the run at its first sample
        try:
            try:
                grid = make_grid(arm, disc, mode, spacing_mm, box_mm, tension_spacing,
                                 tension_max, chunk, region)
                if checkpoint_seconds is not None:
                    checkpoint_seconds = check_checkpoint_seconds(checkpoint_seconds)
                settings = SamplerSettings.make(arm, grid.mode, global_search, share,
                                                min_tension_N, sampler)
                path = None if out is None else check_out(out, resume, overwrite)
                if path is not None and comm.rank == 0:
                    from ...io.hdf5 import OutputLock
                    lock = OutputLock(path)            # one run per output file
                error = None
            except InputError as err:
                error = str(err)
            agree(comm, error)
            results = _sample(arm, disc, grid, settings, path, comm, resume, checkpoint_seconds,
                              progress, provenance, stop)
        finally:
            if lock is not None:
                lock.release()
    limits = limits_of(arm)
    ws = None
    if comm.rank == 0:
        ws = WorkspaceMap.from_results(results, limits, comm.size, path, settings.name,
                                       (settings.share, settings.min_tension_N))
        if ws.stranded:
            return ws                                # no collective: a peer is still busy
    ws, error = comm.bcast((ws, None if comm.rank else results.write_error), root=0)
    if error is not None:                            # a checkpoint failed (full disk, ...)
        raise CollectiveInputError(error)
    return ws


def _sample(arm, disc, grid: Grid, settings: SamplerSettings, path, comm, resume: bool,
            checkpoint_seconds: float, progress, provenance: dict | None, stop: Stop) -> Results:
    """The sampler of ``settings`` over the ranks (:func:`~elastica_petsc.studies.chunks.run`)."""
    attrs = map_attrs(arm, disc, grid, dict(provenance or {}, **settings.attrs()))
    sampler = make_sampler(arm, disc, settings)
    try:
        if settings.fill:
            share_fixed_costs(sampler, comm, stop)      # trace and seeds once for all ranks
        return run(grid, sampler, path, attrs, limits_of(arm), comm=comm, resume=resume,
                   new_results=lambda: Results(grid, disc.n_tendons),
                   checkpoint_seconds=checkpoint_seconds, progress=progress,
                   progress_label=f"workspace ({grid.mode}, {comm.size} rank(s))", stop=stop)
    finally:
        sampler.destroy()


def make_sampler(arm, disc, settings: SamplerSettings):
    """The sampler of ``settings``: in mode targets
    :class:`~.fill.BoundaryFillSampler` ("boundary-fill") or
    :class:`~.samplers.TargetSampler` ("global-search", "local"); in mode
    tensions :class:`~.samplers.TensionSampler`.  The caller destroys it."""
    if settings.fill:
        return BoundaryFillSampler(arm, disc, share=settings.share,
                                   min_tension=settings.min_tension)
    if settings.mode == "targets":
        return TargetSampler(arm, disc, global_search=settings.global_search,
                             share=settings.share, min_tension=settings.min_tension)
    return TensionSampler(arm, disc)


def map_attrs(arm, disc, grid: Grid, extra: dict | None) -> dict:
    """Root attributes of a workspace file: provenance and what defines its grid."""
    from ...core.config import arm_to_dict
    from ...io.hdf5 import provenance

    attrs = provenance(arm, "workspace")
    attrs.update(mode=grid.mode, elements=disc.n_elements, n_tendons=disc.n_tendons,
                 config_json=jsontext.dumps(arm_to_dict(arm)),
                 grid_json=jsontext.dumps(grid.meta))
    attrs.update(extra or {})
    return attrs
