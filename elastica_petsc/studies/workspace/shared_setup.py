"""The fixed costs of a boundary-filled map, paid once for all ranks
(docs/model.md §29).

Every chunk of a boundary-filled map needs the traced W_0 boundary of its
arm, and most ranks need the seed library of the global search
(:class:`~elastica_petsc.solvers.reach.SeedLibrary`) sooner or later; both
are fixed functions of the arm (a map does not depend on how its chunks are
spread over ranks).  Before the first chunk, rank 0 traces the boundary
while rank 1 builds the library; each is then sent to every other rank
(pickled by mpi4py; received by polling, not by a spinning broadcast) and
adopted by every rank, which neither traces nor builds
again.  Two ranks thus pay max(trace, library) once instead of each paying
trace + library; the results are bit for bit those of a rank that did both
itself (the same computation, sent as the floats it produced).

A :class:`~elastica_petsc.studies.boundary.BoundaryResult` keeps, on each
traced curve, the constraint objects that followed it (PETSc matrices,
solvers and factorisations, needed only while tracing):
:func:`plain_boundary` is a copy without them, which is all a map asks of
it (preimage counts, proofs, the loop nodes of the anchors).
"""
from __future__ import annotations

import dataclasses
import time

from ...core import interrupt
from ..boundary import TraceCache


def plain_boundary(result):
    """``result`` (a BoundaryResult) without its curves' constraint objects
    and its caches: plain data that pickles."""
    def plain(curve):
        return dataclasses.replace(curve, active=None, hit=None)

    regions = {name: dataclasses.replace(region, curves=[plain(c) for c in region.curves])
               for name, region in result.regions.items()}
    return dataclasses.replace(result, regions=regions,
                               fold_curves=[plain(c) for c in result.fold_curves],
                               _outside=None, _trees={})


# Message tags of the exchange (the chunk engine's are 11 and 12) and the polling period.
TAG_BOUNDARY, TAG_SEEDS = 31, 32
POLL_SECONDS = 0.001


def _send(comm, value, root: int, tag: int) -> list:
    """On ``root``: ``value`` sent to every other rank (pickled, not waited for); the requests."""
    if comm.rank != root:
        return []
    return [comm.isend(value, dest=rank, tag=tag) for rank in range(comm.size) if rank != root]


def _receive(comm, value, root: int, tag: int):
    """``value`` on ``root``; elsewhere what ``root`` sent, polled with short sleeps
    (a blocking broadcast spins in MPI and takes a core from the rank still
    computing when ranks share cores)."""
    if comm.rank == root:
        return value
    while not comm.iprobe(source=root, tag=tag):
        time.sleep(POLL_SECONDS)
    return comm.recv(source=root, tag=tag)


class AdoptedTraces(TraceCache):
    """A one-entry trace cache holding a boundary traced elsewhere (by rank 0)."""

    def __init__(self, arm, disc, result):
        super().__init__(size=1)
        self._traces[self._key(arm, disc)] = result


def share_fixed_costs(sampler, comm, stop) -> None:
    """Collective over ``comm`` (every rank, before its first chunk): the traced
    boundary from rank 0 and the seed library from rank 1, adopted by every
    rank of a :class:`~.fill.BoundaryFillSampler` of a two-tendon arm (module
    doc).  Nothing on one rank or other arms.  An error or a stop on the rank
    that computes a part leaves that part to each rank (as without sharing);
    the error is raised there after the broadcasts, so that no rank waits."""
    if comm.size < 2 or sampler.disc.n_tendons != 2:
        return
    boundary = seeds = error = None
    try:
        with interrupt.watching(stop):
            if comm.rank == 0:
                traced = sampler.boundary()
                boundary = (None if traced is None else plain_boundary(traced),)
            elif comm.rank == 1:
                library = sampler.library
                seeds = (library.seeds(), library.solves, library.stopped)
    except interrupt.Stopped:
        pass                                     # the run stops at its first sample
    except Exception as err:                     # raised after the broadcasts
        error = err
    sent = _send(comm, boundary, 0, TAG_BOUNDARY) + _send(comm, seeds, 1, TAG_SEEDS)
    boundary = _receive(comm, boundary, 0, TAG_BOUNDARY)
    seeds = _receive(comm, seeds, 1, TAG_SEEDS)
    while not all(request.Test() for request in sent):
        time.sleep(POLL_SECONDS)
    if boundary is not None and comm.rank != 0:
        sampler.adopt_boundary(boundary[0])
    if seeds is not None and comm.rank != 1:
        sampler.library.adopt(*seeds, disc=sampler.disc)
    if error is not None:
        raise error
