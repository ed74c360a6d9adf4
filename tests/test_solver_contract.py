"""The contract of every class that owns PETSc objects (solvers/options.py):
a checked options prefix, code options under it for setFromOptions only
(the command line wins), prefixed Mats/Vecs, options given after the first
solve applied at the next one, per-solve state not kept on the solver, and
tensions checked once per call."""
from __future__ import annotations

import numpy as np
import pytest
from petsc4py import PETSc

import elastica_petsc.solvers.control as control
import elastica_petsc.solvers.equilibrium as equilibrium
from elastica_petsc.core.dynamics import Inertia
from elastica_petsc.core.errors import InputError
from elastica_petsc.core.fem import Discretisation
from elastica_petsc.solvers.continuation import CurveTracer
from elastica_petsc.solvers.control import TipController
from elastica_petsc.solvers.dynamics import DynamicsSolver
from elastica_petsc.solvers.equilibrium import EquilibriumSolver
from elastica_petsc.solvers.lengths import LengthSolver
from elastica_petsc.solvers.calibration import RowSolver
from elastica_petsc.solvers.minimise import BoundedMinimiser, minimise_bounded
from elastica_petsc.solvers.options import check_prefix, flatten_options
from elastica_petsc.solvers.reasons import converged_reason
from elastica_petsc.solvers.sensitivity import SensitivitySolver
from elastica_petsc.solvers.share import TensionSharer
from elastica_petsc.solvers.stability import StabilitySolver

FIG2_TARGET_MM = (535.8, 222.6)


@pytest.fixture(scope="module")
def disc(paper_arm):
    return Discretisation.from_arm(paper_arm, 30)


@pytest.mark.parametrize("prefix, why", [("", "non-empty"), ("eq", "end with '_'"),
                                         ("1eq_", "start with a letter"),
                                         ("e q_", "letters, digits"), (None, "non-empty")])
def test_a_bad_prefix_is_refused_in_one_line(prefix, why):
    with pytest.raises(InputError, match=why):
        check_prefix(prefix)


def test_every_solver_checks_its_prefix(paper_arm, disc):
    makers = [lambda: EquilibriumSolver(disc, options_prefix="eq"),
              lambda: SensitivitySolver(disc, options_prefix="-s_"),
              lambda: StabilitySolver(disc, options_prefix="stab"),
              lambda: LengthSolver(disc, options_prefix="len-"),
              lambda: CurveTracer(disc, options_prefix=""),
              lambda: TipController(paper_arm, n_elements=30, options_prefix="ctl"),
              lambda: RowSolver(paper_arm, 30, options_prefix="calib"),
              lambda: BoundedMinimiser(2, max_iterations=1, options_prefix="design"),
              lambda: DynamicsSolver(disc, Inertia.build(disc), options_prefix="sim")]
    for make in makers:
        with pytest.raises(InputError, match="options prefix"):
            make()


def test_nested_options_flatten():
    assert flatten_options({"snes": {"rtol": 1e-8, "linesearch": {"type": "bt"}},
                            "-ksp_type": "preonly"}) == {
        "snes_rtol": 1e-8, "snes_linesearch_type": "bt", "ksp_type": "preonly"}


def test_code_options_apply_under_the_prefix_and_leave_no_trace(disc):
    opts = PETSc.Options()
    with EquilibriumSolver(disc, options_prefix="ctr_", petsc_options={"snes": {"max_it": 3}}) \
            as solver:
        assert solver.snes.getTolerances()[3] == 3
        for obj in (solver.snes, solver.J, solver.x, solver.f):
            assert obj.getOptionsPrefix() == "ctr_"
    assert not opts.hasName("ctr_snes_max_it")
    # the command line (the database) wins over code
    opts["ctw_snes_max_it"] = 7
    try:
        with EquilibriumSolver(disc, options_prefix="ctw_",
                               petsc_options={"snes_max_it": 3}) as solver:
            assert solver.snes.getTolerances()[3] == 7
        assert opts.getInt("ctw_snes_max_it") == 7
    finally:
        opts.delValue("ctw_snes_max_it")


def test_an_option_given_after_the_first_solve_is_applied(disc):
    """In the database (e.g. petsc4py's options set by a script) or by
    ``options.update``: the next solve uses it."""
    opts = PETSc.Options()
    with EquilibriumSolver(disc, options_prefix="late_") as solver:
        first = solver.solve([4.0, 4.0])
        assert first.converged and first.iterations > 2
        opts["late_snes_max_it"] = 1
        try:
            second = solver.solve([4.0, 4.0])
        finally:
            opts.delValue("late_snes_max_it")
        assert solver.snes.getTolerances()[3] == 1
        assert second.load_steps > first.load_steps      # one Newton step each: shorter steps
        solver.options.update({"snes": {"max_it": 40, "rtol": 1e-3}})
        third = solver.solve([4.0, 4.0])
        assert third.converged and solver.snes.getTolerances()[:4:3] == (1e-3, 40)
    with StabilitySolver(disc, options_prefix="latestab_") as stab:
        u = first.u
        stab.solve(u, first.p)
        stab.options.update({"eps_tol": 1e-7})
        stab.solve(u, first.p)
        assert stab.eps.getTolerances()[0] == pytest.approx(1e-7)


def test_options_for_the_gradient_descent_are_refused(paper_arm):
    with pytest.raises(InputError, match="gd .* runs no TAO"):
        TipController(paper_arm, n_elements=30, method="gd",
                      petsc_options={"tao_ls_type": "armijo"})


def test_tip_control_keeps_no_per_solve_state_and_leaves_a_borrowed_solver_alone(paper_arm,
                                                                              disc):
    with EquilibriumSolver(disc, options_prefix="borrowed_") as solver:
        before = (dict(vars(solver)), solver.snes.getTolerances(), solver.snes.getType(),
                  dict(solver.options.options))
        with TipController(paper_arm, solver=solver) as ctl:
            attrs = set(vars(ctl))
            res = ctl.solve_mm(FIG2_TARGET_MM)
            assert res.converged
            assert set(vars(ctl)) == attrs and ctl.tao.getAppCtx() is None
        after = (dict(vars(solver)), solver.snes.getTolerances(), solver.snes.getType(),
                 dict(solver.options.options))
        assert after[0].keys() == before[0].keys() and after[1:] == before[1:]
        assert solver.snes.getOptionsPrefix() == "borrowed_"       # not destroyed either


def test_tensions_are_checked_once_per_call(paper_arm, monkeypatch):
    calls, check = [], equilibrium.check_tensions

    def counting(p, n):
        calls.append(1)
        return check(p, n)

    monkeypatch.setattr(control, "check_tensions", counting)
    with TipController(paper_arm, n_elements=30) as ctl:
        assert ctl.evaluate([3.0, 4.0]) is not None
        assert len(calls) == 1
        monkeypatch.setattr(equilibrium, "check_tensions", counting)
        res = ctl.solve_mm(FIG2_TARGET_MM)
        # the solve's evaluations (tensions from the optimiser) are not re-checked
        assert res.evaluations > 3 and len(calls) == 1
        ctl.forward([1.0, 2.0])
        assert len(calls) == 2


def test_brgn_reaches_fig2_like_blmvm(paper_arm):
    """TAO BRGN (its own least-squares formulation) in place of the emulated
    Gauss-Newton: the same tensions, TAO's reason checked; the subsolver
    carries the controller's prefix."""
    with TipController(paper_arm, n_elements=60) as ctl:
        ref = ctl.solve_mm(FIG2_TARGET_MM)
    with TipController(paper_arm, n_elements=60, method="brgn") as ctl:
        assert ctl.tao.getBRGNSubsolver().getOptionsPrefix() == "ctl_tao_brgn_subsolver_"
        res = ctl.solve_mm(FIG2_TARGET_MM)
        assert converged_reason(ctl.tao) == res.tao_reason == "CONVERGED_USER"
    assert res.converged and res.tip_error_mm < 1e-5 and res.failed_evaluations == 0
    assert np.allclose(res.p, ref.p, rtol=1e-5)


def test_bounded_minimiser_finds_the_clipped_minimum():
    """min |q - c|^2 / 2 over a box: the minimiser is c clipped to the box."""
    c = np.array([3.0, -2.0, 0.5])
    lo, hi = np.array([0.0, -1.0, -1.0]), np.array([2.0, 1.0, 1.0])
    reason, its = minimise_bounded(lambda q: (0.5 * float((q - c) @ (q - c)), q - c),
                                   np.zeros(3), lo, hi, scale_mm=1.0, max_iterations=50,
                                   options_prefix="mintest_",
                                   petsc_options={"tao": {"gatol": 1e-12}})
    assert reason.startswith("CONVERGED") and its <= 10
    assert not PETSc.Options().hasName("mintest_tao_gatol")


def test_sharer_takes_the_contract(paper_arm):
    with TipController(paper_arm, n_elements=30) as ctl:
        with pytest.raises(InputError, match="options prefix"):
            TensionSharer(ctl, options_prefix="share")


def test_length_solver_gives_each_part_its_options(disc):
    """Keys under ``defl`` go to the deflated solves (<prefix>defl_), over their
    own default (the l2 line search); the rest to the plain solves."""
    with LengthSolver(disc, petsc_options={"snes": {"max_it": 7},
                                           "defl": {"snes_max_it": 9}}) as solver:
        assert solver.system.snes.getTolerances()[3] == 7
        assert solver.deflated_system.snes.getTolerances()[3] == 9
        assert solver.deflated_system.options.options == {"snes_linesearch_type": "l2",
                                                          "snes_max_it": 9}


def test_sharer_keeps_no_warm_start_between_paths():
    """The SQP's warm start (W, multipliers, active set) lives in the trace, not
    on the sharer: the sharer's attributes are the same objects after a path,
    and the same path traced twice gives bitwise the same tensions."""
    from pathlib import Path

    from elastica_petsc.core.model import load_config
    from elastica_petsc.studies import trace as paths

    arm = load_config(Path(__file__).resolve().parents[1] / "configs" / "three_tendon.toml")
    pts = paths.circle((450.0, 290.0), 40.0, 8)[:4]
    with TipController(arm, n_elements=30) as ctl:
        sharer = TensionSharer(ctl, "min-energy")
        before = dict(vars(sharer))
        first = paths.trace(ctl, pts, sharer=sharer)
        assert {k: id(v) for k, v in vars(sharer).items()} == \
            {k: id(v) for k, v in before.items()}
        ctl.forget()
        second = paths.trace(ctl, pts, sharer=sharer)
    assert first.all_converged
    np.testing.assert_array_equal(first.p, second.p)
    np.testing.assert_array_equal(first.iterations, second.iterations)
