"""`schedule --max-deviation-mm`: the fastest constant tip speed within D mm (studies/speed.py,
docs/model.md §16.8), on a short line near the straight arm at 30 elements (seconds per run)."""
from __future__ import annotations

import json
import subprocess
import sys

import pytest

import elastica_petsc as ep
from elastica_petsc.core.model import load_config
from elastica_petsc.core.schedule import read_schedule_csv
from elastica_petsc.studies.speed import play

D_MM = 1.3


def _cli(*args, cwd):
    return subprocess.run([sys.executable, "-m", "elastica_petsc.cli", *args],
                          capture_output=True, text=True, cwd=cwd, timeout=300)


@pytest.fixture(scope="module")
def short_line(tmp_path_factory):
    """A 3 mm line near the straight arm's tip, after its approach: 17 rows."""
    cwd = tmp_path_factory.mktemp("speed")
    r = _cli("trace", "--shape", "line", "--center", "599.5", "8", "--end", "599", "11",
             "--elements", "30", "--schedule", "s.csv", "--quiet", cwd=cwd)
    assert r.returncode == 0, r.stderr
    return cwd


@pytest.mark.slow
def test_fastest_speed_passes_and_one_and_a_half_times_it_fails(short_line):
    """The reported speed's own simulation stays within D (and settles), the speed 1.5 times
    higher, played afresh, does not; the JSON names the mesh and the rule of thumb."""
    r = _cli("schedule", "s.csv", "--max-deviation-mm", str(D_MM), "--elements", "30",
             "--rel-tol", "0.2", "--json", cwd=short_line)
    assert r.returncode == 0, r.stderr
    s = json.loads(r.stdout)
    assert s["kind"] == "schedule" and s["elements"] == 30
    v = s["fastest_mm_s"]
    assert v is not None and s["failing_mm_s"] <= 1.2 * v * (1 + 1e-12)
    assert s["fastest"]["passed"] and s["fastest"]["max_deviation_mm"] <= D_MM
    assert any(not t["passed"] for t in s["trials"])
    assert s["rule_of_thumb_mm_s"] == pytest.approx(2 * 3.141592653589793 * s["f1_hz"] * D_MM)
    arm = load_config(None)
    schedule = read_schedule_csv(short_line / "s.csv", arm.motor)
    ok, _ = play(arm, schedule, v, D_MM, elements=30, settle_s=2.0)
    assert ok.passed and ok.max_deviation_mm <= D_MM and ok.settling_s is not None
    fast, _ = play(arm, schedule, 1.5 * v, D_MM, elements=30, settle_s=2.0)
    assert not fast.passed and fast.max_deviation_mm > D_MM


def test_library_refuses_bad_deviation(tmp_path):
    arm = load_config(None)
    with pytest.raises(ep.InputError, match="positive number of mm"):
        ep.fastest_speed(arm, tmp_path / "none.csv", 0.0)


@pytest.mark.parametrize("args, message", [
    (["--max-deviation-mm", "0"], "largest tip deviation must be a positive"),
    (["--max-deviation-mm", "-1"], "largest tip deviation must be a positive"),
    (["--max-deviation-mm", "1", "--settle-s", "0"], "settling window must be a positive"),
    (["--max-deviation-mm", "1", "--retime", "r.csv"], "without --retime"),
])
@pytest.mark.slow
def test_bad_input_is_one_line_and_exit_2(short_line, args, message):
    r = _cli("schedule", "s.csv", "--elements", "30", *args, cwd=short_line)
    assert r.returncode == 2 and r.stdout == ""
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("elastica-petsc: error: ") \
        and message in lines[0]
    assert not (short_line / "r.csv").exists()
