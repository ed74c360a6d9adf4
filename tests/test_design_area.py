"""The area objective of ``design`` and ``design --sweep`` (issue 13; its gradient
against finite differences of ``boundary``: tests/test_traced_area.py): the union
area of the re-sampling, the sweep's file, resume and ranks, and one-line errors."""
from __future__ import annotations

import shutil
import subprocess
import sys

import h5py
import numpy as np
import pytest
from mpi_env import mpi_env

from elastica_petsc.core.geometry import triangles_union_area
from elastica_petsc.core.model import load_config
from elastica_petsc.studies.design import DesignError
from elastica_petsc.studies.design_area import resampled_area
from elastica_petsc.studies.design_sweep import design_arm, parse_axis, run_sweep
from elastica_petsc.studies.traced_area import traced_area

pytestmark = pytest.mark.slow          # left out by scripts/test.sh --fast

ELEMENTS = 30
P_MAX = 18.0                                  # 10 N on the paper's arm


def test_union_area_closed_forms():
    square = np.array([[[0, 0], [10, 0], [10, 10]], [[0, 0], [10, 10], [0, 10]]], float)
    assert triangles_union_area(square, 0.05) == pytest.approx(100.0, rel=0.02)
    overlapping = np.concatenate((square, square + [5.0, 0.0]))          # union: 15 x 10
    assert triangles_union_area(overlapping, 0.05) == pytest.approx(150.0, rel=0.02)


def test_resampling_agrees_with_the_traced_area():
    """The independent re-sampling (forward solves on a tension grid, union of
    the cells' images) against the traced boundary's area on the paper's arm."""
    arm = load_config()
    a = traced_area(arm, [], P_MAX, elements=ELEMENTS)
    r = resampled_area(arm, P_MAX, elements=ELEMENTS, cells=16, lattice_mm=0.5)
    assert r.samples == 289 and r.stable == 289 and r.cables_clear == 289
    assert abs(r.area_mm2 - a.area_mm2) < r.error_mm2 + 0.02 * a.area_mm2, (r, a.area_mm2)
    assert r.error_mm2 < 0.15 * r.area_mm2


def test_parse_axis_and_design_arm():
    axis = parse_axis("tendon2.route.y=20:40:10", 2)
    assert axis.tendon == 1 and axis.kind == "route.y" and axis.values == (20.0, 30.0, 40.0)
    arm = design_arm(load_config(), [axis, parse_axis("tendon1.attach=100:100:1", 2)], [30, 100])
    assert arm.tendons[1].route_mm == (26.1, 30.0) and arm.tendons[0].attach_mm == 100.0
    for bad, message in (("tendon3.attach=1:2:1", "tendons 1..2"), ("tendon1.route=1:2:1", "expected"),
                         ("tendon1.attach=3:1:1", "STOP >= START"), ("tendon1.attach=a:b", "START")):
        with pytest.raises(DesignError, match=message):
            parse_axis(bad, 2)


def test_sweep_file_resume_and_values(tmp_path):
    """A sweep over an attachment and a routing point: each design's area is
    the area objective of that arm computed directly; a resumed complete file
    computes nothing and keeps the values; an attachment off the mesh is refused."""
    from mpi4py import MPI

    arm = load_config()
    axes = [parse_axis("tendon1.attach=150:200:50", 2), parse_axis("tendon2.route.y=40:50:10", 2)]
    out = tmp_path / "s.h5"
    sweep = run_sweep(arm, 24, axes, P_MAX, comm=MPI.COMM_SELF, out=out, progress=False)
    assert sweep.complete and len(sweep.designs) == 4
    direct = traced_area(design_arm(arm, axes, sweep.designs[3]), [], P_MAX, elements=24)
    assert sweep.values["area"][3] == direct.area_mm2
    with h5py.File(out, "r") as fh:
        assert fh.attrs["complete"] and fh["samples/area"].attrs["units"] == "mm^2"
        assert [n.decode() for n in fh["grid/names"][()]] == ["tendon1.attach", "tendon2.route.y"]
        stored = fh["samples/area"][()]
    again = run_sweep(arm, 24, axes, P_MAX, comm=MPI.COMM_SELF, out=out, resume=True,
                      progress=False)
    assert np.array_equal(again.values["area"], stored)
    with pytest.raises(Exception, match="not on a node"):
        run_sweep(arm, 24, [parse_axis("tendon1.attach=205:205:1", 2)], P_MAX,
                  comm=MPI.COMM_SELF, progress=False)


@pytest.mark.mpi
@pytest.mark.skipif(shutil.which("mpiexec") is None, reason="needs mpiexec")
def test_sweep_on_two_ranks_equals_one(tmp_path):
    common = [sys.executable, "-m", "elastica_petsc.cli", "design", "--sweep",
              "tendon2.route.y=40:50:10", "--elements", "24", "--json"]
    runs = []
    for ranks, name in ((1, "a.h5"), (2, "b.h5")):
        cmd = (["mpiexec", "-n", "2"] if ranks == 2 else []) + common + ["--out", name]
        done = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=300,
                              env=mpi_env())
        assert done.returncode == 0, done.stderr
        with h5py.File(tmp_path / name, "r") as fh:
            runs.append((fh["samples/area"][()], int(fh["timing"].attrs["ranks"])))
    assert runs[0][1] == 1 and runs[1][1] == 2
    assert np.array_equal(runs[0][0], runs[1][0])


@pytest.mark.parametrize("args, message", [
    (["--sweep", "tendon1.route.z=1:2:1"], "expected tendonK.route.x"),
    (["--sweep", "tendon1.attach=205:205:1", "--elements", "60"], "not on a node"),
    (["--sweep", "tendon2.route.y=1:2:1", "--vary", "tendon1.route"], "leave out --vary"),
    (["--vary", "tendon1.route"], "needs --vary and --objective"),
    (["--vary", "tendon1.route", "--objective", "volume"], "expected area or path"),
    (["--vary", "tendon1.route", "--objective", "area", "--out", "x.h5"], "expected .toml"),
    (["--vary", "tendon1.route", "--objective", "path:x.csv", "--plot", "p.png"],
     "--plot draws an area design"),
])
def test_cli_errors_one_line(tmp_path, args, message):
    run = subprocess.run([sys.executable, "-m", "elastica_petsc.cli", "design", *args],
                         cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert run.returncode == 2, run.stderr
    assert message in run.stderr and run.stderr.count("\n") == 1, run.stderr


def test_area_design_small_run_and_plot(tmp_path):
    """One TAO iteration in a 5 mm box: the best feasible design is kept, never
    worse than the start; the re-sampling fills both checks; the figure is drawn."""
    from elastica_petsc.plots.design import plot_area_design
    from elastica_petsc.studies.design_area import design_for_area

    arm = load_config()
    r = design_for_area(arm, [0, 1], P_MAX, elements=ELEMENTS, reach_mm=5.0,
                        max_iterations=1, resample_cells=6)
    assert r.history and r.after.area_mm2 >= r.before.area_mm2 == r.history[0]["area_mm2"]
    q = np.concatenate([t.route_mm for t in r.arm_after.tendons])
    assert np.all(np.abs(q - [46.3, -97.1, 26.1, 51.1]) <= 5.0 + 1e-9)
    assert r.resampled_before.samples == 49 and isinstance(r.confirmed, bool)
    plot_area_design(r, tmp_path / "d.png")
    assert (tmp_path / "d.png").stat().st_size > 10_000


def test_attachment_search_on_nodes():
    """Tendon 1's attachment, one node (20 mm at 30 elements) either way: the
    search ends on the feasible node of largest area, computed here directly."""
    from elastica_petsc.studies.design import with_attachment
    from elastica_petsc.studies.design_area import design_for_area

    arm = load_config()
    r = design_for_area(arm, [], P_MAX, elements=ELEMENTS, attaches=[0], reach_mm=20.0,
                        resample_cells=None)
    direct = {s: traced_area(with_attachment(arm, 0, s), [], P_MAX, elements=ELEMENTS)
              for s in (180.0, 200.0, 220.0)}
    best = max((a.area_mm2, s) for s, a in direct.items() if a.feasible)
    assert r.arm_after.tendons[0].attach_mm == best[1]
    assert r.after.area_mm2 == pytest.approx(best[0], rel=1e-9)
    assert r.confirmed is None and r.arm_after.tendons[1] == arm.tendons[1]
