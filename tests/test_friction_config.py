"""``[[tendon]] friction_coefficient`` (docs/model.md §27): read, written back, checked;
used by the friction path, refused by every study that models frictionless guides."""
from __future__ import annotations

import numpy as np
import pytest

import elastica_petsc as ep
from elastica_petsc.core.config import arm_to_dict
from elastica_petsc.core.model import ModelError, Tendon, arm_from_dict, load_config
from conftest import REPO

FRICTION = REPO / "configs" / "guided3_friction.toml"


@pytest.fixture(scope="module")
def arm():
    return load_config(FRICTION)


def test_read_and_written_back(arm):
    assert [t.friction_coefficient for t in arm.tendons] == [0.3, 0.0]
    data = arm_to_dict(arm)
    assert data["tendon"][0]["friction_coefficient"] == 0.3
    assert "friction_coefficient" not in data["tendon"][1]          # the default is left out
    assert arm_from_dict(data) == arm
    assert "friction_coefficient" not in str(arm_to_dict(load_config(REPO / "configs" /
                                                                     "guided3.toml")))


def test_bad_coefficients_are_refused(arm):
    with pytest.raises(ModelError, match=r"tendon\[1\].friction_coefficient must be a number >= 0"):
        ep.Arm(length_mm=300.0, bending_stiffness_Nm2=0.05, guide_radius_mm=10.0,
               tendons=(Tendon(300.0, (0.0, 8.0), 8.0, arm.tendons[0].guides, -0.1),))
    with pytest.raises(ModelError, match="no guides to rub on"):
        ep.Arm(length_mm=300.0, bending_stiffness_Nm2=0.05,
               tendons=(Tendon(300.0, (0.0, 8.0), friction_coefficient=0.2),))


def test_friction_path_uses_the_config_and_other_studies_refuse_it(arm, tmp_path):
    history = [[0.0, 0.0], [11.0, 0.0], [22.0, 0.0], [11.0, 0.0]]
    from_config = ep.friction_path(arm, history, elements=48)
    given = ep.friction_path(ep.Arm.from_toml(REPO / "configs" / "guided3.toml"), history,
                             mu=[0.3, 0.3, 0.3, 0.0, 0.0, 0.0], elements=48)
    np.testing.assert_array_equal(from_config.path.mu, [0.3, 0.3, 0.3, 0.0, 0.0, 0.0])
    np.testing.assert_array_equal(from_config.tip_mm, given.tip_mm)
    back = ep.read(from_config.save(tmp_path / "f.h5"))            # saved and read back exactly
    assert isinstance(back, ep.FrictionResult) and back.arm == arm
    for name in ("states", "tensions", "modes", "wrap", "mu"):
        np.testing.assert_array_equal(getattr(back.path, name), getattr(from_config.path, name))
    assert back.summary() == from_config.summary()
    for study in (lambda: ep.solve(arm, [1.0, 1.0], elements=48),
                  lambda: ep.control(arm, [250.0, 100.0], elements=48),
                  lambda: ep.workspace(arm, spacing_mm=100.0, elements=48),
                  lambda: ep.simulate(arm, tensions_N=[1.0, 1.0], duration_s=0.01,
                                      elements=48)):
        with pytest.raises(ep.InputError, match="models frictionless guides"):
            study()
