"""Workspace maps (paper Sec. 4.3, Eqs. (18)-(22), Figs. 4-5), sampled over MPI.

Modules: :mod:`.schema` (the status of a sample, :class:`Status`; the
per-sample fields and their units; :class:`WorkspaceMap`, the result),
:mod:`.grids` (target and tension lattices cut into chunks), :mod:`.settings`
(:class:`SamplerSettings`, how a map samples), :mod:`.samplers` (what one
sample computes: tip control with the global search, or a forward solve),
:mod:`.fill` (the default sampler: classes from the traced boundary, Newton
sweeps on the tip of :mod:`.tip_newton`, the global search for the rest),
:mod:`.driver` (:func:`run_map`, :func:`read_map`, :func:`~.driver.make_sampler`).  The MPI chunk engine is
:mod:`elastica_petsc.studies.chunks`, the file layout
:mod:`elastica_petsc.io.workspace`.
"""
from .driver import read_map, run_map
from .schema import STATUS_NAMES, Status, WorkspaceMap, reason_counts
from .settings import SamplerSettings

__all__ = ["STATUS_NAMES", "SamplerSettings", "Status", "WorkspaceMap", "read_map",
           "reason_counts", "run_map"]
