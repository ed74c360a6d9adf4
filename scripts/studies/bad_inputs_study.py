"""Bad inputs, tried as a hostile user would (issue 21): every command-line option
and library argument with values it must refuse, each answered within
``LIMIT_S`` seconds by one line ``elastica-petsc: error: ...`` and exit status 2
(argparse's own usage + error lines count as refused) or by ``ep.InputError``.

Usage: ``python scripts/studies/bad_inputs_study.py [--only cli|api]``: one line per
failure, then a table (tried, refused, failed: traceback / accepted / slow).
Runs in one process (PETSc starts once); a case that runs longer than
``LIMIT_S`` is stopped by an alarm and counted as slow.
"""
from __future__ import annotations

import argparse
import contextlib
import io
import os
import signal
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
THREE = str(ROOT / "configs" / "three_tendon.toml")
LIMIT_S = 10.0
NUMBERS = ["nan", "inf", "-inf", "-1", "0", "1e300", "-1e300", "1e-300"]


class Slow(BaseException):
    pass


def _alarm(signum, frame):
    raise Slow()


def cli_cases(tmp: Path) -> list[list[str]]:
    """Command lines that must be refused (each a list of arguments)."""
    base = {
        "solve": ["solve", "--tensions", "1", "1"],
        "stability": ["stability", "--tensions", "1", "1"],
        "control": ["control", "--target", "500", "100"],
        "trace": ["trace", "--shape", "circle", "--center", "400", "200", "--radius", "20"],
        "lengths": ["lengths", "--lengths", "147.1", "472.5"],
        "equilibria": ["equilibria", "--tensions", "5", "5"],
        "workspace": ["workspace", "--out", str(tmp / "w.h5")],
        "boundary": ["boundary"],
        "design": ["design", "--vary", "tendon1.route", "--objective", "area"],
    }
    numeric = {
        "solve": [["--tensions", "V", "1"], ["--tensions-N", "1", "V"], ["--elements", "V"]],
        "stability": [["--modes", "V"], ["--amplitude-mm", "V"], ["--elements", "V"]],
        "control": [["--target", "V", "100"], ["--tol-mm", "V"], ["--guess", "V", "0"],
                    ["--guess-N", "0", "V"], ["--min-tension-N", "V"]],
        "trace": [["--radius", "V"], ["--step", "V"], ["--speed-mm-s", "V"],
                  ["--amplitude-mm", "V"], ["--center", "V", "200"]],
        "lengths": [["--lengths", "V", "472"], ["--effort", "V"], ["--levels", "V"],
                    ["--deflation-rounds", "V"]],
        "equilibria": [["--tensions", "V", "5"], ["--effort", "V"]],
        "workspace": [["--spacing", "V"], ["--box", "0", "V", "0", "100"], ["--chunk", "V"],
                      ["--tension-max", "V", "--mode", "tensions"],
                      ["--tension-spacing", "V", "--mode", "tensions"],
                      ["--min-tension-N", "V"]],
        "design": [["--tension-max-N", "V"], ["--iterations", "V"], ["--reach", "V"],
                   ["--margin", "V"], ["--resample-cells", "V"], ["--clearance", "V"]],
    }
    integer_options = {"--elements", "--modes", "--effort", "--deflation-rounds", "--chunk",
                       "--iterations", "--resample-cells"}
    tension = {"--tensions", "--tensions-N", "--guess", "--guess-N", "--min-tension-N",
               "--clearance"}
    valid = {**{flag: {"0", "1e-300"} for flag in tension},
             **{flag: {"0", "-1", "1e-300"} for flag in ("--target", "--center", "--box")},
             "--modes": {"1"}, "--deflation-rounds": {"0", "1"}, "--effort": {"1"},
             "--iterations": {"1"}, "--levels": {"1e-300"},
             # positive and finite: a valid if odd request, answered normally
             "--step": {"1e300"}, "--speed-mm-s": {"1e300"}, "--spacing": {"1e300"},
             "--radius": {"1e-300"}, "--amplitude-mm": {"1e300"}, "--chunk": {"1", "99999999"},
             "--reach": {"1e-300"}, "--tension-max": {"1e-300"}, "--margin": {"1e-300"}}
    cases = []
    for command, options in numeric.items():
        for option in options:
            flag = option[0]
            values = (["-1", "0", "1", "2.5", "99999999", "abc"] if flag in integer_options
                      else NUMBERS + ["abc"])
            for v in values:
                if v in valid.get(flag, ()):
                    continue
                args = base[command] + [a if a != "V" else v for a in option]
                if flag != "--elements" and command != "design":
                    args += ["--elements", "30"]
                cases.append(args)
    (tmp / "folder.toml").mkdir()
    (tmp / "same.toml").write_text(
        "[arm]\nlength_mm = 600.0\nbending_stiffness_Nm2 = 0.2\n"
        + "[[tendon]]\nattach_mm = 200.0\nroute_mm = [46.3, -97.1]\n" * 2)
    (tmp / "meters.toml").write_text(
        "[arm]\nlength_mm = 0.6\nbending_stiffness_Nm2 = 0.2\n"
        "[[tendon]]\nattach_mm = 0.2\nroute_mm = [0.05, -0.1]\n")
    (tmp / "huge.toml").write_text(
        "[arm]\nlength_mm = 600.0\nbending_stiffness_Nm2 = 0.2\nelements = 5000000\n"
        "[[tendon]]\nattach_mm = 600.0\nroute_mm = [26.1, 51.1]\n")
    (tmp / "xy.csv").write_text("x,y\n400,200\n")
    (tmp / "three.csv").write_text("x_mm,y_mm,z_mm\n400,200,0\n")
    (tmp / "rows.csv").write_text("x_mm,y_mm\n" + "400,200\n" * 5000)
    (tmp / "exists.h5").write_bytes(b"")
    solve = base["solve"] + ["--elements", "30"]
    cases += [
        solve + ["--config", str(tmp / "folder.toml")],
        solve + ["--config", str(tmp / "same.toml")],
        ["solve", "--tensions", "1", "--config", str(tmp / "meters.toml")],
        solve[:4] + ["--config", str(tmp / "huge.toml")],
        solve + ["--config", str(tmp / "missing.toml")],
        solve + ["--out", str(tmp / "x.txt")],
        solve + ["--out", ""],
        solve + ["--out", str(tmp / "exists.h5")],
        solve + ["--out", "/proc/x.h5"],
        solve + ["--vtk", ""],
        solve + ["--vtk", "/proc/v"],
        solve + ["--plot", str(tmp / "p.xyz")],
        solve + ["--order", "1,1"],
        solve + ["--order", "a"],
        solve + ["--from", str(tmp / "missing.h5")],
        solve + ["--point", "3"],
        solve + ["--tensions", "1", "1", "1"],
        solve + ["-options_file", str(tmp / "missing.opts")],
        base["control"] + ["--animate", str(tmp / "a.avi")],
        base["control"] + ["--animate", "/proc/a.gif"],
        base["control"] + ["--animate", str(tmp / "no" / "a.gif")],
        base["control"] + ["--vtk", ""],
        base["control"] + ["--config", THREE, "--guess", "1", "1"],
        ["trace", "--path", str(tmp / "xy.csv")],
        ["trace", "--path", str(tmp / "three.csv")],
        ["trace", "--path", str(tmp / "missing.csv")],
        ["trace", "--shape", "line", "--center", "400", "200"],
        ["trace", "--shape", "paper-triangle", "--step", "1e-9"],
        ["trace", "--shape", "paper-triangle", "--schedule", str(tmp / "s.txt")],
        ["trace", "--shape", "paper-triangle", "--per-point"],
        ["trace", "--shape", "paper-triangle", "--animate", "/proc/x.gif"],
        ["workspace"],
        base["workspace"] + ["--box", "10", "0", "0", "10"],
        base["workspace"] + ["--spacing", "1e-6"],
        base["workspace"] + ["--mode", "targets", "--config", str(tmp / "missing.toml")],
        base["workspace"] + ["--overlay", str(tmp / "missing.h5")],
        base["workspace"] + ["--vtk", ""],
        ["boundary", "--config", THREE],
        ["boundary", "--overlay", str(tmp / "missing.h5")],
        ["design", "--vary", "tendon9.route", "--objective", "area"],
        ["design", "--vary", "tendon1.route", "--objective", "volume"],
        ["design", "--vary", "tendon1.route", "--objective", f"path:{tmp / 'rows.csv'}"],
        ["design", "--vary", "tendon1.route", "--objective", f"path:{tmp / 'xy.csv'}"],
        ["design", "--sweep", "tendon1.route.x=0:10:0"],
        ["lengths", "--lengths", "147.1"],
        ["lengths", "--lengths", "1e6", "472"],
        ["equilibria", "--tensions", "-5", "5"],
        ["replay", str(tmp / "missing.h5")],
        ["replay", str(tmp / "exists.h5")],
        ["reproduce", "--quick", "--aluminium-config", str(tmp / "missing.toml"), "--out",
         str(tmp / "rep")],
        ["reproduce", "--jobs", "0", "--out", str(tmp / "rep2")],
        ["reproduce", "--out", ""],
    ]
    return cases


def run_cli(args: list[str]) -> tuple[str, str, float]:
    """(verdict, message, seconds): verdict refused / traceback / accepted / slow."""
    from elastica_petsc.cli import main

    err = io.StringIO()
    t0 = time.perf_counter()
    signal.alarm(int(LIMIT_S))
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            try:
                status = main(args)
            except SystemExit as exit:
                status = exit.code
    except Slow:
        return "slow", "", time.perf_counter() - t0
    except BaseException as exc:                               # noqa: BLE001 - what we count
        return "traceback", f"{type(exc).__name__}: {exc}"[:160], time.perf_counter() - t0
    finally:
        signal.alarm(0)
    seconds = time.perf_counter() - t0
    lines = [line for line in err.getvalue().splitlines() if line.strip()]
    argparse_error = len(lines) >= 1 and lines[-1].startswith("elastica-petsc") and \
        ": error: " in lines[-1] and (len(lines) == 1 or lines[0].startswith("usage:"))
    if status == 2 and argparse_error and "Traceback" not in err.getvalue():
        return "refused", lines[-1][:160], seconds
    return ("accepted" if status in (0, 1, 3, 4) else "traceback"), \
        f"status {status}: {err.getvalue()[-160:]!r}", seconds


def api_cases(tmp: Path) -> list[tuple[str, object]]:
    import elastica_petsc as ep

    arm = ep.Arm.paper()
    E = 30
    state = ep.solve(arm, [1.0, 1.0], elements=E)
    tri = [[300.0, 100.0], [310.0, 100.0]]
    bad = [float("nan"), float("inf"), -1.0, "1", None, True, [1.0]]
    cases = []
    for v in bad:
        cases += [] if v is None else [
            (f"trace step_mm={v!r}", lambda v=v: ep.trace(arm, tri, step_mm=v, elements=E)),
            (f"solve elements={v!r}", lambda v=v: ep.solve(arm, [1.0, 1.0], elements=v))]
        cases += [] if v == -1.0 else [
            (f"control target_mm=[{v!r}, 0]",
             lambda v=v: ep.control(arm, [v, 0.0], elements=E))]
        cases += [
            (f"solve tensions_N=[{v!r}, 1]", lambda v=v: ep.solve(arm, [v, 1.0], elements=E)),
            (f"lengths [{v!r}, 472]", lambda v=v: ep.lengths(arm, [v, 472.0], elements=E)),
            (f"stability modes={v!r}", lambda v=v: ep.stability(state, modes=v)),
            (f"workspace spacing_mm={v!r}",
             lambda v=v: ep.workspace(arm, spacing_mm=v, elements=E)),
            (f"control tol_mm={v!r}",
             lambda v=v: ep.control(arm, [500.0, 0.0], tol_mm=v, elements=E)),
            (f"design_area tension_max_N={v!r}",
             lambda v=v: ep.design_area(arm, tension_max_N=v, elements=E)),
        ]
    cases += [
        ("lengths 1e300", lambda: ep.lengths(arm, [1e300, 472], elements=E)),
        ("control 1e300", lambda: ep.control(arm, [1e300, 0], elements=E)),
        ("stability modes 0", lambda: ep.stability(state, modes=0)),
        ("stability modes 2.5", lambda: ep.stability(state, modes=2.5)),
        ("trace step 1e-12", lambda: ep.trace(arm, tri, step_mm=1e-12, elements=E)),
        ("workspace box [1, 2]", lambda: ep.workspace(arm, box_mm=[1, 2], elements=E)),
        ("Arm tendons dicts", lambda: ep.Arm(length_mm=600.0, bending_stiffness_Nm2=0.2,
                                             tendons=[{"attach_mm": 600.0,
                                                       "route_mm": (26.1, 51.1)}])),
        ("solve tensions strings", lambda: ep.solve(arm, ["1", "2"], elements=E)),
        ("workspace out x.txt", lambda: ep.workspace(arm, out=str(tmp / "x.txt"), elements=E)),
        ("Arm length in metres", lambda: ep.Arm(length_mm=0.4, bending_stiffness_Nm2=0.1,
                                                tendons=(ep.Tendon(0.2, (0.0, 0.05)),))),
        ("Arm identical tendons", lambda: ep.Arm(
            length_mm=600.0, bending_stiffness_Nm2=0.2,
            tendons=(ep.Tendon(600.0, (26.1, 51.1)), ep.Tendon(600.0, (26.1, 51.1))))),
        ("solve elements 3e6", lambda: ep.solve(arm, [1, 1], elements=3_000_000)),
        ("design 3000 points", lambda: ep.design(arm, [[400.0, 200.0]] * 3000, elements=E)),
        ("control animate .avi", lambda: ep.control(arm, [500, 0], animate="a.avi",
                                                     elements=E)),
        ("frequencies control", lambda: ep.frequencies(state, control="x")),
        ("stability of a string", lambda: ep.stability("state")),
        ("solve of a string arm", lambda: ep.solve("paper", [1, 1])),
        ("read missing", lambda: ep.read(tmp / "missing.h5")),
        ("boundary three tendons", lambda: ep.boundary(ep.Arm.from_toml(THREE), elements=E)),
        ("equilibria negative", lambda: ep.equilibria(arm, [-1, 1], elements=E)),
        ("schedule speed -1", lambda: ep.schedule(arm, tri, speed_mm_s=-1, elements=E)),
        ("workspace box reversed", lambda: ep.workspace(arm, box_mm=[0, 100, 50, 10],
                                                         elements=E)),
        ("workspace mode", lambda: ep.workspace(arm, mode="grid", elements=E)),
        ("control share", lambda: ep.control(arm, [500, 0], share="max", elements=E)),
        ("control cables", lambda: ep.control(arm, [500, 0], cables="maybe", elements=E)),
        ("solve side", lambda: ep.solve(arm, [1, 1], side="up", elements=E)),
        ("solve order", lambda: ep.solve(arm, [1, 1], order=(1, 1), elements=E)),
        ("design vary", lambda: ep.design(arm, tri, vary=("tendon9.route",), elements=E)),
        ("design_sweep axis", lambda: ep.design_sweep(arm, ["tendon1.route.x=0:1:0"],
                                                      elements=E)),
    ]
    return cases


def run_api(call) -> tuple[str, str, float]:
    import elastica_petsc as ep

    t0 = time.perf_counter()
    signal.alarm(int(LIMIT_S))
    try:
        call()
        verdict, message = "accepted", ""
    except ep.InputError as err:
        verdict, message = "refused", str(err)[:160]
    except Slow:
        verdict, message = "slow", ""
    except BaseException as err:                                # noqa: BLE001 - what we count
        verdict, message = "traceback", f"{type(err).__name__}: {err}"[:160]
    finally:
        signal.alarm(0)
    return verdict, message, time.perf_counter() - t0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", choices=("cli", "api"))
    args = parser.parse_args()
    signal.signal(signal.SIGALRM, _alarm)
    table = {}
    with tempfile.TemporaryDirectory() as tmp:
        os.chdir(tmp)
        tmp = Path(tmp)
        if args.only != "api":
            for case in cli_cases(tmp):
                verdict, message, seconds = run_cli(case)
                table.setdefault("command line", []).append(verdict)
                if verdict != "refused" or seconds > LIMIT_S:
                    print(f"FAIL cli {verdict} ({seconds:.1f} s): {' '.join(case)}: {message}",
                          flush=True)
        if args.only != "cli":
            for name, call in api_cases(tmp):
                verdict, message, seconds = run_api(call)
                table.setdefault("library", []).append(verdict)
                if verdict != "refused":
                    print(f"FAIL api {verdict} ({seconds:.1f} s): {name}: {message}",
                          flush=True)
    print("| where | tried | refused (one line / InputError) | traceback | accepted | slow |")
    print("|---|---|---|---|---|---|")
    for where, verdicts in table.items():
        print(f"| {where} | {len(verdicts)} | {verdicts.count('refused')} | "
              f"{verdicts.count('traceback')} | {verdicts.count('accepted')} | "
              f"{verdicts.count('slow')} |")
    return 0 if all(v == "refused" for vs in table.values() for v in vs) else 1


if __name__ == "__main__":
    sys.exit(main())
