"""The compiled kernels of core/fem.py (docs/model.md §20) beyond what test_fem.py checks.

- node positions: a circular arc (theta linear in s) against its closed form,
  error O(h^2) (the midpoint rule of Eq. (2));
- position derivatives (Eq. (13) at any node) against central finite
  differences of the node positions, and the Taylor remainder of the tip falls
  at order 2;
- the natural-order LDL^T inertia against dense eigenvalues for random
  symmetric bordered matrices (tridiagonal block, dense border columns and a
  dense border block), a zero pivot reported as singular, any other pattern
  refused;
- wrong argument sizes raise ValueError (no memory is read out of bounds).
"""
from __future__ import annotations

import numpy as np
import pytest

from elastica_petsc.core import fem_kernels
from elastica_petsc.core.fem import Discretisation, ldlt_negatives

from conftest import make_arm

TWO = [(200.0, (46.3, -97.1)), (600.0, (26.1, 51.1))]


def disc_of(n_elements: int) -> Discretisation:
    return Discretisation.from_arm(make_arm(TWO, elements=n_elements))


def test_node_positions_of_an_arc_converge_at_order_two():
    """theta = kappa s: x(s) = (sin(kappa s), 1 - cos(kappa s)) / kappa."""
    kappa, errors = 2.0, []
    for n in (12, 24, 48):
        disc = disc_of(n)
        s = np.linspace(0.0, 1.0, n + 1)
        x = disc.node_positions(kappa * s)
        exact = np.column_stack((np.sin(kappa * s), 1 - np.cos(kappa * s))) / kappa
        errors.append(np.abs(x - exact).max())
    rates = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(np.abs(rates - 2.0) < 0.05), rates


def test_position_derivative_matches_fd_and_taylor():
    disc = disc_of(24)
    rng = np.random.default_rng(3)
    theta = np.concatenate(([0.0], np.cumsum(rng.uniform(-0.2, 0.2, 24))))
    dtheta = np.concatenate(([0.0], rng.standard_normal(24)))
    nodes = [0, 8, 24, 13]
    d = disc.position_derivative(theta, dtheta[None, 1:], nodes)[0]
    eps = 1e-6
    fd = (disc.node_positions(theta + eps * dtheta) -
          disc.node_positions(theta - eps * dtheta))[nodes] / (2 * eps)
    assert np.allclose(d, fd, atol=1e-9)
    # the tip's Taylor remainder |x(theta + t dtheta) - x - t dx| falls at order 2
    rem = [np.linalg.norm(disc.node_positions(theta + t * dtheta)[-1]
                          - disc.node_positions(theta)[-1] - t * d[2]) for t in (1e-2, 5e-3)]
    assert abs(np.log2(rem[0] / rem[1]) - 2.0) < 0.1


def bordered_upper(rng, N: int, nb: int, starts, ends):
    """A random symmetric bordered matrix: its dense form and the upper CSR of
    :meth:`Discretisation.bordered_pattern` (border column b in rows starts[b]..ends[b]-1;
    the border block dense here, which the pattern's diagonal corner is a case of)."""
    A = np.zeros((N + nb, N + nb))
    k = np.arange(N)
    A[k, k] = rng.uniform(-1.0, 3.0, N)
    A[k[:-1], k[:-1] + 1] = A[k[:-1] + 1, k[:-1]] = rng.standard_normal(N - 1)
    for b in range(nb):
        A[starts[b]:ends[b], N + b] = rng.standard_normal(ends[b] - starts[b])
    A[N:, N:] = rng.standard_normal((nb, nb))
    A = np.triu(A) + np.triu(A, 1).T
    upper = np.triu(A)
    rows, cols = np.nonzero(upper)
    indptr = np.searchsorted(rows, np.arange(N + nb + 1)).astype(np.int32)
    return A, (indptr, cols.astype(np.int32)), upper[rows, cols]


@pytest.mark.parametrize("seed", range(6))
def test_ldlt_inertia_matches_dense_eigenvalues(seed):
    rng = np.random.default_rng(seed)
    N, nb = 30, 3
    A, pattern, values = bordered_upper(rng, N, nb, starts=[0, 5, 12], ends=[20, 30, 25])
    negative = ldlt_negatives(pattern, values, N)
    assert negative == int(np.sum(np.linalg.eigvalsh(A) < 0))


def test_ldlt_zero_pivot_and_foreign_pattern():
    # [[0, 1], [1, 0]] has a zero first pivot in the natural order: singular to LDL^T
    pattern = (np.array([0, 2, 3], np.int32), np.array([0, 1, 1], np.int32))
    assert ldlt_negatives(pattern, np.array([0.0, 1.0, 0.0]), 2) is None
    # an angle row reaching two columns ahead is not a bordered tridiagonal matrix
    far = (np.array([0, 2, 3, 4], np.int32), np.array([0, 2, 1, 2], np.int32))
    with pytest.raises(ValueError, match="bordered"):
        ldlt_negatives(far, np.ones(4), 3)


def test_wrong_sizes_are_refused():
    disc = disc_of(12)
    u, p = disc.straight(), np.array([1.0, 2.0])
    with pytest.raises(ValueError, match="^p: expected 2 items"):
        disc.residual(u, p[:1])
    with pytest.raises(ValueError, match="out"):
        fem_kernels.residual(u, p, disc.routes, disc.attach_index, 0.0, np.empty(3))
    with pytest.raises(ValueError, match="attachment node"):
        fem_kernels.residual(u, p, disc.routes, np.array([0, 99]), 0.0, np.empty(u.size))
    with pytest.raises(ValueError, match="node 13 outside"):
        disc.position_derivative(np.zeros(13), np.zeros((1, 12)), [13])
