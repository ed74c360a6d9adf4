"""Guide arc lengths as design variables on mesh nodes (issue 24, docs/model.md
§33): ``design --sweep tendonK.guideJ.s=...`` returns the areas `boundary`
reports for the arms with that guide moved by hand, the area objective's node
search over ``tendon1.guide1.s`` never loses area and ends on a node, and bad
names, missing guides and guides out of order are one-line errors (exit 2)."""
from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
from pathlib import Path

import pytest

from elastica_petsc.core.fem import Discretisation
from elastica_petsc.core.model import load_config
from elastica_petsc.studies.boundary import trace_boundary
from elastica_petsc.core.errors import InputError
from elastica_petsc.studies.design import parse_design_variables
from elastica_petsc.studies.design_area import design_for_area
from elastica_petsc.studies.design_nodes import NodePoint
from elastica_petsc.studies.design_sweep import parse_axis, run_sweep
from elastica_petsc.studies.traced_area import limited

GUIDED = Path(__file__).resolve().parents[1] / "configs" / "guided.toml"
ELEMENTS = 12                 # 25 mm: every guide of the config on a node
P_MAX = 50.0                  # 27.8 N


def moved_by_hand(arm, s_mm):
    """``arm`` with tendon 1's first guide at ``s_mm``, built without design code."""
    t = arm.tendons[0]
    guides = (dataclasses.replace(t.guides[0], s_mm=s_mm),) + t.guides[1:]
    return dataclasses.replace(arm, tendons=(dataclasses.replace(t, guides=guides),
                                             *arm.tendons[1:]))


def boundary_area(arm) -> float:
    arm = limited(arm, P_MAX)
    return trace_boundary(arm, Discretisation.from_arm(arm, ELEMENTS)).areas_mm2["W0"]


def test_sweep_of_a_guide_position_gives_boundarys_areas():
    from mpi4py import MPI

    arm = load_config(GUIDED)
    axis = parse_axis("tendon1.guide1.s=25:75:25", arm.n_tendons)
    assert axis.name == "tendon1.guide1.s" and axis.values == (25.0, 50.0, 75.0)
    sweep = run_sweep(arm, ELEMENTS, [axis], P_MAX, comm=MPI.COMM_SELF, progress=False)
    assert sweep.complete and not any(sweep.values["error"])
    areas = [boundary_area(moved_by_hand(arm, s)) for s in (25.0, 50.0, 75.0)]
    assert len(set(areas)) == 3                       # the guide's position matters
    for got, want in zip(sweep.values["area"], areas):
        assert got == pytest.approx(want, rel=1e-9)


def test_area_design_moves_a_guide_on_nodes_without_losing_area():
    arm = load_config(GUIDED)
    _, points = parse_design_variables(["tendon1.guide1.s"], arm.n_tendons, arm)
    assert points == [NodePoint(0, 0)]
    r = design_for_area(arm, [], P_MAX, elements=ELEMENTS, attaches=points, reach_mm=50.0,
                        resample_cells=None)
    s_after = r.arm_after.tendons[0].guides[0].s_mm
    h = arm.length_mm / ELEMENTS
    assert r.after.area_mm2 >= r.before.area_mm2
    assert abs(s_after / h - round(s_after / h)) < 1e-9 and 0 < s_after < 100.0
    assert r.arm_after.tendons[1] == arm.tendons[1]
    assert r.arm_after.tendons[0].guides[1:] == arm.tendons[0].guides[1:]
    summary = r.summary()
    assert summary["point_variables"] == ["tendon1.guide1.s"]
    assert summary["points_before_mm"] == [50.0] and summary["points_after_mm"] == [s_after]
    assert all("guides_s_mm" in h for h in r.history)
    # every node the search visited kept the guide strictly between 0 and guide 2
    assert all(0 < h["guides_s_mm"][0][0] < 100.0 for h in r.history)


def test_bad_guide_names_and_positions():
    arm = load_config(GUIDED)
    for names, message in ((["tendon1.guide6.s"], "guides 1..5"),
                           (["tendon3.guide1.s"], "tendons 1..2"),
                           (["tendon1.guide1.x"], "tendonK.guideJ.s"),
                           (["tendon1.guide1.s"] * 2, "twice")):
        with pytest.raises(InputError, match=message):
            parse_design_variables(names, arm.n_tendons, arm)
    for axes, message in (("tendon1.guide6.s=25:50:25", "guides 1..5"),
                          ("tendon1.guide1.s=75:100:25", r"\(0, 100\) mm"),
                          ("tendon1.guide5.s=275:300:25", r"\(200, 300\) mm"),
                          ("tendon1.guide1.s=30:30:1", "not on a node")):
        with pytest.raises(InputError, match=message):
            run_sweep(arm, ELEMENTS, [parse_axis(axes, 2)], P_MAX, progress=False)


def test_two_guides_of_one_cable_swept_together_are_ordered_per_design():
    arm = load_config(GUIDED)
    axes = [parse_axis("tendon1.guide1.s=50:75:25", 2), parse_axis("tendon1.guide2.s=75:75:25", 2)]
    sweep = run_sweep(arm, ELEMENTS, axes, P_MAX, progress=False)
    assert sweep.values["error"][0] == b"" and sweep.values["area"][0] > 0
    assert b"one point" in sweep.values["error"][1]          # both guides at 75 mm
    assert sweep.best() == 0


@pytest.mark.parametrize("args, message", [
    (["--sweep", "tendon1.guide6.s=25:50:25"], "tendon 1 has guides 1..5"),
    (["--sweep", "tendon2.guide1.s=0:25:25"], "must lie in (0, 50) mm"),
    (["--sweep", "tendon1.guideX.s=25:50:25"], "expected tendonK.route.x"),
    (["--vary", "tendon2.guide9.s", "--objective", "area"], "tendon 2 has guides 1..5"),
    (["--vary", "tendon1.guide1.s", "--objective", "path:none.csv"], "sit on mesh nodes"),
])
def test_cli_one_line_errors(args, message, tmp_path):
    if "path:none.csv" in args:
        (tmp_path / "none.csv").write_text("x_mm,y_mm\n250,10\n")
    done = subprocess.run([sys.executable, "-m", "elastica_petsc.cli", "design", "--config",
                           str(GUIDED), "--elements", str(ELEMENTS), "--json", *args],
                          cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert done.returncode == 2, done.stderr
    assert message in json.loads(done.stdout)["message"]


def test_cli_area_design_json_matches_the_schema(tmp_path):
    """``--json`` of an area design that varies a guide: the point fields, checked
    against the schema (tests/schema_check.py)."""
    from importlib import resources

    from schema_check import errors

    schema = json.loads((resources.files("elastica_petsc") / "schema" / "output.schema.json")
                        .read_text())
    done = subprocess.run([sys.executable, "-m", "elastica_petsc.cli", "design", "--config",
                           str(GUIDED), "--elements", str(ELEMENTS), "--vary", "tendon1.guide1.s",
                           "--objective", "area", "--tension-max-N", "27.8",
                           "--resample-cells", "4", "--json", "--quiet"],
                          cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert done.returncode in (0, 1), done.stderr
    data = json.loads(done.stdout)
    assert errors(data, schema, schema) == []
    assert data["point_variables"] == ["tendon1.guide1.s"]
    assert data["points_before_mm"] == [50.0] and data["points_after_mm"][0] % 25.0 == 0.0
