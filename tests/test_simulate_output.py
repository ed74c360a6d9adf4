"""`simulate --vtk/--animate` and SimulationResult.to_vtk/animate (issue 22): the files
written and read back (ParaView's .pvd and .vtu by meshio, the GIF by Pillow)."""
from __future__ import annotations

import subprocess
import sys
import xml.etree.ElementTree as ET

import h5py
import numpy as np
import pytest
from PIL import Image

import elastica_petsc as ep

meshio = pytest.importorskip("meshio")      # installed by scripts/test.sh (--no-deps)

ELEMENTS = 24
RELEASE = ["--initial-tensions-N", "0", "0.05", "--tensions-N", "0", "0"]


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "elastica_petsc.cli", "simulate",
                           "--elements", str(ELEMENTS), *map(str, args)],
                          capture_output=True, text=True, timeout=300)


def _pvd_times(path):
    sets = ET.parse(path).getroot().findall("./Collection/DataSet")
    return np.array([float(d.get("timestep")) for d in sets]), [d.get("file") for d in sets]


def _gif_durations_ms(path):
    with Image.open(path) as im:
        size, durations = im.size, []
        for k in range(im.n_frames):
            im.seek(k)
            durations.append(im.info["duration"])
    return size, np.array(durations)


def test_cli_vtk_and_animation(tmp_path):
    """One .vtu per recorded step, listed in the .pvd at the steps' times (s, increasing,
    as in --out); each holds the arm (N + 1 nodes) and its cables, with the tip of the
    step; the tip path file; a real-time GIF 1024 px wide, 20 frames per simulated s."""
    out, vtk, gif = tmp_path / "s.h5", tmp_path / "vtk", tmp_path / "s.gif"
    r = _cli(*RELEASE, "--duration", 0.5, "--out", out, "--vtk", vtk, "--animate", gif,
             "--quiet")
    assert r.returncode == 0, r.stderr
    with h5py.File(out, "r") as fh:
        time_s, tip_mm = fh["time_s"][()], fh["tip_mm"][()]
    times, files = _pvd_times(vtk / "simulation.pvd")
    assert len(times) == len(time_s) > 100 and np.all(np.diff(times) > 0)
    np.testing.assert_allclose(times, time_s, rtol=1e-11)
    for k in (0, len(files) // 2, len(files) - 1):
        mesh = meshio.read(vtk / files[k])
        assert len(mesh.points) == ELEMENTS + 1 + 2
        assert [(c.type, len(c.data)) for c in mesh.cells] == [("line", ELEMENTS + 2)]
        np.testing.assert_allclose(mesh.points[ELEMENTS, :2], tip_mm[k], rtol=1e-10)
        assert np.all(np.ravel(mesh.cell_data["tension_N"][0])[ELEMENTS:] == 0.0)
    path = meshio.read(vtk / "simulation_tip.vtu")
    np.testing.assert_allclose(path.points[:, :2], tip_mm, rtol=1e-10)
    np.testing.assert_allclose(path.point_data["time_s"], time_s)
    size, shown = _gif_durations_ms(gif)
    assert size[0] == 1024 and len(shown) == 11 and np.all(shown == 50)


def test_library_to_vtk_and_slow_motion(tmp_path):
    """result.to_vtk(dir) writes what --vtk does; result.animate(path, slow_motion=K)
    plays the run K times slower (GIF frame durations add up to K x the duration)."""
    arm = ep.Arm.paper()
    result = ep.simulate(arm, initial_tensions_N=[0, 0.05], tensions_N=[0, 0],
                         duration_s=0.3, elements=ELEMENTS)
    files = result.to_vtk(tmp_path / "v")
    assert len(files) == len(result.time_s) + 2
    times, _ = _pvd_times(tmp_path / "v" / "simulation.pvd")
    np.testing.assert_allclose(times, result.time_s, rtol=1e-11)
    result.animate(tmp_path / "slow.gif", slow_motion=4)
    _, shown = _gif_durations_ms(tmp_path / "slow.gif")
    assert abs(shown[:-1].sum() / 1000.0 - 4 * 0.3) < 0.06


@pytest.mark.parametrize("case", ["file", "missing parent", "not empty", "slow motion"])
def test_cli_bad_output_options(tmp_path, case):
    """A --vtk folder that cannot be written, or --slow-motion <= 0: one line on
    stderr, exit status 2, before any computing (no --out written)."""
    out = tmp_path / "o.h5"
    (tmp_path / "afile").write_text("x")
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "x.vtu").write_text("x")
    extra = {"file": ["--vtk", tmp_path / "afile"],
             "missing parent": ["--vtk", tmp_path / "no" / "where"],
             "not empty": ["--vtk", tmp_path / "full"],
             "slow motion": ["--animate", tmp_path / "a.gif", "--slow-motion", "0"]}[case]
    r = _cli(*RELEASE, "--duration", 0.2, "--out", out, *extra)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "error:" in r.stderr, r.stderr
    assert not out.exists() and not (tmp_path / "a.gif").exists()
