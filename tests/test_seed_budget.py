"""The seed library's budget (solvers/reach.py, issue 11): the full library grows
like n! 6^n equilibrium solves; arms with up to three tendons keep all of it,
more tendons get fewer levels and orders under a hard cap, the output says
so, and a search ended by the budget stays undecided (reachable None, never
False)."""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from elastica_petsc.core.model import load_config
from elastica_petsc.core.model import Tendon
from elastica_petsc.solvers.control import TipController
from elastica_petsc.solvers.reach import MAX_SEED_SOLVES, SEARCH_EXHAUSTED, Reacher, SeedLibrary

pytestmark = pytest.mark.slow          # left out by scripts/test.sh --fast

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
LEVELS = (2.0, 6.0, 14.0, 28.0, 50.0, 80.0)


def four_tendon_arm():
    arm = load_config(CONFIGS / "three_tendon.toml")
    return dataclasses.replace(arm, tendons=arm.tendons + (Tendon(300.0, (30.0, -60.0)),))


@pytest.mark.parametrize("config", ["paper.toml", "three_tendon.toml"])
def test_up_to_three_tendons_the_library_is_whole(config):
    with TipController(load_config(CONFIGS / config), n_elements=30) as ctl:
        lib = SeedLibrary(ctl)
        assert lib.levels == LEVELS and len(lib.orders) == math.factorial(ctl.n)
        assert lib.full_count <= MAX_SEED_SOLVES and lib.cap_note == ""


def test_four_tendons_fewer_levels_under_the_budget():
    with TipController(four_tendon_arm(), n_elements=30) as ctl:
        lib = SeedLibrary(ctl)
        # 24 * (3 + 9 + 27 + 81) = 2880 > 2000 for three levels; two fit: 24 * 30 + 6 * 2
        assert lib.full_count == 24 * sum(6 ** k for k in range(1, 5)) + 6 * 6
        assert lib.levels == (2.0, 80.0) and len(lib.orders) == 24
        assert "2 of 6 tension levels, 24 of 24 loading orders" in lib.cap_note
        small = SeedLibrary(ctl, max_solves=40)      # one level, then fewer orders: 8 * 4 + 6
        assert small.levels == (28.0,) and len(small.orders) == 8
        assert [o[0] for o in small.orders[:4]] == [0, 1, 2, 3]     # each tendon first once
        assert small.seeds() and small.solves <= 40 and not small.stopped
        assert "1 of 6 tension levels, 8 of 24 loading orders" in small.cap_note
        tiny = SeedLibrary(ctl, max_solves=5)        # not even one order and the rays: a stop
        assert len(tiny.orders) == 1 and tiny.seeds()
        assert tiny.solves == 5 and tiny.stopped and "stopped at the budget" in tiny.cap_note


def test_a_search_ended_by_the_budget_is_undecided_and_says_so():
    with TipController(four_tendon_arm(), n_elements=30) as ctl:
        lib = SeedLibrary(ctl, max_solves=40)
        reacher = Reacher(ctl, seeds=lib, max_seeds=2, max_homotopies=1, max_substeps=4)
        res = reacher.reach(np.array([-400.0, -300.0]) / ctl.length_mm)
        assert not res.converged
        assert res.reachable is None and res.reason == SEARCH_EXHAUSTED
        assert "seed library capped by its budget of 40" in res.message
        assert "seed library capped" in res.evidence


def test_the_text_output_names_the_cap():
    from elastica_petsc.cli.control import unreachable_message

    with TipController(four_tendon_arm(), n_elements=30) as ctl:
        note = SeedLibrary(ctl).cap_note
    s = {"target_mm": [-400.0, -300.0], "tip_mm": [-300.0, -250.0], "tip_error_mm": 100.0,
         "on_bound": [], "reason": SEARCH_EXHAUSTED, "local_reason": "STATIONARY",
         "reachable": None, "message": "", "evidence": f"{SEARCH_EXHAUSTED}: ... (other "
         f"loading orders; {note}); not proven unreachable", "cable_clear": [True] * 4}
    text = unreachable_message(s)
    assert text.endswith("; " + note) and "not proven unreachable" in text
