"""Per-guide datasets of a cable routed through guides (io/guides.py, issue 24):
contact points on the arm, wrap angles and the forces on the arm, with units and
named dimensions."""
from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np

from elastica_petsc.core.fem import Discretisation
from elastica_petsc.core.model import load_config
from elastica_petsc.io.hdf5 import write_equilibrium
from elastica_petsc.solvers.equilibrium import EquilibriumSolver

ROOT = Path(__file__).resolve().parents[1]
P_N = np.array([10.0, 5.0])


def solved(elements=40):
    arm = load_config(ROOT / "configs" / "guided3.toml")
    disc = Discretisation.from_arm(arm, elements)
    with EquilibriumSolver(disc) as solver:
        eq = solver.solve(arm.tensions_from_N(P_N))
    assert eq.converged
    return arm, eq


def test_guide_datasets_of_an_equilibrium(tmp_path):
    arm, eq = solved()
    path = tmp_path / "eq.h5"
    with h5py.File(path, "w") as fh:
        write_equilibrium(fh.create_group("state_1"), arm, eq)
    with h5py.File(path) as fh:
        g = fh["state_1/guides"]
        for name, unit in (("s", "mm"), ("offset", "mm"), ("position", "mm"),
                           ("wrap_angle", "rad"), ("force_N", "N"), ("tendon", "1")):
            assert g[name].attrs["units"] == unit and g[name].attrs["long_name"]
        tendon, is_end, s = g["tendon"][()], g["is_end"][()], g["s"][()]
        offset, X, wrap, F = (g[k][()] for k in ("offset", "position", "wrap_angle", "force_N"))
        x = fh["state_1/state/x"][()]
        theta = fh["state_1/state/theta"][()]
    # 3 guides and an end per tendon, in the config's order
    np.testing.assert_array_equal(tendon, [1, 1, 1, 1, 2, 2, 2, 2])
    np.testing.assert_array_equal(is_end, [0, 0, 0, 1, 0, 0, 0, 1])
    np.testing.assert_allclose(s, [75, 150, 225, 300, 37.5, 75, 112.5, 150])
    np.testing.assert_allclose(offset, [8] * 4 + [-8] * 4)
    # the contact point: x(s) + offset n(theta(s)) with the left normal (-sin, cos)
    nodes = np.rint(s / arm.length_mm * eq.disc.n_elements).astype(int)
    normal = np.column_stack((-np.sin(theta[nodes]), np.cos(theta[nodes])))
    np.testing.assert_allclose(X, x[nodes] + offset[:, None] * normal, atol=1e-10)
    # a frictionless guide takes 2 P sin(wrap/2) from a cable of tension P; an end takes P
    P = P_N[tendon - 1]
    guide = ~is_end.astype(bool)
    np.testing.assert_allclose(np.linalg.norm(F[guide], axis=1),
                               2 * P[guide] * np.sin(wrap[guide] / 2), rtol=1e-10)
    np.testing.assert_allclose(np.linalg.norm(F[~guide], axis=1), P[~guide], rtol=1e-10)
    assert np.all(np.isnan(wrap[~guide])) and np.all(wrap[guide] > 0)
    # the cable's whole length is the sum of its segments
    seg = h5py.File(path)["state_1/guides/segment_length"][()]
    lengths = [seg[tendon == k].sum() for k in (1, 2)]
    np.testing.assert_allclose(lengths, eq.cable_lengths * arm.length_mm, rtol=1e-12)


def test_guide_datasets_open_with_named_dimensions(tmp_path):
    import pytest
    xr = pytest.importorskip("xarray")
    pytest.importorskip("h5netcdf")
    arm, eq = solved(elements=24)
    path = tmp_path / "eq.h5"
    with h5py.File(path, "w") as fh:
        write_equilibrium(fh, arm, eq)
    ds = xr.open_dataset(path, engine="h5netcdf", group="guides")
    assert ds["position"].dims == ("cable_point", "component")
    assert ds["wrap_angle"].dims == ("cable_point",) and ds["wrap_angle"].attrs["units"] == "rad"


def test_paper_arm_has_no_guide_datasets(tmp_path):
    arm = load_config(None)
    with EquilibriumSolver(Discretisation.from_arm(arm, 30)) as solver:
        eq = solver.solve([5.0, 2.0])
    with h5py.File(tmp_path / "eq.h5", "w") as fh:
        write_equilibrium(fh, arm, eq)
        assert "guides" not in fh


def test_trace_guide_datasets_per_path_point(tmp_path):
    from elastica_petsc.io.guides import write_trace_guides
    arm, eq = solved(elements=24)
    with EquilibriumSolver(eq.disc) as solver:
        other = solver.solve(arm.tensions_from_N([4.0, 8.0]))
    with h5py.File(tmp_path / "t.h5", "w") as fh:
        path = fh.create_group("path")
        path.create_dataset("tip", data=np.zeros((2, 2)))
        write_trace_guides(path, arm, [eq, other])
        X = path["guide_position"][()]
        assert X.shape == (2, 8, 2) and path["guide_position"].attrs["units"] == "mm"
        np.testing.assert_allclose(X[1], other.disc.point_positions(other.theta) * arm.length_mm)
        scales = [d[0].name.rsplit("/", 1)[-1] for d in path["guide_wrap_angle"].dims]
        assert scales == ["point", "cable_point"]
