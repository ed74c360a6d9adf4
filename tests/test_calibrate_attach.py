"""Attachment arc lengths as calibration parameters (issue 23;
studies/calibrate_attach.py): a node-by-node search around the continuous fit
recovers an attachment moved by two elements, with a profile standard deviation."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from elastica_petsc.core.calibration_params import ParameterModel
from elastica_petsc.core.errors import InputError
from elastica_petsc.core.model import Arm
from elastica_petsc.studies.calibrate_attach import (calibrate_with_attachments,
                                                     split_attach_names, with_attachments)
from elastica_petsc.studies.calibration_synthetic import command_rows, synthesize

ELEMENTS = 30                                  # h = 20 mm on the paper's 600 mm arm
ARM = dataclasses.replace(Arm.paper(), elements=ELEMENTS)


def test_search_recovers_an_attachment_two_elements_away(tmp_path):
    truth_arm = with_attachments(ARM, [0], [240.0])          # s_1 = 200 mm in the config
    rng = np.random.default_rng(3)
    P = np.column_stack((rng.uniform(1, 9, 8), rng.uniform(0.5, 5, 8)))
    vary = ["bending_stiffness"]
    truth = ParameterModel(truth_arm, vary).start() * 1.1
    data = synthesize(truth_arm, vary, truth, command_rows(truth_arm, P, "tension"),
                      noise_mm=0.05, seed=4)
    result = calibrate_with_attachments(ARM, data, ["bending_stiffness", "tendon1.attach"],
                                        elements=ELEMENTS, folds=0)
    found = result.summary()["attachments"][0]
    assert found["name"] == "tendon1.attach" and found["value"] == 240.0
    assert result.arm.tendons[0].attach_mm == 240.0
    assert abs(result.fit.theta[0] - truth[0]) < 3 * result.report["sigma"][0]
    assert found["sigma"] is not None and 0 < found["sigma"] < 20.0   # below one element
    values = dict(found["profile_mm2"])
    assert values[240.0] < values[220.0] and values[240.0] < values[260.0]
    import elastica_petsc as ep                    # the saved result keeps the search
    result.save(tmp_path / "cal.h5")
    back = ep.read(tmp_path / "cal.h5")
    assert back.arm.tendons[0].attach_mm == 240.0
    assert back.summary()["attachments"] == result.summary()["attachments"]


def test_attach_names_are_checked():
    with pytest.raises(InputError, match="vary='tendon3.attach': the arm has tendons 1..2"):
        split_attach_names(["bending_stiffness", "tendon3.attach"], ARM)
    with pytest.raises(InputError, match="name at least one of them too"):
        split_attach_names(["tendon1.attach"], ARM)
    assert split_attach_names(["tendon1.route", "tendon2.attach"], ARM) == (["tendon1.route"],
                                                                            [1])
    assert with_attachments(ARM, [0], [700.0]) is None        # beyond the arm: no valid arm


def test_calibrate_command_searches_an_attachment(tmp_path):
    import json
    import subprocess
    import sys
    from importlib import resources

    from schema_check import errors

    from elastica_petsc.core.calibration_data import write_calibration_csv
    truth_arm = with_attachments(ARM, [0], [220.0])
    rng = np.random.default_rng(5)
    P = np.column_stack((rng.uniform(1, 9, 8), rng.uniform(0.5, 5, 8)))
    data = synthesize(truth_arm, ["tendon1.route"], ParameterModel(
        truth_arm, ["tendon1.route"]).start(), command_rows(truth_arm, P, "tension"))
    write_calibration_csv(tmp_path / "d.csv", data, ["SYNTHETIC: s_1 = 220 mm"])
    run = subprocess.run([sys.executable, "-m", "elastica_petsc.cli", "calibrate",
                          "--elements", str(ELEMENTS), "--data", "d.csv", "--vary",
                          "tendon1.route", "tendon1.attach", "--folds", "0", "--json",
                          "--out", "fit.toml", "--quiet"], cwd=tmp_path, capture_output=True,
                         text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    out = json.loads(run.stdout)
    schema = json.loads((resources.files("elastica_petsc") / "schema" / "output.schema.json")
                        .read_text())
    assert errors(out, schema, schema) == []
    assert out["attachments"][0]["value"] == 220.0
    assert "attach_mm = 220.0" in (tmp_path / "fit.toml").read_text()


SEARCH_UNDER_MPI = """
import dataclasses, json, sys
import numpy as np
from mpi4py import MPI
from elastica_petsc.core.calibration_params import ParameterModel
from elastica_petsc.core.model import Arm
from elastica_petsc.solvers.calibration import RowSolver
from elastica_petsc.studies.calibrate_attach import calibrate_with_attachments, with_attachments
from elastica_petsc.studies.calibration_synthetic import command_rows, synthesize

arm = dataclasses.replace(Arm.paper(), elements=30)
truth_arm = with_attachments(arm, [0], [240.0])
rng = np.random.default_rng(3)
P = np.column_stack((rng.uniform(1, 9, 8), rng.uniform(0.5, 5, 8)))
truth = ParameterModel(truth_arm, ["bending_stiffness"]).start() * 1.1
data = synthesize(truth_arm, ["bending_stiffness"], truth, command_rows(truth_arm, P, "tension"),
                  noise_mm=0.05, seed=4)
solves = [0]
plain = RowSolver.solve
def counted(self, *args, **kwargs):
    solves[0] += 1
    return plain(self, *args, **kwargs)
RowSolver.solve = counted
comm = MPI.COMM_WORLD if MPI.COMM_WORLD.size > 1 else None
result = calibrate_with_attachments(arm, data, ["bending_stiffness", "tendon1.attach"],
                                    elements=30, folds=0, comm=comm)
found = result.summary()["attachments"][0]
print(json.dumps({"rank": MPI.COMM_WORLD.rank, "solves": solves[0], "value": found["value"],
                  "sigma": found["sigma"], "fits": result.attachments.fits,
                  "B": float(result.fit.theta[0])}))
"""


@pytest.mark.mpi
def test_attachment_search_spreads_its_rows_over_two_ranks(tmp_path):
    """Under mpiexec -n 2 every fit of the node-by-node search solves each row on
    one rank only (each rank about half the row solves of one rank), and both
    ranks find the same attachment, profile sigma and fit as one rank."""
    import json
    import shutil
    import subprocess
    import sys

    if shutil.which("mpiexec") is None:
        pytest.skip("needs mpiexec")
    from mpi_env import mpi_env
    env = mpi_env()
    runs = {}
    for ranks in (1, 2):
        launch = ["mpiexec", "-n", "2"] if ranks == 2 else []
        done = subprocess.run(launch + [sys.executable, "-c", SEARCH_UNDER_MPI],
                              capture_output=True, text=True, timeout=300, env=env,
                              cwd=tmp_path)
        assert done.returncode == 0, done.stderr
        runs[ranks] = [json.loads(line) for line in done.stdout.splitlines()]
    one, = runs[1]
    two = runs[2]
    assert sorted(r["rank"] for r in two) == [0, 1]
    assert one["value"] == 240.0 and one["fits"] >= 3
    for r in two:
        assert r["value"] == one["value"] and r["fits"] == one["fits"]
        assert abs(r["sigma"] - one["sigma"]) < 1e-6 * one["sigma"]
        assert abs(r["B"] - one["B"]) < 1e-9 * abs(one["B"])
        assert 0.4 * one["solves"] <= r["solves"] <= 0.6 * one["solves"], (r, one)
    assert sum(r["solves"] for r in two) == pytest.approx(one["solves"], rel=0.1)
