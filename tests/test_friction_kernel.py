"""Kernel of capstan friction at the guides (core/friction.py, docs/model.md §27):
the residual and its Jacobian in each fixed stick/slip mode (Taylor remainders of
order 2, every derivative inside the stored pattern), the reduction to the
frictionless kernel, and the inputs refused."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from elastica_petsc.core.errors import InputError
from elastica_petsc.core.fem import Discretisation
from elastica_petsc.core.friction import SLIP_IN, SLIP_OUT, STICK, CapstanKernel
from elastica_petsc.core.model import load_config
from conftest import REPO

MODES = (SLIP_IN, STICK, SLIP_OUT)


@pytest.fixture(scope="module", params=[(None, 0.0), ((True, False), 0.0), (None, 0.01),
                                        ((True, False), 0.01)],
                ids=["force", "length", "elastic", "elastic-length"])
def kernel(request):
    """guided3 with both motors under force control, or the first holding its length,
    with inextensible or elastic cables (compliance B/(EA l^2) = 0.01)."""
    disc = Discretisation.from_arm(load_config(REPO / "configs" / "guided3.toml"), 24)
    control, compliance = request.param
    return CapstanKernel.of(disc, 0.3, length_control=control, compliance=compliance)


def bent_state(kernel, seed=0):
    """A state off equilibrium with bent arm, chords off their consistent values,
    segment tensions unrelated to each other, and reference lengths beside S."""
    rng = np.random.default_rng(seed)
    disc = kernel.disc
    theta = np.concatenate(([0.0], np.cumsum(rng.normal(0.05, 0.02, disc.n_elements))))
    u = disc.consistent_state(theta) + 1e-3 * rng.normal(size=disc.size)
    w = np.concatenate((u, rng.uniform(5.0, 10.0, kernel.size - disc.size)))
    motor = np.where(kernel.length_control, kernel.cable_lengths(w) - 1e-3, [12.0, 7.0])
    start = kernel.start_of(w, motor)
    start = start._replace(material=start.material + 1e-3 * rng.normal(size=kernel.n_guides))
    return w, motor, start


def jacobian(kernel, w, p, start, modes):
    indptr, indices = kernel.pattern
    return sp.csr_matrix((kernel.jacobian_values(w, p, start, modes), indices, indptr),
                         shape=(kernel.size, kernel.size))


@pytest.mark.parametrize("mode", MODES)
def test_jacobian_taylor_order_two_in_each_mode(kernel, mode):
    w, p, start = bent_state(kernel)
    modes = np.full(kernel.n_guides, mode)
    modes[::3] = MODES[(MODES.index(mode) + 1) % 3]          # mixed modes along the cables
    J = jacobian(kernel, w, p, start, modes)
    v = np.random.default_rng(1).normal(size=w.size)
    F0 = kernel.residual(w, p, start, modes)
    rem = [np.linalg.norm(kernel.residual(w + e * v, p, start, modes) - F0 - e * (J @ v))
           for e in (1e-3, 5e-4, 2.5e-4)]
    orders = np.log2(np.array(rem[:-1]) / np.array(rem[1:]))
    assert np.all(np.abs(orders - 2.0) < 0.1), (rem, orders)


def test_every_derivative_is_in_the_pattern(kernel):
    w, p, start = bent_state(kernel, seed=2)
    for mode in MODES:
        modes = np.full(kernel.n_guides, mode)
        J = jacobian(kernel, w, p, start, modes).toarray()
        fd = np.empty_like(J)
        for k in range(kernel.size):
            step = np.zeros(kernel.size)
            step[k] = 1e-7
            fd[:, k] = (kernel.residual(w + step, p, start, modes)
                        - kernel.residual(w - step, p, start, modes)) / 2e-7
        assert np.max(np.abs(fd - J)) < 1e-6 * max(1.0, np.abs(J).max())
        stored = np.zeros(J.shape, bool)
        indptr, indices = kernel.pattern
        stored[np.repeat(np.arange(kernel.size), np.diff(indptr)), indices] = True
        assert np.max(np.abs(fd[~stored]), initial=0.0) < 1e-6


def test_mu_zero_residual_is_the_frictionless_one(kernel):
    frictionless = CapstanKernel.of(kernel.disc, 0.0)           # force control
    w, p, start = bent_state(frictionless, seed=3)
    u = frictionless.split(w)[0]
    w0 = frictionless.frictionless_state(u, p)
    F = frictionless.residual(w0, p, start)
    np.testing.assert_array_equal(F[:kernel.disc.size], kernel.disc.residual(u, p))
    assert np.all(F[kernel.disc.size:] == 0.0)
    # with mu = 0 no guide can stick, whatever the slip
    assert not np.any(frictionless.modes(w, p, start) == STICK)


def test_refused_inputs(kernel, paper_arm):
    with pytest.raises(InputError, match="friction coefficient"):
        CapstanKernel.of(kernel.disc, -0.1)
    with pytest.raises(InputError, match="through guides"):
        CapstanKernel.of(Discretisation.from_arm(paper_arm), 0.2)


def test_solver_contract(kernel):
    """CapstanSolver (solvers/friction.py) follows docs/model.md §18: a checked prefix,
    prefixed objects, code options under it, options given later applied at the next solve."""
    from elastica_petsc.solvers.friction import CapstanSolver

    with pytest.raises(InputError, match="options prefix"):
        CapstanSolver(kernel, options_prefix="fric")
    w, motor, _ = bent_state(kernel, seed=4)
    with CapstanSolver(kernel, options_prefix="cap_", petsc_options={"snes_max_it": 1}) as solver:
        assert solver.J.getOptionsPrefix() == solver.x.getOptionsPrefix() == "cap_"
        _, its, reason, ok = solver.increment(w, motor, kernel.start_of(w, motor))
        assert its == 1 and not ok and reason == "DIVERGED_MAX_IT"
        solver.options.update({"snes_max_it": 3})
        assert solver.increment(w, motor, kernel.start_of(w, motor))[1] == 3


def test_antagonists_that_stick_are_statically_indeterminate():
    """configs/guided.toml at equal motor tensions: the arm is straight where both cables run
    (0-150 mm), opposite offsets.  With every guide sticking, the two cables' stuck segments
    over one span constrain the same rotation: the Jacobian loses rank (2, the spans shared
    by stuck segments of both cables), its tensions are indeterminate.  A cable compliance
    B/(EA l^2) > 0 (docs/model.md §27.6) restores the rank."""
    from elastica_petsc.solvers.equilibrium import solve_equilibrium

    disc = Discretisation.from_arm(load_config(REPO / "configs" / "guided.toml"), 48)
    p = np.array([9.0, 9.0])
    u = solve_equilibrium(disc, p).u
    rank_lost = []
    for compliance in (0.0, 1e-5):
        kernel = CapstanKernel.of(disc, 0.6, compliance=compliance)
        w = kernel.frictionless_state(u, p)
        J = jacobian(kernel, w, p, kernel.start_of(w, p), np.full(kernel.n_guides, STICK))
        sv = np.linalg.svd(J.toarray(), compute_uv=False)
        rank_lost.append(int(np.sum(sv < 1e-12 * sv[0])))
    assert rank_lost == [2, 0]
