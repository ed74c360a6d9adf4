"""Issue 21: every bad input to the library raises ``ep.InputError`` at once, with
the library's argument name (not a command-line flag) and the user's unit.

The checks are those of the command line (core/inputs.py, one copy): the
command-line cases of the same inputs are in tests/test_bad_inputs_cli.py.
"""
from __future__ import annotations

import time

import numpy as np
import pytest

import elastica_petsc as ep

ARM = ep.Arm.paper()
E = 30                                  # a coarse mesh with the paper's attachments on nodes


@pytest.fixture(scope="module")
def state():
    return ep.solve(ARM, [1.0, 1.0], elements=E)


def arm_with(**kw):
    args = dict(length_mm=600.0, bending_stiffness_Nm2=0.2,
                tendons=(ep.Tendon(200.0, (46.3, -97.1)), ep.Tendon(600.0, (26.1, 51.1))))
    args.update(kw)
    return ep.Arm(**args)


def cases(state, tmp):
    """(call, words of the message): the issue's 30 and more of our own."""
    tri = [[300.0, 100.0], [310.0, 100.0]]
    return [
        # the issue's
        (lambda: ep.lengths(ARM, [1e300, 472], elements=E), ["lengths_mm", "cable 1"]),
        (lambda: ep.control(ARM, [1e300, 0], elements=E), ["target_mm", "arm lengths"]),
        (lambda: ep.stability(state, modes=0), ["modes", "at least 1"]),
        (lambda: ep.stability(state, modes=2.5), ["modes", "whole number"]),
        (lambda: ep.trace(ARM, tri, step_mm=1e-12, elements=E), ["step_mm", "targets"]),
        (lambda: ep.workspace(ARM, box_mm=[1, 2], elements=E), ["box_mm", "4 numbers"]),
        (lambda: arm_with(tendons=[{"attach_mm": 600.0, "route_mm": (26.1, 51.1)}]),
         ["tendon[1]", "ep.Tendon"]),
        (lambda: ep.solve(ARM, ["1", "2"], elements=E), ["tensions_N", "numbers in N", "'1'"]),
        (lambda: ep.solve(ARM, tensions=["1", "2"], elements=E), ["tensions", "'1'"]),
        (lambda: ep.workspace(ARM, out=tmp / "x.txt", spacing_mm=200, elements=E),
         ["out", "unknown extension"]),
        (lambda: arm_with(length_mm=0.4, tendons=(ep.Tendon(0.2, (0.0, 0.05)),)),
         ["length_mm", "millimetres"]),
        # our own
        (lambda: ep.solve(ARM, [1.0, -2.0], elements=E), ["tensions_N", "-2 N", "push"]),
        (lambda: ep.solve(ARM, [1.0, True], elements=E), ["tensions_N", "True"]),
        (lambda: ep.solve(ARM, [1.0, None], elements=E), ["tensions_N", "None"]),
        (lambda: ep.solve(ARM, [1.0], elements=E), ["tensions_N", "expected 2 tensions"]),
        (lambda: ep.solve(ARM, [1.0, float("inf")], elements=E), ["tensions_N", "finite"]),
        (lambda: ep.solve(ARM, [1.0, 1.0], elements=1), ["elements", "at least 2"]),
        (lambda: ep.solve(ARM, [1.0, 1.0], elements=30.0), ["elements", "whole number"]),
        (lambda: ep.solve(ARM, [1.0, 1.0], elements=3_000_000), ["elements", "at most",
                                                                 "ELASTICA_PETSC_MAX_ELEMENTS"]),
        (lambda: ep.solve("paper", [1.0, 1.0]), ["arm", "ep.Arm"]),
        (lambda: ep.stability(state, modes=E + 1), ["modes", f"at most {E}"]),
        (lambda: ep.stability("state"), ["state", "ep.State"]),
        (lambda: ep.frequencies(state, modes=0), ["modes"]),
        (lambda: ep.frequencies(state, control="speed"), ["control", "'speed'"]),
        (lambda: ep.control(ARM, [500.0], elements=E), ["target_mm", "expected 2"]),
        (lambda: ep.control(ARM, ["500", 0], elements=E), ["target_mm", "'500'"]),
        (lambda: ep.control(ARM, [500, 0], guess_N=[-1, 0], elements=E), ["guess_N", "N"]),
        (lambda: ep.control(ARM, [500, 0], guess=[1], elements=E), ["guess", "2 tensions"]),
        (lambda: ep.control(ARM, [500, 0], tol_mm=0, elements=E), ["tol_mm", "positive"]),
        (lambda: ep.control(ARM, [500, 0], min_tension_N=-1, elements=E), ["min_tension_N"]),
        (lambda: ep.control(ARM, [500, 0], animate=tmp / "a.avi", elements=E), [".gif"]),
        (lambda: ep.lengths(ARM, [147.1], elements=E), ["lengths_mm", "expected 2"]),
        (lambda: ep.lengths(ARM, [0, 472], elements=E), ["lengths_mm", "positive"]),
        (lambda: ep.lengths(ARM, [147.1, "472"], elements=E), ["lengths_mm", "'472'"]),
        (lambda: ep.trace(ARM, [[1, 2, 3]], elements=E), ["points_mm", "shape"]),
        (lambda: ep.trace(ARM, [[1, "a"]], elements=E), ["points_mm", "'a'"]),
        (lambda: ep.trace(ARM, tri, step_mm=-1, elements=E), ["step_mm", "positive"]),
        (lambda: ep.schedule(ARM, tri, step_mm=0, elements=E), ["step_mm", "positive"]),
        (lambda: ep.schedule(ARM, tri, speed_mm_s=-1, elements=E), ["speed_mm_s"]),
        (lambda: ep.workspace(ARM, box_mm=[0, 100, 50, 10], elements=E), ["box_mm", "ymin"]),
        (lambda: ep.workspace(ARM, spacing_mm="5", elements=E), ["spacing_mm", "'5'"]),
        (lambda: ep.workspace(ARM, spacing_mm=0, elements=E), ["spacing_mm", "at least"]),
        (lambda: ep.equilibria(ARM, ["a", 1], elements=E), ["tensions_N"]),
        (lambda: ep.design(ARM, np.zeros((3000, 2)), elements=E),
         ["points_mm", "more than 2,000", "ELASTICA_PETSC_MAX_DESIGN_POINTS"]),
        (lambda: ep.design_area(ARM, tension_max_N=0, elements=E), ["tension_max_N"]),
        (lambda: ep.design_area(ARM, iterations=0.5, elements=E), ["iterations"]),
        (lambda: arm_with(tendons=(ep.Tendon(600.0, (26.1, 51.1)),
                                   ep.Tendon(600.0, (26.1, 51.1)))),
         ["tendon[2]", "same as tendon[1]"]),
    ]


def test_every_bad_library_input_is_one_input_error_at_once(state, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    failures = []
    for k, (call, words) in enumerate(cases(state, tmp_path)):
        t0 = time.perf_counter()
        try:
            call()
            failures.append(f"case {k}: accepted")
            continue
        except ep.InputError as err:
            text = str(err)
        except Exception as err:                          # noqa: BLE001 - what we test
            failures.append(f"case {k}: {type(err).__name__}: {err}")
            continue
        seconds = time.perf_counter() - t0
        missing = [w for w in words if w not in text]
        if missing or "\n" in text or "--" in text.split(":")[0] or seconds > 1.0:
            failures.append(f"case {k}: {text!r} ({seconds:.2f} s; missing {missing})")
    assert not failures, "\n".join(failures)
    assert sorted(p.name for p in tmp_path.iterdir()) == []     # nothing written
