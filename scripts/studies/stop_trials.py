"""Stops of a 2-rank ``workspace`` map under mpiexec at random times (issue 21).

The map (the paper's half-disc at 60 mm spacing, 180 elements) has samples
that take several seconds (the global search builds its seed library, the
boundary proof traces W_0): longer than the ~2 s that Open MPI's mpiexec
waits after forwarding a signal before it kills the ranks.  Periodic
checkpoints are off (``ELASTICA_PETSC_CHECKPOINT_SECONDS=1e6``), so a file
exists only if the stop protocol wrote it.  Each trial sends SIGINT or
SIGTERM to mpiexec or to its process group (Ctrl-C) a random time after the
run took its output lock, then counts:

* file: a valid workspace file was written (scripts/fault_study.py's check);
* message: ``elastica-petsc: interrupted: K of N samples saved ...`` printed;
* ranks: every rank ended by itself, before mpiexec kills the ranks (~2 s after
  the signal; a rank ends with status 130 after a stop);
* status: mpiexec's own exit status.  Open MPI 4.1's mpiexec exits 1 whenever
  it is itself signalled, whatever its ranks' statuses (measured: two ranks
  that exit 130 at once on SIGINT/SIGTERM give 1), so 130 can be seen only when
  the ranks alone are signalled;
* resume: ``--resume`` completes the file to exactly the uninterrupted map.

A signal that comes once every sample is done (the map complete) finds the
ranks in MPI's finalisation, where mpiexec kills them: the file is complete,
no "interrupted" line is due; such trials are counted apart.

Usage: ``python scripts/studies/stop_trials.py [--trials 32] [--seed 21]``; one line per
trial and the counts.  Exit status 1 if any trial of a run still sampling
when signalled missed the file, the message, the ranks' own end or the resume.
"""
from __future__ import annotations

import argparse
import os
import random
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import fault_study as fs                                   # noqa: E402 - helpers shared

GRID = ["--spacing", "60"]
HANG_SECONDS = 30.0
TOTAL = 169       # samples of the map
KILL_S = 1.9      # Open MPI's mpiexec kills the ranks ~2 s after it forwards a signal


def command(out: Path, *extra: str) -> list[str]:
    return [fs.MPIEXEC, "-n", "2", sys.executable, "-m", "elastica_petsc.cli", "workspace",
            *GRID, "--out", str(out), "--quiet", *extra]


def _ranks_end(pids: dict, t0: float) -> float:
    """Seconds from the signal until the last rank has ended (stderr is read
    afterwards: the ranks write little, no pipe fills)."""
    while any(fs._running(pid) for pid in pids.values()):
        if time.monotonic() - t0 > HANG_SECONDS:
            break
        time.sleep(0.005)
    return round(time.monotonic() - t0, 3)


def trial(folder: Path, reference: Path, k: int, victim: str, sig: int, delay: float) -> dict:
    out = folder / f"trial{k}.h5"
    proc = subprocess.Popen(command(out), cwd=fs.ROOT, env=fs.ENV, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    pids = fs.wait_for_ranks(proc)
    fs.wait_for_sampling(out, proc)
    time.sleep(delay)
    ended_before = proc.poll() is not None
    t0 = time.monotonic()
    try:
        fs.send(proc, pids, victim, sig)
    except ProcessLookupError:                     # the map ended just before
        ended_before = True
    ranks_s = _ranks_end(pids, t0)
    stderr, hang = fs.finish(proc, HANG_SECONDS)
    alive = fs.still_alive(pids.values(), deadline=t0 + HANG_SECONDS)
    row = {"trial": k, "victim": victim, "signal": signal.Signals(sig).name,
           "delay_s": round(delay, 2), "status": proc.returncode,
           "seconds": round(time.monotonic() - t0, 2), "hang": hang or bool(alive),
           "ended_before_signal": ended_before, "ranks_end_s": ranks_s,
           "message": any("interrupted:" in line for line in stderr.splitlines())}
    row["file"], row["saved"], _ = fs.check_file(out) if out.exists() else (False, 0, "none")
    resumed = subprocess.run(command(out, "--resume"), cwd=fs.ROOT, env=fs.ENV,
                             capture_output=True, text=True, timeout=600)
    row["resume_equal"] = resumed.returncode == 0 and fs.same_samples(out, reference)
    row["completed"] = row["saved"] == TOTAL       # the map was done when the stop came
    row["ok"] = ended_before or (row["file"] and row["resume_equal"] and not row["hang"] and (
        row["completed"] or (row["message"] and ranks_s < KILL_S)))
    if not row["ok"]:
        row["stderr"] = stderr.strip().splitlines()[-3:]
    return row


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=32)
    parser.add_argument("--seed", type=int, default=21)
    parser.add_argument("--max-delay", type=float, default=12.0,
                        help="latest signal, seconds after the output lock (the run takes ~17 s under "
                             "load, ~3 s on 2 idle cores: lower it there)")
    args = parser.parse_args()
    rng = random.Random(args.seed)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        reference = folder / "reference.h5"
        subprocess.run(command(reference), cwd=fs.ROOT, env=fs.ENV, check=True,
                       capture_output=True, timeout=600)
        plan = [(v, s) for v in ("mpiexec", "group") for s in (signal.SIGINT, signal.SIGTERM)]
        for k in range(args.trials):
            victim, sig = plan[k % len(plan)]
            row = trial(folder, reference, k, victim, sig, rng.uniform(0.2, args.max_delay))
            rows.append(row)
            print(" ".join(f"{key}={value}" for key, value in row.items()), flush=True)
    signalled = [r for r in rows if not (r["ended_before_signal"] or r["completed"])]
    count = {key: sum(bool(r[key]) for r in signalled) for key in ("file", "message",
                                                                     "resume_equal")}
    statuses = sorted({r["status"] for r in signalled})
    own = sum(r["ranks_end_s"] < KILL_S for r in signalled)
    print(f"{len(rows)} trials, {len(rows) - len(signalled)} ended or completed before the "
          f"stop took effect, {len(signalled)} stopped while sampling: file written "
          f"{count['file']}, message printed {count['message']}, every rank ended by itself "
          f"{own} (latest {max((r['ranks_end_s'] for r in signalled), default=0.0):.2f} s after the signal), "
          f"mpiexec's exit statuses {statuses}, resume "
          f"equal to the uninterrupted map {count['resume_equal']}, hangs "
          f"{sum(r['hang'] for r in signalled)}; longest signal-to-end "
          f"{max(r['seconds'] for r in rows):.2f} s; load average {os.getloadavg()[0]:.1f} "
          f"on {os.cpu_count()} cores")
    return 0 if all(r["ok"] for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
