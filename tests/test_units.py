"""Newton forms of the tension options (cli/common.py): --X-N is --X times l^2/B."""
from __future__ import annotations

import pytest

from elastica_petsc.cli import build_parser, common
from elastica_petsc.core.model import load_config
from elastica_petsc.core.errors import InputError


@pytest.mark.parametrize("argv, key, p_value", [
    (["control", "--target", "500", "200", "--guess-N", "1.8", "3.6"], "guess", [3.24, 6.48]),
    (["trace", "--shape", "circle", "--guess-N", "0", "1.8"], "guess", [0.0, 3.24]),
    (["lengths", "--lengths", "150", "470", "--all", "--levels-N", "9"], "levels", [16.2]),
    (["equilibria", "--tensions", "25.2", "10.8", "--levels-N", "1.8"], "levels", [3.24]),
    (["workspace", "--mode", "tensions", "--tension-max-N", "18", "--tension-spacing-N", "0.9",
      "--out", "x.h5"], "tension_max", 32.4),
])
def test_newton_forms_become_p(argv, key, p_value):
    """The paper's arm: B / l^2 = 0.2 N m^2 / (0.6 m)^2 = 5/9 N, so p = 1.8 P / N."""
    arm = load_config()
    assert arm.force_scale_N == pytest.approx(5.0 / 9.0)
    args = build_parser().parse_args(argv)
    common.newton_forms(args, arm)
    assert getattr(args, key) == pytest.approx(p_value)
    if key == "tension_max":
        assert args.tension_spacing == pytest.approx(1.62)


def test_newton_and_p_forms_exclude_each_other_and_are_checked(capsys):
    parser = build_parser()
    with pytest.raises(SystemExit):
        parser.parse_args(["control", "--target", "1", "1", "--guess", "1", "1",
                           "--guess-N", "1", "1"])
    assert "not allowed with" in capsys.readouterr().err
    args = parser.parse_args(["control", "--target", "1", "1", "--guess-N", "-1", "1"])
    with pytest.raises(InputError, match="--guess-N"):
        common.newton_forms(args, load_config())
    # the p form and the other newton option (--tensions-N) are left alone
    args = parser.parse_args(["solve", "--tensions-N", "1", "2"])
    common.newton_forms(args, load_config())
    assert args.tensions_N == [1.0, 2.0] and args.tensions is None


def test_unused_petsc_options_are_reported_one_line_each():
    """A misspelt option (-eq_snes_monitr) is named, as -options_left would;
    an option the solver read (-eq_snes_rtol) is not."""
    import subprocess
    import sys

    run = subprocess.run([sys.executable, "-m", "elastica_petsc.cli", "solve", "--tensions",
                          "5", "5", "--elements", "30", "-eq_snes_monitr", "-eq_snes_rtol",
                          "1e-9"], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    warnings = [line for line in run.stderr.splitlines() if "warning" in line]
    assert warnings == ["elastica-petsc: warning: PETSc option -eq_snes_monitr was not used by "
                        "any solver (misspelt, or not for this command?)"]
