"""Arms described as builders know them (core/config.py, docs/model.md §13):
B and mass per length from the material and cross-section, and ``--elements
auto`` for arms whose attachments are not nodes of the config's mesh."""
from __future__ import annotations

import json
import subprocess
import sys

import pytest

from elastica_petsc.core.config import ConfigError
from elastica_petsc.core.fem import Discretisation, nearest_element_count
from elastica_petsc.core.model import Arm, Tendon, load_config

TENDONS = """
[[tendon]]
attach_mm = 200.0
route_mm = [46.3, -97.1]
[[tendon]]
attach_mm = 600.0
route_mm = [26.1, 51.1]
"""


def config(tmp_path, arm_lines: str):
    path = tmp_path / "arm.toml"
    path.write_text("[arm]\nlength_mm = 600.0\n" + arm_lines + TENDONS)
    return path


def test_bending_stiffness_and_mass_from_the_material(tmp_path):
    arm = load_config(config(tmp_path, "youngs_modulus_Pa = 2.4e9\ndensity_kg_m3 = 1200.0\n"
                                       "width_mm = 40.0\nthickness_mm = 2.5\n"))
    # B = E w h^3 / 12 and m = rho w h, w = 0.040 m, h = 0.0025 m
    assert arm.bending_stiffness_Nm2 == pytest.approx(2.4e9 * 0.040 * 0.0025 ** 3 / 12, rel=1e-14)
    assert arm.mass_per_length_kg_m == pytest.approx(1200.0 * 0.040 * 0.0025, rel=1e-14)
    # the paper's arm given by its B and by an E that makes the same B: the same arm
    paper = load_config()
    E = 0.2 * 12 / (0.040 * 0.003 ** 3)
    same = load_config(config(tmp_path, f"youngs_modulus_Pa = {E!r}\ndensity_kg_m3 = 1200.0\n"
                                        "width_mm = 40.0\nthickness_mm = 3.0\n"))
    assert same.bending_stiffness_Nm2 == pytest.approx(paper.bending_stiffness_Nm2, rel=1e-12)
    assert same.mass_per_length_kg_m == pytest.approx(paper.mass_per_length_kg_m, rel=1e-12)


@pytest.mark.parametrize("lines, message", [
    ("bending_stiffness_Nm2 = 0.2\nyoungs_modulus_Pa = 2.2e9\nwidth_mm = 40.0\n"
     "thickness_mm = 3.0\n", "bending_stiffness_Nm2 = 0.2 disagrees with arm.youngs_modulus_Pa"),
    ("bending_stiffness_Nm2 = 0.2\nmass_per_length_kg_m = 0.2\ndensity_kg_m3 = 1200.0\n"
     "width_mm = 40.0\nthickness_mm = 3.0\n", "mass_per_length_kg_m = 0.2 disagrees"),
    ("youngs_modulus_Pa = 2.2e9\nthickness_mm = 3.0\n", "youngs_modulus_Pa needs arm.width_mm"),
    ("youngs_modulus_Pa = -1.0\nwidth_mm = 40.0\nthickness_mm = 3.0\n", "must be positive"),
    ("width_mm = 40.0\n", "bending_stiffness_Nm2: missing required key"),
])
def test_material_mistakes_are_refused_naming_the_key(tmp_path, lines, message):
    with pytest.raises(ConfigError, match=message):
        load_config(config(tmp_path, lines))


def test_both_forms_that_agree_are_accepted(tmp_path):
    arm = load_config(config(tmp_path, "bending_stiffness_Nm2 = 0.198\nyoungs_modulus_Pa = 2.2e9\n"
                                       "width_mm = 40.0\nthickness_mm = 3.0\n"))
    assert arm.bending_stiffness_Nm2 == 0.198


def test_elements_auto_is_the_nearest_count_with_attachments_on_nodes():
    arm = Arm(600.0, 0.2, (Tendon(200.0, (46.3, -97.1)), Tendon(600.0, (26.1, 51.1))),
              elements=100)
    assert nearest_element_count(arm) == 99          # 101 is not a multiple of 3
    Discretisation.from_arm(arm, 99)
    quarter = Arm(600.0, 0.2, (Tendon(150.0, (46.3, -97.1)),), elements=102)
    assert nearest_element_count(quarter) == 104     # 100 and 104 tie: the finer
    assert nearest_element_count(quarter, 180) == 180


@pytest.mark.slow
def test_cli_elements_auto(tmp_path):
    path = config(tmp_path, "bending_stiffness_Nm2 = 0.2\nelements = 100\n")
    cmd = [sys.executable, "-m", "elastica_petsc.cli", "solve", "--config", str(path),
           "--tensions", "1", "1", "--json"]
    refused = subprocess.run(cmd + ["--elements", "100"], capture_output=True, text=True)
    assert refused.returncode == 2 and "--elements auto" in refused.stderr
    done = subprocess.run(cmd + ["--elements", "auto"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["elements"] == 99
    bad = subprocess.run(cmd + ["--elements", "many"], capture_output=True, text=True)
    assert bad.returncode == 2 and "expected an integer or auto" in bad.stderr
