"""A shorter timing than the forward/backward passes where the acceleration
limits bind: dynamic programming over the chain of moves (docs/model.md, audit
section "Re-timing as a chain").

The acceleration limit couples only neighbouring moves k, k+1 (module
docstring of :mod:`.motion`, with u = 1/d):

    |dq_i,k+1 u_k+1 - dq_ik u_k| <= A_i (1/u_k + 1/u_k+1) / 2,

and from or to rest |dq_i| u <= A_i / (2 u) at the first and last move.  The
right side grows as a move slows down, so the bound a move puts on its
neighbour is not monotone in its speed, and the passes (which only lower
speeds) miss schedules that slow a short move (a path corner, a motor's
reversal) to let its neighbours run faster.  Over a grid of speeds per move
(its cap u_k scaled down geometrically, plus the passes' speed, so the
passes' schedule is one of the candidates) the chain's shortest feasible
schedule is found exactly by dynamic programming (each pair of neighbouring
grid values checked against the limit), then every speed is raised towards
its cap while both its neighbours' limits allow (coordinate sweeps, odd and
even moves in turn).  Every candidate the result is built from satisfies the
limits, so it is playable; it is never longer than the passes' schedule.
"""
from __future__ import annotations

import numpy as np

GRID = 64                  # candidate speeds per move
SLOWEST = 0.2              # the grid reaches down to this fraction of the passes' speed
RAISE_STEPS = 24           # trial speeds between a move's speed and its cap per sweep
RAISE_SWEEPS = 30
_SLACK = 1.0 + 1e-12       # round-off allowed in a pair's test (check allows 1e-9)


def _column(dq, i):
    """Motor i's moves: a number for one move (n,), a column (m, 1) for rows (m, n)."""
    d = np.asarray(dq)[..., i]
    return d[:, None] if d.ndim else d


def _pair_ok(dq_a, dq_b, accel, ua, ub) -> np.ndarray:
    """Whether moves a, b (dq rows (n,), or (m, n) for m pairs) at speeds ua, ub
    (broadcast) meet every motor's acceleration limit between them."""
    ok = np.ones(np.broadcast(ua, ub).shape, bool)
    for i in np.flatnonzero(np.isfinite(accel)):
        jump = np.abs(_column(dq_b, i) * ub - _column(dq_a, i) * ua)
        ok &= jump <= _SLACK * accel[i] * 0.5 * (1.0 / ua + 1.0 / ub)
    return ok


def _end_ok(dq_k, accel, u) -> np.ndarray:
    """From or to rest: |dq_i| u <= A_i / (2 u) for every motor."""
    ok = np.ones(np.shape(u), bool)
    for i in np.flatnonzero(np.isfinite(accel)):
        ok &= np.abs(_column(dq_k, i)) * u * u <= _SLACK * 0.5 * accel[i]
    return ok


def chain_speeds(dq: np.ndarray, caps: np.ndarray, passes: np.ndarray,
                 accel: np.ndarray) -> np.ndarray:
    """Speeds u (K-1,) of the moves (module docstring): the dynamic programme's
    shortest schedule over the grid, raised towards ``caps``; ``passes``: the
    forward/backward passes' speeds (feasible)."""
    K1 = len(dq)
    scale = np.exp(-np.linspace(0.0, 1.0, GRID - 1))[None, :]
    low = np.log(np.maximum(caps / (SLOWEST * passes), 1.0))[:, None]
    grid = np.hstack([passes[:, None], caps[:, None] * scale ** low])
    grid = np.minimum(grid, caps[:, None])
    cost = np.where(_end_ok(dq[0], accel, grid[0]), 1.0 / grid[0], np.inf)
    back = np.zeros((K1, GRID), int)
    for k in range(1, K1):
        ok = _pair_ok(dq[k - 1], dq[k], accel, grid[k - 1][:, None], grid[k][None, :])
        total = np.where(ok, cost[:, None], np.inf)
        back[k] = np.argmin(total, axis=0)
        cost = total[back[k], np.arange(GRID)] + 1.0 / grid[k]
    cost = np.where(_end_ok(dq[-1], accel, grid[-1]), cost, np.inf)
    if not np.isfinite(cost).any():        # round-off rejected even the passes' schedule
        return passes
    pick = np.empty(K1, int)
    pick[-1] = int(np.argmin(cost))
    for k in range(K1 - 1, 0, -1):
        pick[k - 1] = back[k, pick[k]]
    u = grid[np.arange(K1), pick]
    return _raise(u, dq, caps, accel)


def _raise(u, dq, caps, accel) -> np.ndarray:
    """Each speed raised to the largest trial value up to its cap at which both
    neighbours' limits still hold (odd and even moves in turn, so each sweep
    moves independent speeds)."""
    u = u.copy()
    K1 = len(u)
    trials = np.linspace(1.0, 0.0, RAISE_STEPS)[None, :]
    for _ in range(RAISE_SWEEPS):
        moved = False
        for parity in (0, 1):
            k = np.arange(parity, K1, 2)
            k = k[u[k] < caps[k] * (1 - 1e-12)]
            if not len(k):
                continue
            cand = u[k, None] + (caps[k, None] - u[k, None]) * trials    # cap first
            ok = np.ones(cand.shape, bool)
            inner = k > 0
            ok[inner] &= _pair_ok(dq[k[inner] - 1], dq[k[inner]], accel,
                                  u[k[inner] - 1][:, None], cand[inner])
            ok[~inner] &= _end_ok(dq[:1], accel, cand[~inner])
            inner = k < K1 - 1
            ok[inner] &= _pair_ok(dq[k[inner]], dq[k[inner] + 1], accel, cand[inner],
                                  u[k[inner] + 1][:, None])
            ok[~inner] &= _end_ok(dq[-1:], accel, cand[~inner])
            first = np.argmax(ok, axis=1)                 # the fastest feasible trial
            better = ok[np.arange(len(k)), first] & (cand[np.arange(len(k)), first]
                                                     > u[k] * (1 + 1e-9))
            u[k[better]] = cand[np.arange(len(k)), first][better]
            moved |= bool(better.any())
        if not moved:
            break
    return u
