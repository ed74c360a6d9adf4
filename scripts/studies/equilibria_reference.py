"""Exhaustive reference for the equilibrium searches (issue 12): a dense,
deliberately brute-force multi-start, independent of the search it checks.

    .venv/bin/python scripts/studies/equilibria_reference.py [--elements 180] [--grid-max 160]
        [--grid-step 10] [--random 400] [--pairs L1 L2 [L1 L2 ...]] [--json out.json]
    .venv/bin/python scripts/studies/equilibria_reference.py --tensions 25.2 10.8
    .venv/bin/python scripts/studies/equilibria_reference.py --compare ref.json

``--compare`` runs the default search (studies.search.search_lengths /
search_tensions) on every case of a reference JSON file written by ``--json``
and prints, per case, the states of the reference inside the search's box
0 <= p_i <= P_crit l^2/B that the search missed, and those it found beyond
the reference.

Length control (default; the paper's arm, cable lengths in mm): starts are

1. the load-controlled states on a grid of tensions p_i in {0, step, ..., grid-max}
   reached along every loading order (proportional and each permutation, both sides
   of every bifurcation crossed: studies.search.tension_starts), and
2. ``--random`` random shapes theta(s) = sum_k a_k sin((k - 1/2) pi s / l), k = 1..4,
   a_k uniform in [-3, 3] rad (seeded), with least-squares tensions;

from every start one plain VI Newton solve of the length equations (Eq. (23);
no deflation) and, from the grid starts, one length continuation with unstable
states allowed (LengthSolver.follow).  Load control (``--tensions``): from every
start one plain Newton solve at the tensions.  Converged states are
deduplicated by shape (max nodal angle difference 1e-4 rad) and listed with
p >= 0 (P l^2/B), cable lengths, tip and stability under load/length control.

This is a reference by brute force, not a proof either; it is slow (minutes per
pair at 180 elements) and lives here, not in the test suite.
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np

from elastica_petsc.core.model import load_config
from elastica_petsc.core.fem import Discretisation
from elastica_petsc.solvers.equilibrium import EquilibriumSolver
from elastica_petsc.solvers.lengths import LengthSolver, same_shape
from elastica_petsc.studies.search import LoadSolves, tension_starts

# Fig. 8's lengths and five more pairs in the region of Fig. 8 (mm)
PAIRS = ((147.1, 472.5), (96.2, 454.3), (130.0, 480.0), (160.0, 450.0), (120.0, 500.0),
         (150.0, 420.0))


def random_starts(disc, count: int, seed: int, solver: LengthSolver) -> list:
    rng = np.random.default_rng(seed)
    s = np.arange(disc.n_elements + 1) * disc.h
    out = []
    for j in range(count):
        a = rng.uniform(-3.0, 3.0, 4)
        theta = sum(a[k] * np.sin((k + 0.5) * np.pi * s) for k in range(4))
        u = disc.consistent_state(theta)
        out.append((f"random {j}", (u, solver._tension_guess(u))))
    return out


def collect(states, state) -> None:
    if state is not None and state.converged and not any(same_shape(state, s) for s in states):
        states.append(state)


def describe(states, l_mm: float) -> list[dict]:
    rows = []
    for s in sorted(states, key=lambda s: tuple(s.p)):
        rows.append({"p": [round(float(v), 4) for v in s.p],
                     "cable_lengths_mm": [round(float(v) * l_mm, 3) for v in s.cable_lengths],
                     "tip_mm": [round(float(v) * l_mm, 3) for v in s.tip],
                     "unstable_modes_load": int(s.unstable_modes),
                     "unstable_modes_length": int(getattr(s, "length_unstable_modes", -1))})
    return rows


def length_reference(solver, grid, rand, L) -> list:
    states = []
    for _, start in grid:
        collect(states, solver.solve(L, start))
        collect(states, solver.follow(L, start, keep_stable=False))
    for _, start in rand:
        collect(states, solver.solve(L, start))
    return [s for s in states if np.all(s.p >= 0.0)]


def compare(path: str) -> None:
    from elastica_petsc.studies.search import search_box, search_lengths, search_tensions

    arm = load_config()
    with open(path) as fh:
        ref = json.load(fh)
    box = search_box(arm)
    print("| case | reference in the box | default search | missed | found beyond the "
          "reference | time |")
    print("|---|---|---|---|---|---|")
    for case in ref["cases"]:
        t0 = time.process_time()
        if "lengths_mm" in case:
            res = search_lengths(arm, case["lengths_mm"], elements=ref["elements"])
            name = "L = " + str(tuple(case["lengths_mm"])) + " mm"
        else:
            res = search_tensions(arm, case["tensions"], elements=ref["elements"])
            name = "p = " + str(tuple(case["tensions"]))
        seconds = time.process_time() - t0
        ours = [np.asarray(f.state.p) for f in res.states]
        refs = [np.asarray(r["p"]) for r in case["states"] if max(r["p"]) <= box]
        tips = [np.asarray(r["tip_mm"]) for r in case["states"] if max(r["p"]) <= box]
        our_tips = [f.state.tip * arm.length_mm for f in res.states]
        missed = [tuple(p) for p, t in zip(refs, tips)
                  if not any(np.max(np.abs(t - q)) < 0.5 for q in our_tips)]
        extra = [tuple(np.round(p, 2)) for p, t in zip(ours, our_tips)
                 if not any(np.max(np.abs(t - q)) < 0.5 for q in tips)]
        print(f"| {name} | {len(refs)} | {len(ours)} | {missed or '-'} | {extra or '-'} "
              f"| {seconds:.1f} s |", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--elements", type=int, default=180)
    ap.add_argument("--grid-max", type=float, default=160.0)
    ap.add_argument("--grid-step", type=float, default=10.0)
    ap.add_argument("--random", type=int, default=400)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--pairs", type=float, nargs="+", default=None)
    ap.add_argument("--tensions", type=float, nargs="+", default=None)
    ap.add_argument("--json", default=None)
    ap.add_argument("--config", default=None, help="an arm TOML file (default: the paper's)")
    ap.add_argument("--compare", default=None, metavar="REF_JSON")
    args = ap.parse_args()
    if args.compare:
        return compare(args.compare)
    arm = load_config(args.config) if args.config else load_config()
    disc = Discretisation.from_arm(arm, args.elements)
    levels = np.arange(args.grid_step, args.grid_max + 0.5 * args.grid_step, args.grid_step)
    out = {"elements": args.elements, "grid": [args.grid_step, args.grid_max],
           "random": args.random, "seed": args.seed, "cases": []}
    t0 = time.process_time()
    with EquilibriumSolver(disc) as eq, LengthSolver(disc, length_mm=arm.length_mm) as ls:
        grid = tension_starts(eq, levels=levels)
        rand = random_starts(disc, args.random, args.seed, ls)
        print(f"{len(grid)} grid starts, {len(rand)} random starts "
              f"({time.process_time() - t0:.1f} s)", flush=True)
        if args.tensions is not None:
            p = np.asarray(args.tensions, float)
            solves = LoadSolves(eq, length_mm=arm.length_mm)
            states = []
            for _, start in grid + rand:
                collect(states, solves.solve(p, start))
            solves.destroy()
            cases = [("tensions", list(p), states)]
        else:
            pairs = np.asarray(args.pairs if args.pairs else PAIRS, float).reshape(-1, 2)
            cases = []
            for pair in pairs:
                t1 = time.process_time()
                states = length_reference(ls, grid, rand, pair / arm.length_mm)
                cases.append(("lengths_mm", list(pair), states))
                print(f"L = {tuple(pair)} mm: {len(states)} states with p >= 0 "
                      f"({time.process_time() - t1:.1f} s)", flush=True)
        for key, value, states in cases:
            rows = describe(states, arm.length_mm)
            out["cases"].append({key: value, "count": len(rows), "states": rows})
            print(f"{key} = {value}: {len(rows)} states")
            for r in rows:
                print("   p =", r["p"], " L =", r["cable_lengths_mm"], " tip =", r["tip_mm"],
                      " unstable modes load/length =",
                      f"{r['unstable_modes_load']}/{r['unstable_modes_length']}")
    out["process_time_s"] = round(time.process_time() - t0, 1)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(out, fh, indent=1)


if __name__ == "__main__":
    main()
