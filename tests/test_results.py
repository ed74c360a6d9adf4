"""Results are the public surface (issue 20): every result type is exported,
frozen, printed in one line, summarised as a dict, and ``ep.read(x.save(path))``
equals ``x`` field by field.  The tests that build every result (about a
minute on a loaded host) are marked slow: ``scripts/test.sh --fast`` leaves them out."""
from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

import elastica_petsc as ep
from elastica_petsc.core.loading import Loading

ELEMENTS = 30          # a coarse mesh (the paper's attachments are on its nodes): fast


@pytest.fixture(scope="module")
def results():
    """One result of every public type, on the paper's arm (about 15 s in all)."""
    arm = ep.Arm.paper()
    state = ep.solve(arm, tensions_N=[14.0, 6.0], order=(2, 1), elements=ELEMENTS)
    return {
        "State": state,
        "Equilibrium": state.equilibrium,
        "ControlResult": ep.control(arm, [535.8, 222.6], elements=ELEMENTS),
        "Stability": ep.stability(state),
        "Frequencies": ep.frequencies(state),
        "LengthEquilibrium": ep.lengths(arm, [150, 470], elements=ELEMENTS),
        "TraceResult": ep.trace(arm, [[500, 250], [480, 260]], elements=ELEMENTS),
        "TracedSchedule": ep.schedule(arm, [[500, 250], [490, 255]], step_mm=10,
                                      elements=ELEMENTS),
        "WorkspaceMap": ep.workspace(arm, spacing_mm=150, elements=ELEMENTS),
        "SearchResult": ep.equilibria(arm, tensions_N=[14.0, 6.0], elements=ELEMENTS),
        "BoundaryResult": ep.boundary(arm, elements=ELEMENTS),
        "Sweep": ep.design_sweep(arm, ["tendon2.route.x=20:30:10"], elements=ELEMENTS),
        "DesignResult": ep.design(arm, [[500, 250], [480, 260]], elements=ELEMENTS),
        "AreaDesign": ep.design_area(arm, iterations=1, resample_cells=None,
                                     elements=ELEMENTS),
        "SimulationResult": ep.simulate(arm, initial_tensions_N=[0.0, 0.05],
                                        tensions_N=[0.0, 0.0], duration_s=0.05,
                                        elements=ELEMENTS),
        "CalibrationResult": ep.calibrate(arm, calibration_data(arm), ["tendon1.route"],
                                          folds=2, elements=ELEMENTS),
    }


def calibration_data(arm):
    """Six synthetic rows of the paper arm with tendon 1's routing point moved 3 mm."""
    from elastica_petsc.core.calibration_params import ParameterModel
    from elastica_petsc.studies.calibration_synthetic import command_rows, synthesize

    arm = dataclasses.replace(arm, elements=ELEMENTS)
    P = np.column_stack((np.linspace(1, 9, 6), np.linspace(5, 0.5, 6)))
    truth = ParameterModel(arm, ["tendon1.route"]).start() + [3.0, -2.0]
    return synthesize(arm, ["tendon1.route"], truth, command_rows(arm, P, "tension"),
                      noise_mm=0.2, seed=1, marker_s_mm=(300.0,))


def assert_same(a, b, where: str = "result") -> None:
    """``a`` and ``b`` equal field by field (arrays bitwise, NaN equal to NaN)."""
    assert type(a) is type(b), f"{where}: {type(a).__name__} != {type(b).__name__}"
    if dataclasses.is_dataclass(a):
        for field in dataclasses.fields(a):
            if field.name.startswith("_"):
                continue                                   # a cache, not a value
            x, y = getattr(a, field.name), getattr(b, field.name)
            if not field.repr and y is None and x is not None and not isinstance(
                    x, (np.ndarray, list, tuple, dict, str, float, int)):
                continue                                   # a live solver object (records.py)
            assert_same(x, y, f"{where}.{field.name}")
    elif isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and a.shape == b.shape, where
        assert np.array_equal(a, b, equal_nan=a.dtype.kind in "fc"), where
    elif isinstance(a, (list, tuple)):
        assert len(a) == len(b), where
        for k, (x, y) in enumerate(zip(a, b)):
            assert_same(x, y, f"{where}[{k}]")
    elif isinstance(a, dict):
        assert list(a) == list(b), where
        for key in a:
            assert_same(a[key], b[key], f"{where}[{key!r}]")
    elif isinstance(a, Loading):
        assert np.array_equal(a.vertices(), b.vertices()), where
    elif isinstance(a, float) and np.isnan(a):
        assert np.isnan(b), where
    else:
        assert a == b, f"{where}: {a!r} != {b!r}"


@pytest.mark.slow
def test_every_result_type_is_exported(results):
    for name in results:
        assert name in ep.__all__ and getattr(ep, name) is type(results[name])


@pytest.mark.parametrize("name", ["State", "Equilibrium", "ControlResult", "Stability",
                                  "Frequencies", "LengthEquilibrium", "TraceResult",
                                  "TracedSchedule", "WorkspaceMap", "SearchResult",
                                  "BoundaryResult", "Sweep", "DesignResult", "AreaDesign",
                                  "SimulationResult", "CalibrationResult"])
@pytest.mark.slow
def test_read_of_save_is_the_same_result(results, name, tmp_path):
    result = results[name]
    path = result.save(tmp_path / f"{name}.h5")
    back = ep.read(path)
    assert_same(result, back, name)
    assert json.dumps(back.summary()) == json.dumps(result.summary())


@pytest.mark.slow
def test_results_are_frozen_short_and_summarised(results):
    for name, result in results.items():
        field = dataclasses.fields(result)[0].name
        with pytest.raises(dataclasses.FrozenInstanceError):
            setattr(result, field, None)
        text = repr(result)
        assert "\n" not in text and len(text) < 400 and text.startswith(name + "("), name
        summary = result.summary()
        assert isinstance(summary, dict) and summary, name
        json.dumps(summary)                                # JSON-ready


@pytest.mark.slow
def test_print_state_does_not_dump_arrays(results, capsys):
    print(results["State"])
    out = capsys.readouterr().out
    assert out.count("\n") == 1 and "array(" not in out and "[" not in out


@pytest.mark.slow
def test_saved_state_keeps_the_command_line_layout(results, tmp_path):
    """``State.save`` writes the layout of ``solve --out`` (read by the CLI's readers)."""
    from elastica_petsc.io.reader import equilibrium_from_group, open_h5

    state = results["State"]
    with open_h5(state.save(tmp_path / "s.h5")) as fh:
        assert fh.attrs["kind"] == "equilibrium" and fh["state/x"].attrs["units"] == "mm"
        eq = equilibrium_from_group(fh, state.arm)
    np.testing.assert_allclose(eq.u, state.equilibrium.u, rtol=0, atol=1e-12)


@pytest.mark.slow
def test_save_refuses_an_existing_file_unless_asked(results, tmp_path):
    path = results["Stability"].save(tmp_path / "s.h5")
    with pytest.raises(ep.InputError):
        results["Stability"].save(path)
    results["Stability"].save(path, overwrite=True)


def test_error_hierarchy():
    from elastica_petsc.core.fem import DiscretisationError
    from elastica_petsc.solvers.continuation import ContinuationError
    from elastica_petsc.solvers.stability import StabilityError

    assert issubclass(ep.InputError, ep.ElasticaError) and issubclass(ep.InputError, ValueError)
    assert issubclass(ep.SolverError, ep.ElasticaError)
    assert issubclass(ep.SolverError, RuntimeError)
    assert issubclass(DiscretisationError, ep.InputError)
    assert issubclass(StabilityError, ep.SolverError)
    assert issubclass(ContinuationError, ep.SolverError)


@pytest.mark.slow
def test_to_vtk_writes_what_the_cli_writes(results, tmp_path):
    """``State.to_vtk`` (``solve --vtk``) and ``WorkspaceMap.to_vtk`` (``workspace
    --vtk``, from the map's file); a map without a file says how to get one."""
    import xml.etree.ElementTree as ET

    (vtu,) = results["State"].to_vtk(tmp_path / "s")
    piece = ET.parse(vtu).getroot().find("UnstructuredGrid/Piece")
    assert int(piece.get("NumberOfPoints")) == ELEMENTS + 1 + 2      # nodes and routing points
    with pytest.raises(ep.InputError, match="out="):
        results["WorkspaceMap"].to_vtk(tmp_path / "w")
    arm = ep.Arm.paper()
    wmap = ep.workspace(arm, spacing_mm=200, elements=ELEMENTS, out=tmp_path / "w.h5")
    piece = ET.parse(wmap.to_vtk(tmp_path / "w")).getroot().find("UnstructuredGrid/Piece")
    assert int(piece.get("NumberOfPoints")) == len(wmap.status)


@pytest.mark.slow
def test_cli_control_and_trace_files_read_back_as_their_results(tmp_path):
    """``control --out`` and ``trace --out`` files hold the whole result: ep.read
    returns a ControlResult (target, history kept) and a TracedSchedule."""
    import subprocess
    import sys

    cli = [sys.executable, "-m", "elastica_petsc.cli"]
    subprocess.run(cli + ["control", "--target", "535.8", "222.6", "--elements", "30",
                          "--out", str(tmp_path / "c.h5")], check=True, capture_output=True)
    subprocess.run(cli + ["trace", "--shape", "line", "--center", "500", "250", "--end", "480",
                          "260", "--step", "10",
                          "--elements", "30", "--out", str(tmp_path / "t.h5")],
                   check=True, capture_output=True)
    control = ep.read(tmp_path / "c.h5")
    assert isinstance(control, ep.ControlResult) and control.converged
    np.testing.assert_allclose(control.target_mm, [535.8, 222.6], atol=1e-9)
    assert len(control.history_E) == control.iterations + 1
    planned = ep.read(tmp_path / "t.h5")
    assert isinstance(planned, ep.TracedSchedule) and planned.path.all_converged
    assert control.arm == planned.arm == ep.Arm.paper()          # the config the CLI loaded


@pytest.mark.slow
def test_cli_boundary_file_reads_back_as_the_result(tmp_path):
    import subprocess
    import sys

    subprocess.run([sys.executable, "-m", "elastica_petsc.cli", "boundary", "--no-restricted",
                    "--elements", "30", "--out", str(tmp_path / "b.h5")], check=True,
                   capture_output=True)
    back = ep.read(tmp_path / "b.h5")
    direct = ep.boundary(ep.Arm.paper(), restricted=False, elements=ELEMENTS)
    assert isinstance(back, ep.BoundaryResult)
    np.testing.assert_array_equal(back.polygons_mm["W0"][0], direct.polygons_mm["W0"][0])
    assert back.areas_mm2 == direct.areas_mm2


@pytest.mark.slow
def test_simulate_and_calibrate_files_read_back_as_their_results(results, tmp_path):
    """``simulate --out`` and ``calibrate --h5`` files (their writers) hold the whole
    result: ep.read returns a SimulationResult / CalibrationResult, not a dict."""
    from elastica_petsc.io.calibration import write_calibration_h5
    from elastica_petsc.io.simulation import write_simulation

    write_simulation(tmp_path / "s.h5", False, results["SimulationResult"])
    write_calibration_h5(tmp_path / "c.h5", results["CalibrationResult"])
    assert_same(results["SimulationResult"], ep.read(tmp_path / "s.h5"), "simulate --out")
    assert_same(results["CalibrationResult"], ep.read(tmp_path / "c.h5"), "calibrate --h5")


@pytest.mark.parametrize("name", ["ControlResult", "TraceResult", "TracedSchedule",
                                  "SearchResult"])
@pytest.mark.slow
def test_saved_control_and_trace_results_carry_their_arm(results, name, tmp_path):
    """Their files have the arm's config (provenance ``config_json``, as every
    writer stores it) and ep.read gives the arm back."""
    from elastica_petsc.io.reader import file_arm, open_h5

    path = results[name].save(tmp_path / f"{name}.h5")
    with open_h5(path) as fh:
        assert file_arm(fh) == ep.Arm.paper()
    assert ep.read(path).arm == ep.Arm.paper()


@pytest.mark.slow
def test_control_and_trace_results_write_vtk(results, tmp_path):
    """``to_vtk`` as ``control --vtk`` and ``trace --vtk`` write it."""
    import xml.etree.ElementTree as ET

    (vtu,) = results["ControlResult"].to_vtk(tmp_path / "c")
    assert vtu.name == "control.vtu"
    with pytest.raises(ep.InputError, match="keep_results=True"):
        results["TraceResult"].to_vtk(tmp_path / "t")
    planned = results["TracedSchedule"]
    files = planned.path.to_vtk(tmp_path / "t")
    assert [f.name for f in files[-2:]] == ["trace.pvd", "trace_path.vtu"]
    assert len(files) == planned.path.n_points + 2
    piece = ET.parse(files[-1]).getroot().find("UnstructuredGrid/Piece")
    assert int(piece.get("NumberOfPoints")) == planned.path.n_points
    files = planned.to_vtk(tmp_path / "s")
    approach = planned.approach.n_points if planned.approach is not None else 0
    assert len(files) == approach + planned.path.n_points + 2
    import dataclasses as dc
    with pytest.raises(ep.InputError, match="no arm"):
        dc.replace(results["ControlResult"], arm=None).to_vtk(tmp_path / "x")
