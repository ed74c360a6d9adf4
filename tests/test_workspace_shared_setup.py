"""The fixed costs of a boundary-filled map shared by the ranks
(studies/workspace/shared_setup.py): the plain boundary pickles and answers
as the traced one; a rank adopts the boundary of rank 0 and the seeds of
rank 1 without tracing or building them (a stand-in communicator)."""
from __future__ import annotations

import pickle

import numpy as np
import pytest

from elastica_petsc.core.fem import Discretisation
from elastica_petsc.core.model import load_config
from elastica_petsc.studies import boundary as boundary_module
from elastica_petsc.studies.workspace.fill import BoundaryFillSampler
from elastica_petsc.studies.workspace.shared_setup import plain_boundary, share_fixed_costs

ELEMENTS = 60


class SentComm:
    """Rank ``rank`` of ``size``: a message from another rank is what that rank
    computed (``sent[source]``, round-tripped through pickle); sends complete."""

    class Done:
        def Test(self) -> bool:
            return True

    def __init__(self, rank: int, size: int, sent: dict):
        self.rank, self.size, self.sent = rank, size, sent
        self.sends = []

    def isend(self, value, dest: int, tag: int):
        self.sends.append((dest, tag))
        return self.Done()

    def iprobe(self, source: int, tag: int) -> bool:
        return source in self.sent

    def recv(self, source: int, tag: int):
        return pickle.loads(pickle.dumps(self.sent[source]))


@pytest.fixture(scope="module")
def built():
    """A sampler that traced the boundary and built the seeds itself."""
    arm = load_config()
    sampler = BoundaryFillSampler(arm, Discretisation.from_arm(arm, ELEMENTS))
    sampler.boundary()
    lib = sampler.library
    yield arm, sampler, (lib.seeds(), lib.solves, lib.stopped)
    sampler.destroy()


def test_plain_boundary_pickles_and_counts_the_same(built):
    arm, sampler, _ = built
    traced = sampler.boundary()
    copy = pickle.loads(pickle.dumps(plain_boundary(traced)))
    points = np.random.default_rng(7).uniform(-600.0, 600.0, (400, 2))
    assert copy.preimage_counts(points) == traced.preimage_counts(points)
    assert [copy.outside(x)[0] for x in points[:40]] == [traced.outside(x)[0] for x in points[:40]]


@pytest.mark.parametrize("rank", [1, 2])
def test_other_ranks_adopt_without_tracing(built, rank, monkeypatch):
    arm, done, seeds = built
    sent = {0: (plain_boundary(done.boundary()),), 1: seeds}

    def no_trace(*args, **kwargs):
        raise AssertionError("traced again")
    monkeypatch.setattr(boundary_module.trace, "trace_boundary", no_trace)
    sampler = BoundaryFillSampler(arm, Discretisation.from_arm(arm, ELEMENTS))
    try:
        if rank == 1:                    # rank 1 builds the seeds itself, then adopts the trace
            sampler.library.seeds()
        else:                            # rank 2 builds nothing
            monkeypatch.setattr(type(sampler.library), "_sweep", no_trace)
        comm = SentComm(rank, 3, sent)
        share_fixed_costs(sampler, comm, stop=lambda: False)
        assert comm.sends == ([(0, 32), (2, 32)] if rank == 1 else [])
        points = np.random.default_rng(3).uniform(-600.0, 600.0, (200, 2))
        assert sampler.boundary().preimage_counts(points) == \
            done.boundary().preimage_counts(points)
        mine = [s.equilibrium for s in sampler.library.seeds()]
        theirs = [s.equilibrium for s in done.library.seeds()]
        assert all(np.array_equal(a.u, b.u) and np.array_equal(a.p, b.p)
                   for a, b in zip(mine, theirs, strict=True))
        assert all(eq.disc is sampler.disc for eq in mine)
    finally:
        sampler.destroy()
