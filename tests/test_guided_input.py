"""Input for cables through guides and weight (docs/model.md §11.6): the TOML keys,
today's configs unchanged, bad input as one line with exit status 2."""
from __future__ import annotations

import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

from elastica_petsc.core.config import arm_to_dict
from elastica_petsc.core.model import arm_from_dict, load_config
from elastica_petsc.core.errors import InputError
from elastica_petsc.core.fem import Discretisation
from elastica_petsc.io.design import config_toml

ROOT = Path(__file__).resolve().parents[1]
ARM = "[arm]\nlength_mm = 300\nbending_stiffness_Nm2 = 0.05\nelements = 120\nguide_radius_mm = 10\n"
TENDON = "[[tendon]]\nroute_mm = [0, 8]\nattach_mm = 300\nattach_offset_mm = 8\n"


def cli(*args):
    return subprocess.run([sys.executable, "-m", "elastica_petsc.cli", *map(str, args)],
                          capture_output=True, text=True, timeout=120)


def test_guided_configs_read_and_round_trip():
    for name, guides in (("guided", 5), ("guided3", 3)):
        arm = load_config(ROOT / "configs" / f"{name}.toml")
        assert [len(t.guides) for t in arm.tendons] == [guides, guides]
        assert arm.tendons[0].attach_offset_mm == 8.0
        again = arm_from_dict(tomllib.loads(config_toml(arm)))
        assert again == arm
    vertical = load_config(ROOT / "configs" / "paper_vertical.toml")
    assert vertical.gravity_m_s2 == (0.0, -9.81) and vertical.tip_mass_kg == 0.0
    assert np.allclose(vertical.gravity_load(), [0.0, -0.144 * 9.81 * 0.6**3 / 0.2])


def test_paper_config_unchanged(paper_arm):
    """Today's configs mean the same: the paper kernel, no new keys written."""
    assert not paper_arm.has_paths
    assert type(Discretisation.from_arm(paper_arm)) is Discretisation
    data = arm_to_dict(paper_arm)
    assert set(data["tendon"][0]) == {"attach_mm", "route_mm"}
    assert "tip_mass_kg" not in data["arm"] and "gravity_m_s2" not in data["arm"]


BAD = [
    (ARM + TENDON + "guides = [{s_mm = 350.0, offset_mm = 8.0}]\n",
     "tendon[1].guides[1]: s = 350 mm lies outside the arm"),
    (ARM + TENDON + "guides = [{s_mm = 0.0}]\n", "tendon[1].guides[1]: s = 0 mm lies outside"),
    (ARM + TENDON + "guides = [{s_mm = 100.0, offset_mm = 8.0}, {s_mm = 100.0, offset_mm = 8.0}]\n",
     "tendon[1].guides[1] and tendon[1].guides[2] are at one point"),
    (ARM + TENDON + "guides = [{s_mm = 300.0, offset_mm = 8.0}]\n",
     "tendon[1].guides[1] and tendon[1].attach are at one point"),
    (ARM + TENDON + "guides = [{s_mm = 100.0, offset_mm = 12.0}]\n",
     "offset 12 mm is larger than arm.guide_radius_mm = 10 mm"),
    (ARM + TENDON + "guides = [{s_mm = 101.0}]\n", "guide 1 at s = 101 mm is not on a node"),
    (ARM + TENDON + "guides = [{s_mm = 100.0, colour = 1}]\n", "guides[1].colour: unknown key"),
    (ARM + "gravity_m_s2 = [0.0, -9.81]\n" + TENDON, "gravity needs a mass"),
    (ARM + "gravity_m_s2 = [0.0]\nmass_per_length_kg_m = 0.1\n" + TENDON,
     "arm.gravity_m_s2: expected two numbers"),
    (ARM + "tip_mass_kg = -0.1\n" + TENDON, "arm.tip_mass_kg must be a number >= 0"),
]


@pytest.mark.parametrize("text, message", BAD)
def test_bad_guides_and_weight_are_input_errors(tmp_path, text, message):
    path = tmp_path / "arm.toml"
    path.write_text(text)
    with pytest.raises(InputError) as err:
        Discretisation.from_arm(load_config(path))
    assert message in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize("case", [0, 2, 4, 7])
def test_bad_input_on_the_command_line_one_line_exit_2(tmp_path, case):
    text, message = BAD[case]
    path = tmp_path / "arm.toml"
    path.write_text(text)
    run = cli("solve", "--config", path, "--tensions", 1)
    assert run.returncode == 2, run.stdout
    assert message in run.stderr, run.stderr
    assert "Traceback" not in run.stderr
    assert len(run.stderr.strip().splitlines()) == 1


def test_sweep_axis_offset_moves_guides_and_end_point():
    from elastica_petsc.studies.design_sweep import design_arm, parse_axis
    arm = load_config(ROOT / "configs" / "guided3.toml")
    axis = parse_axis("tendon2.offset=-9:-5:2", arm.n_tendons)
    assert axis.values == (-9.0, -7.0, -5.0)
    moved = design_arm(arm, [axis], [-5.0])
    t = moved.tendons[1]
    assert t.attach_offset_mm == -5.0 and all(g.offset_mm == -5.0 for g in t.guides)
    assert [g.s_mm for g in t.guides] == [g.s_mm for g in arm.tendons[1].guides]
    assert moved.tendons[0] == arm.tendons[0]
    with pytest.raises(InputError, match="larger than arm.guide_radius_mm = 10 mm"):
        design_arm(arm, [axis], [-11.0])


OLD_ARM = ARM.replace("guide_radius_mm = 10", "width_mm = 20")


def test_width_as_guide_extent_still_works_with_a_warning_naming_the_new_key(tmp_path):
    """arm.width_mm without arm.guide_radius_mm still bounds the offsets by width/2
    (the old meaning), with a deprecation warning that names guide_radius_mm."""
    from elastica_petsc.core.errors import InputDeprecation
    path = tmp_path / "arm.toml"
    path.write_text(OLD_ARM + TENDON)
    with pytest.warns(InputDeprecation, match="add guide_radius_mm = 10 to \\[arm\\]"):
        arm = load_config(path)
    assert arm.guide_radius_mm is None
    path.write_text(OLD_ARM + TENDON + "guides = [{s_mm = 100.0, offset_mm = 12.0}]\n")
    with pytest.raises(InputError, match="larger than half the arm's width .*guide_radius_mm"):
        load_config(path)
    run = cli("solve", "--config", path, "--tensions", 1)
    assert run.returncode == 2 and len(run.stderr.strip().splitlines()) == 1, run.stderr
    path.write_text(OLD_ARM + TENDON)
    run = cli("solve", "--config", path, "--tensions", 1, "--elements", 12)
    assert run.returncode == 0, run.stderr
    assert "elastica-petsc: warning: arm.width_mm = 20 bounds the guide offsets" in run.stderr
    assert "Traceback" not in run.stderr and "FutureWarning" not in run.stderr


def test_guide_radius_is_independent_of_the_strip_width(tmp_path):
    """With guide_radius_mm, width_mm is the strip's width only: no warning, and a disk
    wider than the strip is allowed."""
    import warnings
    path = tmp_path / "arm.toml"
    path.write_text(ARM + "width_mm = 4\n" + TENDON)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        arm = load_config(path)
    assert arm.guide_radius_mm == 10.0 and arm.width_mm == 4.0


def test_width_deprecation_printed_once_under_mpiexec(tmp_path):
    """Every rank reads the config and warns; rank 0 alone prints the line."""
    import os
    import shutil
    if shutil.which("mpiexec") is None:
        pytest.skip("no mpiexec")
    path = tmp_path / "arm.toml"
    path.write_text(OLD_ARM + TENDON)
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
               OMPI_MCA_rmaps_base_oversubscribe="1")
    run = subprocess.run(["mpiexec", "-n", "2", sys.executable, "-m", "elastica_petsc.cli",
                          "solve", "--config", str(path), "--tensions", "1", "--elements", "12"],
                         capture_output=True, text=True, timeout=120, env=env)
    assert run.returncode == 0, run.stderr
    assert run.stderr.count("elastica-petsc: warning: arm.width_mm = 20") == 1, run.stderr
