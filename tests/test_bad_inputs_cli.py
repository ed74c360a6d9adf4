"""Issue 21, the command line: each problem of the issue as the command it gives.

Bad input: one line ``elastica-petsc: error: ...``, exit status 2, no traceback,
nothing created, answered before any computing (under 1 s of work in this
process; PETSc's start-up is a subprocess's, timed only where the input is
PETSc's own).  Plus the commands that used to end in a traceback (a --guess
that collapses a cable) or in a JSON crash (numpy integers in the summary).
"""
from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
THREE = ROOT / "configs" / "three_tendon.toml"
PAPER_TENDONS = ("[arm]\nlength_mm = 600.0\nbending_stiffness_Nm2 = 0.2\n"
                 "[[tendon]]\nattach_mm = 200.0\nroute_mm = [46.3, -97.1]\n")


def run_main(args, capsys) -> tuple[int, str, str, float]:
    """The command line in this process: (exit status, stdout, stderr, seconds)."""
    from elastica_petsc.cli import main

    capsys.readouterr()
    t0 = time.perf_counter()
    try:
        status = main([str(a) for a in args])
    except SystemExit as exit:                      # argparse
        status = exit.code
    seconds = time.perf_counter() - t0
    captured = capsys.readouterr()
    return status, captured.out, captured.err, seconds


def refused(args, capsys, *words, seconds: float = 1.0) -> str:
    status, _, err, took = run_main(args, capsys)
    lines = err.strip().splitlines()
    assert status == 2 and len(lines) == 1, (args, status, err[-2000:])
    assert lines[0].startswith("elastica-petsc: error:"), lines[0]
    for word in words:
        assert word in lines[0], (word, lines[0])
    assert took < seconds, f"{args}: {took:.2f} s before the refusal"
    return lines[0]


def bad_inputs(tmp: Path) -> list[tuple[list, list[str]]]:
    same = tmp / "same.toml"
    same.write_text(PAPER_TENDONS + "[[tendon]]\nattach_mm = 200.0\nroute_mm = [46.3, -97.1]\n")
    rows = tmp / "rows.csv"
    rows.write_text("x_mm,y_mm\n" + "".join(f"{400 + i * 1e-4},200\n" for i in range(200_000)))
    names = tmp / "names.csv"
    names.write_text("x,y_mm\n400,200\n")
    ws = ["workspace", "--elements", 30, "--out", tmp / "w.h5"]
    return [
        (["boundary", "--config", same, "--elements", 30], ["tendon[2]", "same as tendon[1]"]),
        (["trace", "--path", names, "--step", 5], ["header", "unknown: x"]),
        (["control", "--target", 500, 100, "--animate", "/proc/x.gif"], ["cannot write"]),
        (["control", "--target", 500, 100, "--animate", tmp / "no" / "x.gif"],
         ["no such directory"]),
        (["control", "--target", 500, 100, "--vtk", ""], ["--vtk", "empty"]),
        (["solve", "--tensions", 1, 1, "--vtk", ""], ["--vtk", "empty"]),
        (["solve", "--tensions", 1, 1, "--vtk", "/proc/vtkdir"], ["cannot write"]),
        (["trace", "--shape", "paper-triangle", "--animate", "/proc/x.gif"], ["cannot write"]),
        (ws + ["--vtk", ""], ["--vtk", "empty"]),
        (["solve", "--tensions", 1, 1, "--elements", 3_000_000],
         ["--elements", "ELASTICA_PETSC_MAX_ELEMENTS"]),
        (["stability", "--tensions", 1, 1, "--elements", 3_000_000],
         ["--elements", "ELASTICA_PETSC_MAX_ELEMENTS"]),
        (["solve", "--tensions", 1, 1, "--elements", 9_999_999], ["--elements"]),
        (["control", "--target", 500, 100, "--elements", 9_999_999], ["--elements"]),
        (["design", "--vary", "tendon1.route", "--objective", f"path:{rows}"],
         ["more than 2,000 targets", "ELASTICA_PETSC_MAX_DESIGN_POINTS"]),
        (["solve", "--tensions", 1, "1e400"], ["--tensions", "finite"]),
        (["solve", "--tensions-N", 1, -1], ["--tensions-N", "-1 N"]),
        (["stability", "--tensions", 1, 1, "--modes", 0], ["--modes", "at least 1"]),
        (["lengths", "--lengths", 1e300, 472], ["--lengths", "cable 1"]),
        (["reproduce", "--quick", "--aluminium-config", tmp / "missing.toml", "--out",
          tmp / "rep"], ["missing.toml"]),
        (["reproduce", "--quick", "--config", tmp / "missing.toml", "--out", tmp / "rep2"],
         ["missing.toml"]),
        # found by scripts/studies/bad_inputs_study.py (tracebacks, or minutes of work, before)
        (["control", "--target", 500, 100, "--tol-mm", 1e300], ["--tol-mm", "at most 600"]),
        (["equilibria", "--tensions", 1e300, 5], ["--tensions", "exceeds"]),
        (["lengths", "--lengths", 147.1, 472.5, "--effort", 99999999], ["--effort", "<= 16"]),
        (ws + ["--spacing", 1e-300], ["--spacing", "at least"]),
        (ws + ["--spacing", 1e-9], ["--spacing", "samples"]),
        (ws + ["--mode", "tensions", "--tension-max", 1e300], ["--tension-max", "exceeds"]),
        (["trace", "--shape", "circle", "--center", 1e300, 200], ["the path", "arm lengths"]),
        (["trace", "--shape", "circle", "--center", 400, 200, "--radius", 1e300],
         ["the path", "arm lengths"]),
        (["design", "--vary", "tendon1.route", "--objective", "area", "--tension-max-N",
          1e-300], ["--tension-max"]),
        (["design", "--vary", "tendon1.route", "--objective", "area", "--margin", "nan"],
         ["--margin"]),
    ]


def test_bad_inputs_one_line_before_any_work_nothing_created(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    run_main(["solve", "--tensions", 1], capsys)    # start-up (PETSc, imports): not timed
    cases = bad_inputs(tmp_path)
    before = sorted(p.name for p in tmp_path.iterdir())
    failures = []
    for args, words in cases:
        try:
            refused(args, capsys, *words)
        except AssertionError as err:
            failures.append(f"{' '.join(map(str, args))}: {err}")
    assert not failures, "\n".join(failures)
    assert sorted(p.name for p in tmp_path.iterdir()) == before     # no --out folder, no file


def test_missing_petsc_options_file_is_one_line(tmp_path):
    """PETSc opens -options_file in its own initialisation: a missing one was its error
    stack and a traceback."""
    run = subprocess.run([sys.executable, "-m", "elastica_petsc.cli", "solve", "--tensions",
                          "1", "1", "-options_file", "missing.opts"], cwd=tmp_path,
                         capture_output=True, text=True, timeout=60)
    assert run.returncode == 2, run.stderr
    assert run.stderr.strip().splitlines() == [
        "elastica-petsc: error: -options_file missing.opts: no such readable file"]


@pytest.mark.parametrize("guess", [(80, 0), (90, 0), (100, 100), (0, 110)])
def test_a_guess_that_collapses_a_cable_is_a_failed_start(guess, capsys):
    """`control --target 535.8 222.6 --guess-N 80 0` (all below the 112.9 N motor limit):
    no equilibrium exists at the guess (tendon 1 collapses onto its routing point); the
    search goes on from the straight arm and reaches the target."""
    status, out, err, _ = run_main(["control", "--target", 535.8, 222.6, "--guess-N", *guess,
                                    "--json"], capsys)
    assert status == 0, err[-2000:]
    data = json.loads(out)
    assert data["converged"] and data["tip_error_mm"] < 1e-5
    assert "straight arm" in data["strategy"] and "Traceback" not in err


@pytest.mark.parametrize("share", ["min-norm", "min-energy"])
@pytest.mark.parametrize("floor_N", [0, 1])
def test_control_json_with_a_tension_on_its_bound(share, floor_N, capsys):
    """`control --share ... --json` on configs/three_tendon.toml: tendon 2 sits on its
    bound (its index an int64) and the JSON is written, equal to the text output."""
    args = ["control", "--target", 450, 250, "--share", share, "--min-tension-N", floor_N,
            "--config", THREE]
    status, out, err, _ = run_main(args + ["--json"], capsys)
    assert status == 0, err[-2000:]
    data = json.loads(out)
    assert data["on_bound"] == [{"tendon": 2, "bound": "lower"}]
    assert data["tensions_N"][1] == pytest.approx(floor_N, abs=1e-6)
    status, text, _, _ = run_main(args, capsys)
    assert status == 0 and f"{data['tensions_N'][0]:.4f}" in text


def test_the_json_encoder_takes_numpy_values():
    import numpy as np

    from elastica_petsc.core import jsontext

    data = {"i": np.int64(2), "f": np.float32(0.5), "b": np.bool_(True),
            "a": np.arange(3), "nested": [{"k": np.int32(-1)}]}
    assert json.loads(jsontext.dumps(data)) == {"i": 2, "f": 0.5, "b": True, "a": [0, 1, 2],
                                                "nested": [{"k": -1}]}
    with pytest.raises(TypeError, match="object"):
        jsontext.dumps({"x": object()})


T3 = ["--config", THREE, "--elements", 30]


@pytest.mark.parametrize("command", [
    ["solve", "--tensions-N", 5, 0, 5, *T3],
    ["stability", "--tensions-N", 5, 0, 5, *T3],
    ["trace", "--shape", "line", "--center", 450, 250, "--end", 455, 250, "--step", 5,
     "--share", "min-norm", "--min-tension-N", 1, "--per-point", *T3],
    ["lengths", "--lengths", 120, 320, 460, *T3],          # tendon 3 slack: P_3 = 0
    ["workspace", "--box", 400, 480, 200, 260, "--spacing", 40, "--share", "min-energy",
     "--min-tension-N", 1, *T3, "--out", "w.h5"],
    ["boundary", "--elements", 30],
], ids=lambda c: c[0])
def test_every_command_json_with_three_tendons_and_a_tension_on_a_bound(command, tmp_path,
                                                                        monkeypatch, capsys):
    """--json of every command that computes (control: above) is valid JSON with 3
    tendons (2 for boundary, which needs two) and a tension on a bound."""
    monkeypatch.chdir(tmp_path)
    status, out, err, _ = run_main(command + ["--json"], capsys)
    assert status == 0, err[-2000:]
    assert isinstance(json.loads(out), dict)
