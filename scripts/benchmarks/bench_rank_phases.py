#!/usr/bin/env python3
"""Where each rank's time goes in a workspace map (issue 25: the 1 -> 2 rank
speed-up of the Fig. 4 map), as a user runs it.

    .venv/bin/python scripts/benchmarks/bench_rank_phases.py [--ranks 1 2] [--repeat 3]
        [--spacing 11.67]

Each run is ``elastica-petsc workspace --spacing S --elements 180 --out F``
(the command's own code, in a fresh process, under ``mpiexec -n R`` for R > 1)
with timers wrapped around its phases on every rank, all measured from the
moment the launcher was started: the interpreter and imports, the fixed costs
(the trace on rank 0, the seed library on rank 1, and the wait for the other
rank's part), every chunk (start, end, number of samples, UNDECIDED samples),
the time a rank spends after its last chunk until the command returns
(rank 0: receiving, the last checkpoint), and the end of the process as the
launcher sees it.  Per rank: busy time in chunks, idle time; median of
``--repeat`` runs of the whole command's wall time, interleaved over R.

Each mark also records the rank's CPU (process) time, which a loaded machine
inflates far less than wall time: from it the script estimates what an idle
machine's wall times would be (the launcher's own start not counted): on one
rank the sum of its CPU, on R ranks the slowest rank's start, the slowest
rank's fixed costs, the chunks' CPU of all ranks over R (the chunks are handed
out dynamically: bench_chunk_schedule.py) and the slowest rank's rest; and
the bound (Amdahl) that the one-rank run's start-up and end put on the speed-up.
These are estimates, marked as such in the output, not measurements.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
           OMPI_MCA_rmaps_base_oversubscribe="1")

# The child: the CLI's workspace command with timers (monkey-patched wrappers, no change
# to what is computed).  Events are (name, seconds since the launcher started, extra).
CHILD = r"""
import json, os, sys, time
launch = float(os.environ["BENCH_LAUNCH"])
events = [("python", time.time() - launch, None, time.process_time())]
def mark(name, extra=None):
    events.append((name, time.time() - launch, extra, time.process_time()))
sys.path.insert(0, HERE)
from elastica_petsc.cli import main
from elastica_petsc.studies import chunks
from elastica_petsc.studies.workspace import driver, shared_setup, fill
mark("imports")
share, receive, solve_chunk = driver.share_fixed_costs, shared_setup._receive, \
    fill.BoundaryFillSampler.solve_chunk
def timed_share(*a, **k):
    mark("setup start"); share(*a, **k); mark("setup end")
def timed_receive(comm, value, root, tag):
    mark("wait start", root); v = receive(comm, value, root, tag); mark("wait end", root); return v
def timed_chunk(self, points, stop):
    mark("chunk start", len(points)); out = solve_chunk(self, points, stop)
    mark("chunk end", int((out["status"] == 4).sum()) if out is not None else -1); return out
driver.share_fixed_costs, shared_setup._receive = timed_share, timed_receive
fill.BoundaryFillSampler.solve_chunk = timed_chunk
run = chunks.run
def timed_run(*a, **k):
    mark("run start"); r = run(*a, **k); mark("run end"); return r
driver.run = timed_run
from elastica_petsc.solvers import runtime
def timed(module, name):
    f = getattr(module, name)
    def g(*a, **k):
        mark(name + " start"); r = f(*a, **k); mark(name + " end"); return r
    setattr(module, name, g)
timed(runtime, "init"); timed(driver, "agree"); timed(driver, "make_sampler")
from mpi4py import MPI
rank = MPI.COMM_WORLD.rank
sys.argv = ["elastica-petsc", "workspace", "--spacing", SPACING, "--elements", "180",
            "--quiet", "--overwrite", "--out", OUT]
code = main()
mark("main end")
with open(os.path.join(DIR, f"rank{rank}.json"), "w") as f:
    json.dump(events, f)
sys.exit(code)
"""


def run(ranks: int, spacing: float, directory: str) -> tuple[float, dict]:
    """(whole wall time, {rank: events}) of one run."""
    from elastica_petsc.studies.workspace.schema import Status
    assert Status.UNDECIDED == 4
    out = os.path.join(directory, f"map_{ranks}.h5")
    code = (CHILD.replace("HERE", repr(HERE)).replace("SPACING", repr(str(spacing)))
            .replace("OUT", repr(out)).replace("DIR", repr(directory)))
    cmd = [sys.executable, "-c", code]
    if ranks > 1:
        cmd = ["mpiexec", "-n", str(ranks)] + cmd
    env = dict(ENV, BENCH_LAUNCH=repr(time.time()))
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, cwd=directory, env=env, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    events = {}
    for r in range(ranks):
        with open(os.path.join(directory, f"rank{r}.json")) as f:
            events[r] = json.load(f)
    return wall, events


def summary(wall: float, events: dict) -> list[str]:
    lines = []
    for rank, ev in sorted(events.items()):
        at = {}
        for name, t, _, _ in ev:
            at.setdefault(name, t)
        chunks = [(t, x) for name, t, x, _ in ev if name.startswith("chunk")]
        busy = sum(chunks[i + 1][0] - chunks[i][0] for i in range(0, len(chunks) - 1, 2))
        undecided = sum(x for name, t, x, _ in ev if name == "chunk end" and x and x > 0)
        waits = [t for name, t, _, _ in ev if name.startswith("wait")]
        wait = sum(waits[i + 1] - waits[i] for i in range(0, len(waits) - 1, 2))
        first = chunks[0][0] if chunks else float("nan")
        last = chunks[-1][0] if chunks else float("nan")
        lines.append(
            f"rank {rank}: python {at['python']:.2f}, imports {at['imports']:.2f}, "
            f"setup {at.get('setup start', float('nan')):.2f}-{at.get('setup end', float('nan')):.2f}"
            f" (waiting {wait:.2f}), chunks {first:.2f}-{last:.2f}: {len(chunks) // 2} chunks, "
            f"busy {busy:.2f}, {undecided} UNDECIDED; run end {at['run end']:.2f}, "
            f"main end {at['main end']:.2f}; process end {wall:.2f}")
    return lines


def phases(wall: float, events: dict) -> dict:
    """The run's phases in seconds: ``start`` (launch to the fixed costs, the
    slowest rank), ``setup`` (fixed costs: trace and seed library on 2+ ranks),
    ``chunks`` (first chunk start to the last chunk's end, over all ranks;
    on one rank the trace and the library are paid inside it), ``end`` (to the
    process's end as the launcher sees it) and ``map`` (the in-process map:
    fixed costs to the end of the chunk engine on rank 0, file written)."""
    def first(name, cpu=False):
        return {r: next(c if cpu else t for n, t, _, c in ev if n == name)
                for r, ev in events.items()}
    chunk_times = [t for ev in events.values() for n, t, _, _ in ev if n.startswith("chunk")]
    chunk_cpu = sum(c1 - c0 for ev in events.values()
                    for (n0, _, _, c0), (n1, _, _, c1) in zip(ev, ev[1:])
                    if n0 == "chunk start" and n1 == "chunk end")
    start_cpu, end_cpu = first("setup start", True), first("main end", True)
    setup_cpu = {r: first("setup end", True)[r] - start_cpu[r] for r in events}
    last_cpu = {r: end_cpu[r] - first("setup end", True)[r] for r in events}
    setup_start, setup_end = max(first("setup start").values()), max(first("setup end").values())
    return {"start": setup_start, "setup": setup_end - setup_start,
            "chunks": max(chunk_times) - min(chunk_times), "end": wall - max(chunk_times),
            "map": first("run end")[0] - first("setup start")[0], "wall": wall,
            # CPU seconds (process time of each rank; waiting polls with sleeps): before the
            # fixed costs (slowest rank), the fixed costs (slowest rank), the chunks (all
            # ranks together), and after the fixed costs outside the chunks (slowest rank)
            "cpu start": max(start_cpu.values()), "cpu setup": max(setup_cpu.values()),
            "cpu chunks": chunk_cpu,
            "cpu rest": max(last_cpu[r] - sum(
                c1 - c0 for (n0, _, _, c0), (n1, _, _, c1) in zip(ev, ev[1:])
                if n0 == "chunk start" and n1 == "chunk end") for r, ev in events.items())}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--spacing", type=float, default=11.67)
    ap.add_argument("--timelines", action="store_true", help="print every run's timeline")
    args = ap.parse_args()
    load = [os.getloadavg()[0]]
    walls = {r: [] for r in args.ranks}
    parts = {r: [] for r in args.ranks}
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(args.repeat):
            for ranks in args.ranks:
                wall, events = run(ranks, args.spacing, tmp)
                walls[ranks].append(wall)
                parts[ranks].append(phases(wall, events))
                print(f"-- {ranks} rank(s), wall {wall:.2f} s")
                for line in summary(wall, events):
                    print("   " + line)
                if args.timelines:
                    for rank, ev in sorted(events.items()):
                        print(f"   rank {rank}: " + ", ".join(
                            f"{n} {t:.2f}" + (f" ({x})" if x is not None else "")
                            for n, t, x, _ in ev))
            load.append(os.getloadavg()[0])
    print(f"\nload average {min(load):.2f}-{max(load):.2f}; median of {args.repeat}, interleaved")
    med = {r: statistics.median(w) for r, w in walls.items()}
    for r in args.ranks:
        print(f"{r} rank(s): whole command {med[r]:.2f} s (runs "
              + ", ".join(f"{w:.2f}" for w in walls[r]) + ")")
    names = ("start", "setup", "chunks", "end", "map", "wall", "cpu start", "cpu setup",
             "cpu chunks", "cpu rest")
    print("\n| ranks | " + " | ".join(f"{n} [s]" for n in names) + " |")
    print("|---" * (len(names) + 1) + "|")
    table = {r: {n: statistics.median(p[n] for p in parts[r]) for n in names}
             for r in args.ranks}
    for r in args.ranks:
        print(f"| {r} | " + " | ".join(f"{table[r][n]:.2f}" for n in names) + " |")
    if 1 in med:
        for r in args.ranks:
            if r > 1:
                print(f"speed-up 1 -> {r} ranks: whole command {med[1] / med[r]:.2f}, "
                      f"in-process map {table[1]['map'] / table[r]['map']:.2f}")
                one, many = table[1], table[r]
                serial = one["cpu start"] + one["cpu rest"]
                t1 = serial + one["cpu chunks"]
                tr = many["cpu start"] + many["cpu setup"] + many["cpu chunks"] / r + \
                    many["cpu rest"]
                print(f"from CPU times (an idle machine's wall, launcher not counted): "
                      f"1 rank {t1:.2f} s, {r} ranks {tr:.2f} s, speed-up {t1 / tr:.2f}; "
                      f"not divided on 1 rank: {serial:.2f} s of {t1:.2f} s (bound "
                      f"{t1 / (serial + (t1 - serial) / r):.2f})")
                m1 = one["cpu chunks"] + one["cpu rest"]
                mr = many["cpu setup"] + many["cpu chunks"] / r + many["cpu rest"]
                print(f"from CPU times, in-process (fixed costs, chunks, file, summary): "
                      f"1 rank {m1:.2f} s, {r} ranks {mr:.2f} s, speed-up {m1 / mr:.2f}")


if __name__ == "__main__":
    main()
