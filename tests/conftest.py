"""Shared fixtures for the forward-statics tests.

Units follow the package: arms are described in mm and N m^2 (docs/model.md §5); the
solvers work non-dimensionally (docs/model.md §3: lengths / l, p = P l^2 / B).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp

from elastica_petsc.core.model import load_config
from elastica_petsc.core.model import Arm, Tendon

REPO = Path(__file__).resolve().parents[1]
PAPER_TOML = REPO / "configs" / "paper.toml"


def make_arm(tendons, *, length_mm: float = 600.0, bending_stiffness_Nm2: float = 0.2,
             elements: int = 180) -> Arm:
    """An Arm from ``[(attach_mm, (rx_mm, ry_mm)), ...]``."""
    return Arm(length_mm=float(length_mm), bending_stiffness_Nm2=float(bending_stiffness_Nm2),
               tendons=tuple(Tendon(float(s), (float(r[0]), float(r[1]))) for s, r in tendons),
               elements=int(elements))


def tip_tendon_arm(route_l, n_elements: int) -> Arm:
    """A 1000 mm arm with one tendon at the tip routed to ``route_l`` (units of l)."""
    return make_arm([(1000.0, (1000.0 * route_l[0], 1000.0 * route_l[1]))],
                    length_mm=1000.0, bending_stiffness_Nm2=1.0, elements=n_elements)


def csr_to_dense(disc, values, pattern=None) -> np.ndarray:
    """Dense matrix from entries in the order of a CSR pattern (indptr, indices, src)."""
    indptr, indices, _ = disc.pattern if pattern is None else pattern
    n = len(indptr) - 1
    return sp.csr_matrix((values, indices, indptr), shape=(n, n)).toarray()


def reduced_tangent(disc, u, p) -> np.ndarray:
    """K = J_tt - J_ty J_yy^{-1} J_yt: the Schur complement of the bordered
    Jacobian on the attachment unknowns (docs/model.md §2: the Hessian of Pi)."""
    J = csr_to_dense(disc, disc.jacobian_values(u, p))
    N = disc.n_elements
    A, B, C, D = J[:N, :N], J[:N, N:], J[N:, :N], J[N:, N:]
    return A - B @ np.linalg.solve(D, C)


def stability_dense(disc, u, p) -> np.ndarray:
    """The symmetric H = [[T, W], [W^T, -I]] from its stored upper triangle."""
    U = csr_to_dense(disc, disc.stability_values(u, p), disc.stability_pattern)
    assert np.all(np.tril(U, -1) == 0.0), "stability_pattern must hold the upper triangle only"
    return U + np.triu(U, 1).T


@pytest.fixture(scope="session")
def paper_arm() -> Arm:
    """The arm of the paper's Fig. 1 (docs/model.md §5), from configs/paper.toml."""
    arm = load_config(PAPER_TOML)
    # guard against a silently edited reference configuration (docs/model.md §5)
    assert arm.length_mm == 600.0 and arm.elements == 180
    assert [t.attach_mm for t in arm.tendons] == [200.0, 600.0]
    assert [t.route_mm for t in arm.tendons] == [(46.3, -97.1), (26.1, 51.1)]
    return arm


@pytest.fixture(scope="session")
def paper_solver(paper_arm):
    """One EquilibriumSolver on the paper's 180-element mesh, shared."""
    from elastica_petsc.solvers.equilibrium import EquilibriumSolver
    from elastica_petsc.core.fem import Discretisation

    solver = EquilibriumSolver(Discretisation.from_arm(paper_arm, 180))
    yield solver
    solver.destroy()


# The slowest files first (measured with --durations): the parallel run of
# scripts/test.sh (pytest-xdist, a file per worker) hands files out in collection
# order, so a long file collected last would leave the other core idle at the end.
SLOW_FILES_FIRST = ("test_workspace.py", "test_readme.py", "test_reproduce.py", "test_api.py",
                    "test_cli_lengths.py", "test_lengths.py", "test_search_curves.py", "test_workspace_share.py",
                    "test_boundary.py")


def pytest_collection_modifyitems(items):
    rank = {name: k for k, name in enumerate(SLOW_FILES_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))     # stable sort
