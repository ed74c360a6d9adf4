"""The commands on a continuum robot with cables through guides and on the paper's
arm in a vertical plane (issue 24; docs/model.md §11), through the library API on
coarse meshes: tip control, a closed traced circle that closes in cable space (whole
path lengths), stability, length control, the W_0 boundary (closed loop) and a
sampled point inside and outside it."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from elastica_petsc import api
from elastica_petsc.core.model import load_config

CONFIGS = Path(__file__).resolve().parents[1] / "configs"


@pytest.fixture(scope="module")
def robot():
    """configs/guided3.toml on 40 elements (guides every 37.5 / 75 mm on nodes)."""
    return load_config(CONFIGS / "guided3.toml")


def test_control_trace_and_lengths_of_a_guided_robot(robot):
    result = api.control(robot, [240.0, 100.0], elements=40)
    assert result.converged and result.equilibrium.stable
    assert np.linalg.norm(result.tip_mm - [240.0, 100.0]) < 1e-5
    # the cable lengths are the whole paths, longer than the straight chords
    eq = result.equilibrium
    chord = np.linalg.norm(robot.routes() - eq.attachments, axis=1) * robot.length_mm
    assert np.all(result.cable_lengths_mm > chord)
    a = np.linspace(0.0, 2.0 * np.pi, 25)
    circle = np.column_stack((225.0 + 8.0 * np.cos(a), 140.0 + 8.0 * np.sin(a)))
    traced = api.trace(robot, circle, step_mm=2.0, elements=40)
    lengths = traced.cable_lengths_mm
    assert traced.all_converged
    assert np.max(np.abs(lengths[-1] - lengths[0])) < 1e-5         # closes in cable space
    # length control at the reached lengths finds the same state
    state = api.lengths(robot, result.cable_lengths_mm, elements=40)
    assert state.converged
    assert np.allclose(state.cable_lengths_mm, result.cable_lengths_mm, atol=1e-7)
    assert np.allclose(state.tip_mm, result.tip_mm, atol=1e-5)


def test_boundary_of_guided_robot_and_vertical_paper_arm(robot):
    for arm, elements in ((robot, 40), (load_config(CONFIGS / "paper_vertical.toml"), 60)):
        result = api.boundary(arm, restricted=False, elements=elements)
        assert not any("did not close" in m for m in result.messages), result.messages
        assert result.areas_mm2["W0"] > 0
    # the paper's arm in a vertical plane sags at rest, stably
    vertical = load_config(CONFIGS / "paper_vertical.toml")
    rest = api.solve(vertical, [0.0, 0.0], elements=60)
    assert rest.equilibrium.tip[1] < -0.1                           # it sags
    assert rest.equilibrium.stable


def test_tension_sharing_with_three_guided_cables(robot):
    """A third cable through guides on the right to the tip: the tensions that reach a
    target form a family; min-norm sharing picks one of smaller norm.  (Cable 3, slack
    at the unshared state, cuts through the curled arm between its sparse guides:
    cables="ignore" keeps the search local.)"""
    import dataclasses
    from elastica_petsc.core.model import Guide, Tendon
    third = Tendon(300.0, (0.0, -8.0), attach_offset_mm=-8.0,
                   guides=tuple(Guide(s, -8.0) for s in (75.0, 150.0, 225.0)))
    arm = dataclasses.replace(robot, tendons=robot.tendons + (third,))
    plain = api.control(arm, [240.0, 100.0], elements=40, guess=[20.0, 10.0, 5.0],
                        global_search=False, cables="ignore")
    shared = api.control(arm, [240.0, 100.0], elements=40, guess=[20.0, 10.0, 5.0],
                         global_search=False, cables="ignore", share="min-norm")
    assert plain.converged and shared.converged
    assert np.linalg.norm(shared.tip_mm - [240.0, 100.0]) < 1e-5
    assert np.linalg.norm(shared.tensions_N) <= np.linalg.norm(plain.tensions_N) + 1e-9


def test_vtk_draws_each_cable_through_its_guides(robot, tmp_path):
    from elastica_petsc.io.vtk import write_state
    state = api.solve(robot, [20.0, 10.0], elements=40)
    path = write_state(tmp_path / "s.vtu", robot, state.equilibrium)
    text = path.read_text()
    # 41 nodes + (route + 3 guides + end) per cable; 40 elements + 4 segments per cable
    assert 'NumberOfPoints="51"' in text and 'NumberOfCells="48"' in text
