"""The public Python API (issue 10): mm and newtons at the edge, one call per study."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import elastica_petsc as ep

SCRIPT = """\
import elastica_petsc as ep
arm = ep.Arm.paper()
s = ep.solve(arm, tensions_N=[14.0, 6.0], order=(2, 1))
c = ep.control(arm, [535.8, 222.6])
w = ep.workspace(arm, spacing_mm=100)
print(*s.cable_lengths_mm, *c.tensions_N, len(w.status), int(w.masks["W0"].sum()))
"""


@pytest.mark.slow
def test_fifteen_line_script_reproduces_fig8_and_fig2(tmp_path):
    """The issue's script: Fig. 8 state 1, Fig. 2 and a map without writing a file."""
    assert len(SCRIPT.splitlines()) <= 15
    done = subprocess.run([sys.executable, "-c", SCRIPT], cwd=tmp_path, capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    values = [float(v) for v in done.stdout.split()]
    assert values[0:2] == pytest.approx([147.2, 472.5], abs=0.5)     # Fig. 8 state 1, mm
    assert values[2:4] == pytest.approx([1.206, 4.201], abs=0.01)    # Fig. 2 tensions, N
    assert values[4] > 0 and 0 < values[5] < values[4]
    assert list(tmp_path.iterdir()) == []


def test_import_does_not_start_petsc():
    code = "import sys, elastica_petsc; print('petsc4py.PETSc' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_all_names_resolve():
    for name in ep.__all__:
        assert getattr(ep, name) is not None
    with pytest.raises(AttributeError):
        ep.no_such_name


def test_state_units_match_the_nondimensional_state():
    arm = ep.Arm.paper()
    s = ep.solve(arm, tensions=[25.2, 10.8], order=(1, 2))           # Fig. 8 state 3
    eq = s.equilibrium
    assert s.loading == "order 1,2"
    assert s.x_mm.shape == (arm.elements + 1, 2)
    np.testing.assert_allclose(s.tip_mm, eq.tip * arm.length_mm)
    np.testing.assert_allclose(s.tensions_N, eq.p * arm.force_scale_N)
    assert s.cable_lengths_mm == pytest.approx([96.3, 454.3], abs=0.2)   # paper (96.2, 454.3)


def test_bad_input_is_an_input_error():
    arm = ep.Arm.paper()
    with pytest.raises(ep.InputError, match="exactly one"):
        ep.solve(arm, tensions_N=[1, 1], tensions=[1, 1])
    with pytest.raises(ep.InputError, match="negative"):
        ep.solve(arm, tensions_N=[-1, 1])
    with pytest.raises(ep.InputError, match="permutation"):
        ep.solve(arm, tensions_N=[1, 1], order=(1, 1))
    with pytest.raises(ep.InputError, match="target_mm"):
        ep.control(arm, [1.0, float("nan")])


def test_read_returns_the_state_the_cli_wrote(tmp_path):
    out = tmp_path / "s.h5"
    subprocess.run([sys.executable, "-m", "elastica_petsc.cli", "solve", "--tensions", "25.2",
                    "10.8", "--order", "1,2", "--out", str(out)], check=True, capture_output=True)
    s = ep.read(out)
    direct = ep.solve(ep.Arm.paper(), tensions=[25.2, 10.8], order=(1, 2))
    assert isinstance(s, ep.State) and s.loading == "order 1,2"
    np.testing.assert_allclose(s.x_mm, direct.x_mm, atol=1e-9)
    np.testing.assert_allclose(s.cable_lengths_mm, direct.cable_lengths_mm, atol=1e-9)
    assert s.stable and s.converged


def test_read_refuses_what_it_cannot_read(tmp_path):
    (tmp_path / "x.h5").write_text("not hdf5")
    with pytest.raises(ep.InputError, match="not an HDF5 file"):
        ep.read(tmp_path / "x.h5")
    with pytest.raises(ep.InputError, match="no such file"):
        ep.read(tmp_path / "missing.h5")


@pytest.mark.slow
def test_readme_python_block_runs(tmp_path):
    """The README's Python section is a script that runs as shown."""
    from pathlib import Path

    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text()
    block = readme.split("## Python", 1)[1].split("```python\n", 1)[1].split("```", 1)[0]
    done = subprocess.run([sys.executable, "-c", block], cwd=tmp_path, capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "motors.csv").exists()


def test_read_round_trips_an_arm_without_optional_keys(tmp_path):
    """A config without mass or motor limit (None in the arm) survives config_json."""
    from elastica_petsc.core.config import arm_to_dict
    from elastica_petsc.core.model import arm_from_dict

    cfg = tmp_path / "one.toml"
    cfg.write_text("[arm]\nlength_mm = 1000.0\nbending_stiffness_Nm2 = 1.0\nelements = 40\n"
                   "[[tendon]]\nattach_mm = 1000.0\nroute_mm = [-5000.0, 0.0]\n")
    arm = ep.Arm.from_toml(cfg)
    assert arm.mass_per_length_kg_m is None and arm.motor.max_tension_N is None
    assert arm_from_dict(arm_to_dict(arm)) == arm


def test_bifurcation_side_and_its_record(tmp_path):
    """Cable through (l/2, 0) past p_cr = 18.27: both buckled sides by side=, and the
    bifurcation crossed travels through the file (solve --out, ep.read)."""
    cfg = tmp_path / "mid.toml"
    cfg.write_text("[arm]\nlength_mm = 1000.0\nbending_stiffness_Nm2 = 1.0\nelements = 60\n"
                   "[[tendon]]\nattach_mm = 1000.0\nroute_mm = [500.0, 0.0]\n")
    arm = ep.Arm.from_toml(cfg)
    left, right = (ep.solve(arm, tensions=[18.6], side=s) for s in ("left", "right"))
    assert left.stable and right.stable
    assert left.tip_mm[1] > 50 and right.tip_mm[1] == pytest.approx(-left.tip_mm[1], abs=1e-6)
    out = tmp_path / "s.h5"
    subprocess.run([sys.executable, "-m", "elastica_petsc.cli", "solve", "--config", str(cfg),
                    "--tensions", "18.6", "--side", "right", "--out", str(out)], check=True,
                   capture_output=True)
    back = ep.read(out)
    np.testing.assert_allclose(back.tip_mm, right.tip_mm, atol=1e-9)
    (b,) = back.equilibrium.bifurcations
    assert b.side == "right" and b.p_critical[0] == pytest.approx(18.27, abs=0.05)


def test_boundary_in_one_call():
    """ep.boundary: the W_0 polygon of the paper's arm contains the tips of forward
    solves at admissible tensions (coarse mesh: a quick check of the wiring)."""
    from elastica_petsc.core.geometry import winding_number

    arm = ep.Arm.paper()
    b = ep.boundary(arm, restricted=False, elements=60)
    assert b.areas_mm2["W0"] > 0 and b.solves > 0
    tip = ep.solve(arm, tensions=[10.0, 5.0], elements=60).tip_mm
    assert any(winding_number(poly, tip[None, :])[0] != 0 for poly in b.polygons_mm["W0"])


@pytest.mark.slow
def test_workspace_file_reads_back_as_the_map(tmp_path):
    arm = ep.Arm.paper()
    wmap = ep.workspace(arm, spacing_mm=150, out=tmp_path / "w.h5")
    back = ep.read(tmp_path / "w.h5")
    assert type(back) is type(wmap) and back.complete
    assert (back.status == wmap.status).all()
    for name, mask in wmap.masks.items():
        np.testing.assert_array_equal(back.masks[name], mask)
    np.testing.assert_array_equal(back.tensions_N, wmap.tensions_N)
