"""ParaView export (io/vtk.py) read back by a reader that is not ours (meshio):
point counts, cell counts and fields of states, traced paths and workspace maps."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import h5py
import numpy as np
import pytest

from elastica_petsc.core.model import load_config
from elastica_petsc.io.vtk import lattice_quads, workspace_map, write_state, write_trace
from elastica_petsc.solvers.control import TipController
from elastica_petsc.studies.trace import densify, line, trace

meshio = pytest.importorskip("meshio")      # installed by scripts/test.sh (--no-deps)

ELEMENTS = 30


@pytest.fixture(scope="module")
def traced():
    arm = load_config()
    with TipController(arm, n_elements=ELEMENTS) as controller:
        result = trace(controller, densify(line((430.0, 200.0), (450.0, 215.0)), 10.0),
                       keep_results=True)
    return arm, result


def test_state_read_back(traced, tmp_path):
    """One equilibrium: N + 1 nodes and the n routing points; N arm segments
    and n cables as line cells; theta at the nodes, tensions on the cables."""
    arm, result = traced
    eq = result.results[-1].equilibrium
    mesh = meshio.read(write_state(tmp_path / "s.vtu", arm, eq))
    n = arm.n_tendons
    assert len(mesh.points) == ELEMENTS + 1 + n
    assert [(c.type, len(c.data)) for c in mesh.cells] == [("line", ELEMENTS + n)]
    np.testing.assert_allclose(mesh.points[:ELEMENTS + 1, :2], eq.x * arm.length_mm, rtol=1e-11)
    np.testing.assert_allclose(mesh.points[ELEMENTS + 1:, :2], arm.routes() * arm.length_mm)
    np.testing.assert_allclose(mesh.point_data["theta_rad"][:ELEMENTS + 1], eq.theta, rtol=1e-11)
    part = np.ravel(mesh.cell_data["part"][0])
    np.testing.assert_array_equal(part, [0] * ELEMENTS + list(range(1, n + 1)))
    tension = np.ravel(mesh.cell_data["tension_N"][0])
    np.testing.assert_allclose(tension[ELEMENTS:], arm.tensions_to_N(eq.p), rtol=1e-11)
    np.testing.assert_allclose(np.ravel(mesh.cell_data["curvature"][0])[:ELEMENTS], eq.curvature,
                               rtol=1e-10, atol=1e-12)
    # each cable joins its attachment node to its routing point
    cables = mesh.cells[0].data[ELEMENTS:]
    np.testing.assert_array_equal(cables[:, 0], eq.disc.attach_nodes)
    L = np.linalg.norm(mesh.points[cables[:, 1]] - mesh.points[cables[:, 0]], axis=1)
    np.testing.assert_allclose(L, np.ravel(mesh.cell_data["cable_length_mm"][0])[ELEMENTS:],
                               rtol=1e-10)


def test_trace_read_back(traced, tmp_path):
    arm, result = traced
    times = 0.5 * np.arange(result.n_points)
    files = write_trace(tmp_path, arm, result, times_s=times)
    K = result.n_points
    assert len(files) == K + 2
    pvd = ET.parse(tmp_path / "trace.pvd").getroot()
    sets = pvd.findall("./Collection/DataSet")
    assert [float(d.get("timestep")) for d in sets] == list(times)
    for d, r in zip(sets, result.results):
        mesh = meshio.read(tmp_path / d.get("file"))
        assert len(mesh.points) == ELEMENTS + 1 + arm.n_tendons
        np.testing.assert_allclose(mesh.points[ELEMENTS, :2], r.tip_mm, rtol=1e-11)
    # with an approach (here: the path itself stands in) its states come first
    more = write_trace(tmp_path / "both", arm, result, times_s=times + 10.0, approach=result,
                       approach_times_s=times)
    sets = ET.parse(tmp_path / "both" / "trace.pvd").getroot().findall("./Collection/DataSet")
    assert [float(d.get("timestep")) for d in sets] == list(times) + list(times + 10.0)
    assert sets[0].get("file") == "trace_approach_0000.vtu" and len(more) == 2 * K + 2
    path = meshio.read(tmp_path / "trace_path.vtu")
    assert len(path.points) == K and [(c.type, len(c.data)) for c in path.cells] == [("line", K - 1)]
    np.testing.assert_allclose(path.points[:, :2], result.tips_mm, rtol=1e-11)
    np.testing.assert_allclose(path.point_data["tension_2_N"], result.tensions_N[:, 1], rtol=1e-11)
    np.testing.assert_array_equal(path.point_data["reached"], result.converged.astype(np.uint8))
    np.testing.assert_allclose(path.point_data["time_s"], times)


def test_lattice_quads():
    # an L-shaped set of lattice points: exactly one full cell
    index = np.array([(0, 0), (1, 0), (2, 0), (0, 1), (1, 1)])
    np.testing.assert_array_equal(lattice_quads(index), [[0, 1, 4, 3]])


def test_workspace_cli_vtk_and_grid_index(tmp_path):
    """`workspace --vtk`: every sample a point with its fields, the lattice cells
    as quads; the HDF5 grid/index gives the 2-D map with two lines of numpy."""
    out, vtk = tmp_path / "ws.h5", tmp_path / "vtk"
    run = subprocess.run([sys.executable, "-m", "elastica_petsc.cli", "workspace", "--spacing",
                          "60", "--box", "420", "540", "180", "300", "--elements", str(ELEMENTS),
                          "--out", str(out), "--vtk", str(vtk), "--json", "--quiet"],
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    assert run.stderr == ""                                       # --quiet: no progress lines
    total = json.loads(run.stdout)["samples_total"]
    assert total == 9
    with h5py.File(out, "r") as fh:
        ix, iy = fh["grid/index"][()].T
        kappa = np.full((iy.max() + 1, ix.max() + 1), np.nan)
        kappa[iy, ix] = fh["samples/kappa_max"][()]
        points, k_flat = fh["grid/points"][()], fh["samples/kappa_max"][()]
        np.testing.assert_allclose(fh["grid/axis_0"][()], [420.0, 480.0, 540.0])
        np.testing.assert_allclose(fh["grid/axis_1"][()], [180.0, 240.0, 300.0])
        w0 = fh["masks/W0"][()]
        p, P = fh["samples/tensions"][()], fh["samples/tensions_N"][()]
        # tensions in N wherever p is (also for targets outside W_0), strings for reasons
        np.testing.assert_allclose(P, p * load_config().force_scale_N)
        assert fh["samples/reason"].dtype.kind == "S"
        status = fh["samples/status"][()]
        assert fh["masks/W0"].dtype == np.bool_
    assert 0 < np.sum(status == 1) < 9                # some targets outside W_0 (box corner)
    assert kappa.shape == (3, 3)
    x, y, same = workspace_map(out, "kappa_max")              # the library function
    np.testing.assert_array_equal(same, kappa)
    np.testing.assert_allclose(x, [420.0, 480.0, 540.0])
    _, _, P2 = workspace_map(out, "tensions_N", component=1)
    _, _, W0 = workspace_map(out, "W0")
    assert np.nanmax(P2) > 0 and set(np.unique(W0[~np.isnan(W0)])) <= {0.0, 1.0}
    # map cell [j, i] lies at (axis_0[i], axis_1[j]): the target of its sample
    np.testing.assert_allclose(np.column_stack((x[ix], y[iy])), points)
    s = int(np.flatnonzero(np.all(points == (540.0, 180.0), axis=1))[0])
    assert np.isfinite(k_flat[s]) and kappa[0, 2] == k_flat[s]
    # the README's snippet gives the same map
    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text()
    block = readme.split("**Loading a map.**", 1)[1].split("\n\n", 2)[1]
    snippet = "\n".join(line[4:] for line in block.splitlines())
    scope = {}
    cwd = os.getcwd()
    try:
        os.chdir(tmp_path)
        exec(compile(snippet, "README.md", "exec"), scope)
    finally:
        os.chdir(cwd)
    np.testing.assert_array_equal(scope["kappa"], kappa)
    np.testing.assert_allclose(scope["y"], [180.0, 240.0, 300.0])
    mesh = meshio.read(vtk / "workspace.vtu")
    assert len(mesh.points) == total
    assert [(c.type, len(c.data)) for c in mesh.cells] == [("vertex", 9), ("quad", 4)]
    np.testing.assert_allclose(mesh.points[:, :2], points)
    np.testing.assert_allclose(mesh.point_data["kappa_max"], k_flat)
    np.testing.assert_array_equal(mesh.point_data["W0"], w0.astype(np.uint8))
    for name in ("tension_1_N", "tension_2_p", "cable_length_1_mm", "lambda_min", "status"):
        assert name in mesh.point_data


def _cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "elastica_petsc.cli", *args], cwd=cwd,
                          capture_output=True, text=True, timeout=300)


def test_solve_and_lengths_cli_vtk(tmp_path):
    """`solve --vtk`: DIR/solve.vtu holds the state the command printed (arm
    nodes, routing points, tip, theta, cable tensions and lengths); `lengths
    --vtk`: DIR/state_K.vtu per state and DIR/states.pvd; an occupied folder
    is refused before any computing."""
    run = _cli("solve", "--tensions", "25.2", "10.8", "--order", "2,1", "--elements",
               str(ELEMENTS), "--vtk", str(tmp_path / "s"), "--json")
    assert run.returncode == 0, run.stderr
    state = json.loads(run.stdout)
    mesh = meshio.read(tmp_path / "s" / "solve.vtu")
    n = len(state["tensions"])
    assert len(mesh.points) == ELEMENTS + 1 + n
    assert [(c.type, len(c.data)) for c in mesh.cells] == [("line", ELEMENTS + n)]
    np.testing.assert_allclose(mesh.points[ELEMENTS, :2], state["tip_mm"], atol=1e-6)
    np.testing.assert_allclose(np.ravel(mesh.cell_data["tension_N"][0])[ELEMENTS:],
                               state["tensions_N"], rtol=1e-6)
    np.testing.assert_allclose(np.ravel(mesh.cell_data["cable_length_mm"][0])[ELEMENTS:],
                               state["cable_lengths_mm"], atol=1e-3)
    assert mesh.point_data["theta_rad"][0] == 0.0 and mesh.point_data["s_mm"][ELEMENTS] == 600.0
    # the same cable lengths prescribed (length control) give the same state
    run = _cli("lengths", "--lengths", *map(str, state["cable_lengths_mm"]), "--elements",
               str(ELEMENTS), "--vtk", str(tmp_path / "L"), "--out", str(tmp_path / "L.h5"),
               "--json")
    assert run.returncode == 0, run.stderr
    sets = ET.parse(tmp_path / "L" / "states.pvd").getroot().findall("./Collection/DataSet")
    assert [(d.get("timestep"), d.get("file")) for d in sets] == [("1", "state_1.vtu")]
    back = meshio.read(tmp_path / "L" / "state_1.vtu")
    with h5py.File(tmp_path / "L.h5", "r") as fh:                 # --out beside --vtk
        assert list(fh["equilibria"]) == ["state_1"]
    np.testing.assert_allclose(back.points[:ELEMENTS + 1], mesh.points[:ELEMENTS + 1], atol=1e-3)
    again = _cli("solve", "--tensions", "1", "1", "--vtk", str(tmp_path / "s"))
    assert again.returncode == 2 and "folder is not empty" in again.stderr
    assert again.stderr.count("\n") == 1
