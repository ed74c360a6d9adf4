#!/usr/bin/env python3
"""Would a stagnation stop make failed deflated solves cheaper without losing a
state?  (issue 25, branch lenspeed; docs/model.md §21 for the divergence stop.)

    .venv/bin/python scripts/benchmarks/deflated_stagnation.py [--windows 6 8 9 10]

Runs the four searches of docs/model.md §21 (Fig. 8's lengths L = (147.1,
472.5) mm and tensions p = (25.2, 10.8), L = (96.2, 454.3) and (130, 480) mm)
and records the residual norm of every iteration of every deflated VI solve
(:class:`~elastica_petsc.solvers.length_system.DivergenceStop` sees each).  For
each candidate rule "stop at iteration k once the best norm of the last W
iterations is above r times the best norm before them" it counts the solves
that converged but would have been stopped (states that could be lost) and the
Newton iterations the rule saves on the solves that failed anyway.
"""
from __future__ import annotations

import argparse
import itertools

import elastica_petsc as ep
from elastica_petsc.solvers import length_system


def histories() -> list[tuple[str, bool, list[float]]]:
    """(search, converged, residual norms) of every deflated solve of the four searches."""
    runs: list[list] = []
    test = length_system.DivergenceStop.__call__

    def recording(self, snes, it, norms):
        if it == 0:
            runs.append([[], None])
        runs[-1][0].append(norms[2])
        reason = test(self, snes, it, norms)
        runs[-1][1] = int(reason)
        return reason

    length_system.DivergenceStop.__call__ = recording
    arm = ep.Arm.paper()
    out = []
    try:
        for name, search in [
                ("L = (147.1, 472.5)", lambda: ep.length_equilibria(arm, [147.1, 472.5])),
                ("L = (96.2, 454.3)", lambda: ep.length_equilibria(arm, [96.2, 454.3])),
                ("L = (130, 480)", lambda: ep.length_equilibria(arm, [130.0, 480.0])),
                ("p = (25.2, 10.8)", lambda: ep.equilibria(arm, tensions=[25.2, 10.8]))]:
            runs.clear()
            result = search()
            print(f"{name}: {len(result.states)} states, {len(runs)} deflated solves")
            # a solve is converged when the test's last answer was a convergence (> 0);
            # one cut by SNES itself (iteration cap) ended while the test said "iterating"
            out += [(name, reason is not None and reason > 0, norms) for norms, reason in runs]
    finally:
        length_system.DivergenceStop.__call__ = test
    return out


def fires(norms: list[float], window: int, ratio: float) -> int | None:
    """The first iteration at which the rule would stop the solve, or None."""
    for k in range(window + 1, len(norms)):
        if min(norms[k - window + 1:k + 1]) > ratio * min(norms[1:k - window + 1]):
            return k
    return None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--windows", type=int, nargs="+", default=[6, 8, 9, 10])
    ap.add_argument("--ratios", type=float, nargs="+", default=[1.0, 0.5])
    args = ap.parse_args()
    runs = histories()
    conv = [(n, h) for n, c, h in runs if c]
    failed = [h for _, c, h in runs if not c]
    print(f"\n{len(conv)} converged deflated solves (at most {max(len(h) - 1 for _, h in conv)} "
          f"iterations), {len(failed)} failed ({sum(len(h) - 1 for h in failed)} iterations)\n")
    print("| W | r | converged solves stopped | iterations saved on failed solves |")
    print("|---|---|---|---|")
    for window, ratio in itertools.product(args.windows, args.ratios):
        lost = [n for n, h in conv if fires(h, window, ratio) is not None]
        saved = sum(len(h) - 1 - fires(h, window, ratio) for h in failed
                    if fires(h, window, ratio) is not None)
        print(f"| {window} | {ratio:g} | {len(lost)} {sorted(set(lost)) if lost else ''} | "
              f"{saved} |")


if __name__ == "__main__":
    main()
