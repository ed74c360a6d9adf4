"""Animations (plots/animate.py): files written and opened again (frame count, size)."""
from __future__ import annotations

import shutil
import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

from elastica_petsc.core.model import load_config
from elastica_petsc.core.errors import InputError
from elastica_petsc.plots.animate import animate_trace, check_animation_path, trace_frames
from elastica_petsc.solvers.control import TipController
from elastica_petsc.studies.trace import densify, line, trace

ELEMENTS = 30


@pytest.fixture(scope="module")
def traced():
    arm = load_config()
    with TipController(arm, n_elements=ELEMENTS) as controller:
        return arm, trace(controller, densify(line((430.0, 200.0), (450.0, 215.0)), 5.0),
                          keep_results=True)


def test_trace_gif(traced, tmp_path):
    arm, result = traced
    out = animate_trace(arm, result, tmp_path / "t.gif", max_frames=4)
    with Image.open(out) as im:
        assert im.format == "GIF" and im.n_frames == 4
        assert im.size == (1024, 832)                   # 6.4 x 5.2 in at 160 dpi
        first = np.asarray(im.convert("RGB"))
        im.seek(3)
        last = np.asarray(im.convert("RGB"))
    assert np.any(first != last)                        # the arm moves between frames
    frames = trace_frames(arm, result, max_frames=4)
    assert [f.caption.split(":")[0] for f in frames] == ["point 1/6", "point 3/6", "point 4/6",
                                                          "point 6/6"]
    np.testing.assert_allclose(frames[-1].tip_mm, result.tips_mm[-1])
    # with an approach its frames come first, sampled over the whole schedule
    both = trace_frames(arm, result, max_frames=100, approach=result)
    assert len(both) == 2 * result.n_points
    assert both[0].caption.startswith("approach 1/6") and both[6].caption.startswith("point 1/6")


@pytest.mark.slow
def test_trace_gif_timed_to_the_schedule(traced, tmp_path):
    """Frames at constant playback intervals show the row the motors are at then;
    the GIF's frame durations add up to the schedule's duration (real time) or
    K times it (--slow-motion K)."""
    arm, result = traced
    times = np.array([0.0, 0.5, 1.0, 3.0, 3.5, 4.0])         # a slow move in the middle
    frames = trace_frames(arm, result, max_frames=100, times_s=times, fps=2.0)
    assert len(frames) == 9 and frames[0].caption.startswith("t = 0.0 s  point 1/6")
    shown = [f.caption.split("point ")[1].split("/")[0] for f in frames]
    assert shown == ["1", "2", "3", "3", "3", "3", "4", "5", "6"]   # held during the slow move
    for slow in (1.0, 3.0):
        out = animate_trace(arm, result, tmp_path / f"t{slow:g}.gif", times_s=times, fps=2.0,
                            slow_motion=slow)
        with Image.open(out) as im:
            total_ms = 0
            for k in range(im.n_frames):
                im.seek(k)
                total_ms += im.info["duration"]
            count = im.n_frames
        # 4 s of schedule, K times slower, one frame per 0.5 s and the end held 0.5 s
        assert count == 4.0 * slow / 0.5 + 1
        assert abs(total_ms - 1000 * (4.0 * slow + 0.5)) <= count


@pytest.mark.slow
def test_control_gif_from_the_command_line(tmp_path):
    """`control --animate`: one frame per optimiser iterate (Fig. 2 as a movie)."""
    out = tmp_path / "c.gif"
    run = subprocess.run([sys.executable, "-m", "elastica_petsc.cli", "control", "--target",
                          "500", "200", "--elements", str(ELEMENTS), "--animate", str(out),
                          "--out", str(tmp_path / "c.h5")], capture_output=True, text=True,
                         timeout=300)
    assert run.returncode == 0, run.stderr
    import h5py
    with h5py.File(tmp_path / "c.h5", "r") as fh:
        iterates = len(fh["control/history_E"])
    with Image.open(out) as im:
        assert im.n_frames == iterates and im.size == (1024, 832)


def test_animation_path_errors(tmp_path):
    with pytest.raises(InputError, match=r"\.gif or \.mp4"):
        check_animation_path(tmp_path / "a.avi")
    (tmp_path / "b.gif").write_bytes(b"")
    with pytest.raises(InputError, match="--overwrite"):
        check_animation_path(tmp_path / "b.gif")
    if shutil.which("ffmpeg") is None:
        with pytest.raises(InputError, match="ffmpeg"):
            check_animation_path(tmp_path / "c.mp4")
