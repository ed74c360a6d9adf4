"""The figure list of issue 26, checked on the drawn matplotlib objects (the
PNGs of the gallery are looked at by eye; these tests keep what was fixed):
legends off the data, r_1 and r_2 told apart, one marker size for every class
of Fig. 4, tensions in N in Fig. 5, one arrow scale in Fig. 6b, no state of
Fig. 6c hidden under another, a crossing cable said in Fig. 8's legend, and
rejected design steps off the feasible areas."""
from __future__ import annotations

import dataclasses
from types import SimpleNamespace

import numpy as np
import pytest

from elastica_petsc.core.model import Arm, load_config
from elastica_petsc.studies.workspace import Status

ELEMENTS = 30


@pytest.fixture
def drawn(monkeypatch):
    """plots.<module>.save replaced: the figures are kept (drawn), then closed."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figures = []

    def keep(fig, path):
        fig.canvas.draw()
        figures.append(fig)

    def patch(module):
        monkeypatch.setattr(module, "save", keep)
        return figures

    yield patch
    for fig in figures:
        plt.close(fig)


def clear_of(legend_owner, *axes) -> bool:
    """True if the legend's box on the canvas overlaps none of ``axes``."""
    box = legend_owner.get_legend().get_window_extent()
    return not any(box.overlaps(ax.get_window_extent()) for ax in axes)


@pytest.fixture(scope="module")
def closed_trace():
    """A short closed path (a triangle, 25 mm steps) traced on the paper arm."""
    from elastica_petsc.solvers.control import TipController
    from elastica_petsc.studies.trace import densify, paper_triangle, trace

    arm = load_config()
    with TipController(arm, n_elements=ELEMENTS) as controller:
        return arm, trace(controller, densify(paper_triangle((400.0, 200.0)), 25.0),
                          p0=np.full(2, 2.0), keep_results=True)


def test_fig6b_one_arrow_scale_for_both_tendons(closed_trace, drawn):
    from matplotlib.quiver import Quiver

    from elastica_petsc.plots import control

    arm, tr = closed_trace
    figures = drawn(control)
    control.plot_sensitivities(arm, tr, "unused.png")
    quivers = [c for c in figures[0].axes[0].collections if isinstance(c, Quiver)]
    assert len(quivers) == 2
    assert quivers[0].scale == quivers[1].scale          # arrow lengths compare across tendons
    lengths = [np.max(np.hypot(q.U, q.V)) for q in quivers]
    assert lengths[1] > 3 * lengths[0]                   # the ratio the panel is meant to show


def test_fig6c_no_state_hidden_under_a_later_one(closed_trace, drawn):
    """Each solid curve is wider than every curve drawn over it, so two nearly
    equal states (or the closed path's repeated point) both stay visible."""
    from elastica_petsc.plots import control

    arm, tr = closed_trace
    figures = drawn(control)
    control.plot_curvature(arm, tr, "unused.png")
    ax = figures[0].axes[0]
    solid = sorted((line for line in ax.lines if line.get_linestyle() == "-"
                    and not line.get_label().startswith("_")), key=lambda l: l.get_zorder())
    assert len(solid) >= 3
    widths = [line.get_linewidth() for line in solid]
    assert all(a > b for a, b in zip(widths, widths[1:])), widths
    labels = [line.get_label() for line in solid]
    assert labels[0].startswith("point 0 = point ")      # the closed path: one curve, named


def test_fig2a_legend_below_the_geometry(drawn):
    from elastica_petsc.plots import control
    from elastica_petsc.solvers.control import TipController

    arm = load_config()
    with TipController(arm, n_elements=ELEMENTS) as controller:
        result = controller.solve_mm((535.8, 222.6), p0=np.zeros(2))
    figures = drawn(control)
    control.plot_descent(arm, result, "unused.png")
    geometry = figures[0].axes[0]
    assert clear_of(geometry, *figures[0].axes)


def workspace_data(arm: Arm) -> dict:
    """A small Fig. 4/5 data set of every class (values made up, shapes real)."""
    rng = np.random.default_rng(0)
    pts = np.column_stack((rng.uniform(-500, 500, 60), rng.uniform(0, 500, 60)))
    status = np.repeat([Status.REACHED, Status.REACHED, Status.UNDECIDED,
                        Status.OUTSIDE_BOUNDARY], 15)
    strategy = np.array([b"local"] * 15 + [b"seed 3"] * 15 + [b""] * 30)
    p = rng.uniform(0.5, 20.0, (60, 2))
    return {"tip": pts, "target": pts, "status": status, "strategy": strategy,
            "reason": np.array([b""] * 60), "mode": "targets", "length_mm": arm.length_mm,
            "routes_mm": arm.routes() * arm.length_mm, "spacing": None,
            "region": "half-disc y >= 0, |x| <= l = 600 mm", "min_tension_N": 0.0,
            "tensions": p, "tensions_N": arm.tensions_to_N(p),
            "kappa_max": rng.uniform(0, 8, 60), "lambda_min_raw": rng.uniform(0, 0.1, 60),
            "strain_energy": rng.uniform(0, 20, 60),
            "limits": {"kappa_limit": 10.0, "strain_energy_max": 18.0, "max_tension": 203.2}}


def test_fig4_one_marker_size_and_named_routing_points():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from elastica_petsc.plots.workspace import plot_samples

    arm = load_config()
    fig, ax = plt.subplots()
    try:
        plot_samples(workspace_data(arm), ax)
        classes = [line for line in ax.lines if line.get_label().startswith(
            ("reached", "not reached", "outside"))]
        names = [t.get_text() for t in ax.texts]
        halos = [bool(t.get_path_effects()) for t in ax.texts]    # legible over samples
    finally:
        plt.close(fig)
    assert len(classes) == 4
    assert len({line.get_markersize() for line in classes}) == 1
    assert names == ["r_1", "r_2"] and all(halos)


def test_fig5_tensions_in_newton(drawn):
    from elastica_petsc.plots import workspace

    arm = load_config()
    figures = drawn(workspace)
    workspace.plot_restrictions(workspace_data(arm), "unused.png")
    titles = [ax.get_title() for ax in figures[0].axes]
    tension = [t for t in titles if t.startswith("(d) tension")]
    assert len(tension) == 2 and all("[N]" in t for t in tension)
    bars = [ax.get_ylabel() for ax in figures[0].axes if ax.get_label() == "<colorbar>"]
    assert bars.count("P [N]") == 2


def test_fig8_legend_says_which_cable_crosses_the_arm(drawn):
    """State 3 of Fig. 8 (p = (25.2, 10.8), tendon 1 loaded first) has cable 2
    across the arm: its legend entry says so and the cable is on a red band;
    state 1 (tendon 2 first) has none."""
    import elastica_petsc as ep
    from elastica_petsc.plots import lengths

    arm = dataclasses.replace(load_config(), elements=60)
    p = np.array([25.2, 10.8])
    state1 = ep.solve(arm, tensions=p, order=(2, 1))
    state3 = ep.solve(arm, tensions=p, order=(1, 2))
    figures = drawn(lengths)
    lengths.plot_states(arm, [(state1.equilibrium, "state 1"), (state3.equilibrium, "state 3")],
                        "unused.png", "Fig. 8")
    labels = figures[0].axes[0].get_legend_handles_labels()[1]
    assert "state 1" in labels
    assert "state 3; cable 2 crosses the arm (red band)" in labels
    bands = [line for line in figures[0].axes[0].lines if line.get_linewidth() == 6]
    assert len(bands) == 1
    assert clear_of(figures[0].axes[0], figures[0].axes[0])


def test_design_figure_rejected_steps_and_legends_off_the_data(drawn):
    """Rejected designs never sit at the feasible designs' areas (with a loop:
    at their own area; untraced: on the axis), r_i are named, and both legends
    lie below their panels."""
    from elastica_petsc.plots import design

    arm = load_config()
    moved = dataclasses.replace(arm, tendons=tuple(
        dataclasses.replace(t, route_mm=(t.route_mm[0] + 5.0, t.route_mm[1] - 8.0))
        for t in arm.tendons))
    angle = np.linspace(0, 2 * np.pi, 50, endpoint=False)
    loop = np.column_stack((400 + 100 * np.cos(angle), 200 + 100 * np.sin(angle)))
    history = [{"area_mm2": 58000.0, "feasible": True}, {"area_mm2": None, "feasible": False},
               {"area_mm2": 61000.0, "feasible": False}, {"area_mm2": 72000.0, "feasible": True}]
    result = SimpleNamespace(
        arm_before=arm, arm_after=moved, before=SimpleNamespace(loop_mm=loop, area_mm2=58000.0),
        after=SimpleNamespace(loop_mm=1.1 * loop, area_mm2=72000.0), resampled_before=None,
        resampled_after=None, confirmed=None, p_max=18.0, history=history)
    figures = drawn(design)
    design.plot_area_design(result, "unused.png")
    ax, hx = figures[0].axes
    feasible = next(line for line in hx.lines if line.get_label() == "feasible")
    rejected = next(line for line in hx.lines if line.get_label().startswith("rejected: loop"))
    untraced = next(line for line in hx.lines if "clearance" in line.get_label())
    np.testing.assert_array_equal(rejected.get_xydata(), [[3, 61000.0]])
    assert untraced.get_xdata().tolist() == [2]
    assert np.isnan(feasible.get_ydata()[[1, 2]]).all()
    assert sorted(t.get_text() for t in ax.texts) == ["r_1", "r_1", "r_2", "r_2"]
    assert clear_of(ax, ax, hx) and clear_of(hx, ax, hx)


def test_equilibria_text_says_which_cable_crosses_the_arm(tmp_path):
    """`equilibria` at Fig. 8's tensions (14, 6) N: the state that loading tendon 1
    first reaches (Fig. 8's state 3) is noted as having cable 2 across the arm;
    the state of tendon 2 first / proportional loading (state 1) is not."""
    import subprocess
    import sys

    run = subprocess.run([sys.executable, "-m", "elastica_petsc.cli", "equilibria",
                          "--tensions-N", "14", "6", "--elements", str(ELEMENTS), "--effort", "1",
                          "--quiet"], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    blocks = run.stdout.split("\nstate ")[1:]
    notes = {b.split(";")[0]: [line.strip() for line in b.splitlines() if "crosses the arm" in line]
             for b in blocks}
    by_order = {b.split(";")[0]: b.splitlines()[0] for b in blocks}
    first = next(k for k, head in by_order.items() if "'straight arm, proportional'" in head)
    state3 = next(k for k, head in by_order.items() if "'straight arm, order 1,2'" in head)
    assert notes[first] == []
    assert notes[state3] == ["note: cable 2 crosses the arm (a straight cable through the arm: "
                             "this state needs a guide or is not physical; core/clearance.py)"]
