"""Fault injection for ``workspace`` under ``mpiexec -n 2`` (issue 15, items 2-3).

Each trial starts a map, waits a chosen time, sends SIGINT or SIGTERM to
mpiexec, to its whole process group (Ctrl-C in a terminal), to rank 0, to
rank 1 or to both ranks, and then checks:

* no hang: every process ends within ``HANG_SECONDS`` of the signal;
* a valid file: it opens, says incomplete (or complete), its per-chunk and
  per-sample bookkeeping agree;
* when sampling had begun, the last checkpoint was written on the stop:
  periodic checkpoints are switched off (``ELASTICA_PETSC_CHECKPOINT_SECONDS=1e6``),
  so the file exists only if the stop protocol wrote it, and every sample in it
  (``saved``) was saved by that protocol; the work lost is the chunk each rank
  had in hand (at most one per rank: 4 samples here);
* ``--resume`` completes the file to exactly the uninterrupted map.

Usage: ``python scripts/studies/fault_study.py [--trials 20] [--load 1]`` (``--load N``
runs N busy-loop processes beside it).  Prints one line per trial and a
summary; exit status 1 if any trial failed.
"""
from __future__ import annotations

import argparse
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
MPIEXEC = shutil.which("mpiexec")
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
           OMPI_MCA_rmaps_base_oversubscribe="1", ELASTICA_PETSC_CHECKPOINT_SECONDS="1e6")
GRID = ["--box", "-120", "480", "60", "420", "--spacing", "15", "--elements", "30",
        "--chunk", "4"]
HANG_SECONDS = 30.0
VICTIMS = ("mpiexec", "group", "rank0", "rank1", "both")


def command(out: Path, *extra: str, ranks: int = 2) -> list[str]:
    cli = [sys.executable, "-m", "elastica_petsc.cli", "workspace", *GRID, "--out", str(out),
           *extra]
    return [MPIEXEC, "-n", str(ranks), *cli] if ranks > 1 else cli


def rank_pids(mpiexec_pid: int) -> dict[int, int]:
    """{rank: pid} of the processes that mpiexec started (from their environment)."""
    ranks = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            if int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1]) != mpiexec_pid:
                continue
            env = (entry / "environ").read_bytes().split(b"\0")
        except (OSError, IndexError, ValueError):
            continue
        for item in env:
            if item.startswith(b"OMPI_COMM_WORLD_RANK="):
                ranks[int(item.split(b"=")[1])] = int(entry.name)
    return ranks


def wait_for_ranks(proc: subprocess.Popen, timeout: float = 60.0) -> dict[int, int]:
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        pids = rank_pids(proc.pid)
        if len(pids) == 2:
            return pids
        time.sleep(0.01)
    raise RuntimeError("the ranks did not start")


def finish(proc, seconds: float = HANG_SECONDS):
    """(stderr, hung): wait for the job; one still running after ``seconds`` is killed."""
    try:
        return proc.communicate(timeout=seconds)[1], False
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        return proc.communicate()[1], True


def send(proc: subprocess.Popen, pids: dict[int, int], victim: str, sig: int) -> None:
    if victim == "mpiexec":
        proc.send_signal(sig)
    elif victim == "group":
        os.killpg(proc.pid, sig)
    else:
        for rank in ((0, 1) if victim == "both" else (int(victim[-1]),)):
            os.kill(pids[rank], sig)


def _running(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except (OSError, IndexError):
        return False


def still_alive(pids, deadline: float) -> list[int]:
    """The ranks still running at ``deadline`` (mpiexec may return while the
    ranks it killed are being torn down)."""
    while time.monotonic() < deadline:
        alive = [pid for pid in pids if _running(pid)]
        if not alive:
            return []
        time.sleep(0.01)
    return [pid for pid in pids if _running(pid)]


def check_file(path: Path) -> tuple[bool, int, str]:
    """(valid, samples_done, complaint) of a workspace file."""
    import h5py

    try:
        with h5py.File(path, "r") as fh:
            order, bounds = fh["grid/chunk_order"][()], fh["grid/chunk_bounds"][()]
            done = fh["samples/done"][()]
            expected = np.zeros_like(done)
            for c in np.flatnonzero(fh["grid/chunk_done"][()]):
                expected[order[bounds[c]:bounds[c + 1]]] = True
            status = fh["samples/status"][()]
            ok = (np.array_equal(done, expected) and fh.attrs["samples_done"] == done.sum()
                  and np.all(status[done] > 0) and np.all(status[~done] == 0)
                  and bool(fh.attrs["complete"]) == bool(done.all()))
            return bool(ok), int(done.sum()), "" if ok else "bookkeeping disagrees"
    except (OSError, KeyError) as err:
        return False, 0, f"unreadable: {err}"


def same_samples(a: Path, b: Path) -> bool:
    import h5py

    with h5py.File(a, "r") as fa, h5py.File(b, "r") as fb:
        for name in fa["samples"]:
            if name.startswith("seconds_"):
                continue
            x, y = fa["samples"][name][()], fb["samples"][name][()]
            same = (np.array_equal(x, y, equal_nan=True) if x.dtype.kind == "f"
                    else np.array_equal(x, y))
            if not same:
                return False
    return True


def wait_for_sampling(out: Path, proc: subprocess.Popen, timeout: float = 120.0) -> None:
    """Until the run holds its output lock (``.<name>.lock``): sampling has begun."""
    lock = out.with_name(f".{out.name}.lock")
    t0 = time.monotonic()
    while not lock.exists():
        if proc.poll() is not None or time.monotonic() - t0 > timeout:
            raise RuntimeError("the run never started sampling")
        time.sleep(0.005)


def trial(folder: Path, reference: Path, victim: str, sig: int, delay: float | None) -> dict:
    """One interruption: signal ``victim`` ``delay`` seconds after sampling began
    (``delay`` None: as soon as both ranks exist, i.e. during their set-up)."""
    out = folder / f"{victim}-{sig}-{delay}.h5"
    proc = subprocess.Popen(command(out), cwd=ROOT, env=ENV, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    pids = wait_for_ranks(proc)
    if delay is not None:
        wait_for_sampling(out, proc)
        time.sleep(delay)
    ended_before = proc.poll() is not None
    t0 = time.monotonic()
    send(proc, pids, victim, sig)
    stderr, hang = finish(proc)
    alive = still_alive(pids.values(), deadline=t0 + HANG_SECONDS)
    seconds = time.monotonic() - t0
    row = {"victim": victim, "signal": signal.Signals(sig).name, "delay": delay,
           "status": proc.returncode, "seconds": round(seconds, 2), "hang": hang or bool(alive),
           "ended_before_signal": ended_before,
           "message": next((l for l in stderr.splitlines() if "interrupted" in l), "")[:70]}
    row["file"], row["saved"], complaint = check_file(out) if out.exists() else (False, 0, "none")
    resumed = subprocess.run(command(out, "--resume"), cwd=ROOT, env=ENV, capture_output=True,
                             text=True, timeout=300)
    row["resume_equal"] = resumed.returncode == 0 and same_samples(out, reference)
    sampling = delay is not None and not ended_before
    row["ok"] = (not row["hang"] and row["resume_equal"]
                 and (row["file"] if sampling else row["file"] or not out.exists()))
    row["complaint"] = complaint
    return row


def reference_map(folder: Path) -> Path:
    ref = folder / "reference.h5"
    subprocess.run(command(ref), cwd=ROOT, env=ENV, check=True, capture_output=True, timeout=300)
    return ref


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=20)
    parser.add_argument("--load", type=int, default=0, help="busy-loop processes beside it")
    args = parser.parse_args()
    burners = [subprocess.Popen([sys.executable, "-c", "while True: pass"])
               for _ in range(args.load)]
    rows = []
    try:
        with tempfile.TemporaryDirectory() as tmp:
            folder = Path(tmp)
            reference = reference_map(folder)
            moments = (0.5, 2.0, None, 1.2)        # s after sampling began; None: set-up
            plan = [(v, s, d) for d in moments for s in (signal.SIGINT, signal.SIGTERM)
                    for v in VICTIMS]
            for k in range(args.trials):
                victim, sig, delay = plan[k % len(plan)]
                row = trial(folder, reference, victim, sig, delay)
                rows.append(row)
                print(" ".join(f"{key}={value}" for key, value in row.items()), flush=True)
    finally:
        for b in burners:
            b.kill()
    failed = [r for r in rows if not r["ok"]]
    worst = max(r["seconds"] for r in rows)
    print(f"{len(rows)} trials, {len(rows) - len(failed)} ok, {len(failed)} failed; "
          f"no hang: {not any(r['hang'] for r in rows)}; longest time from signal to the "
          f"end of every process: {worst:.2f} s; load: {args.load} busy process(es) added, "
          f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
