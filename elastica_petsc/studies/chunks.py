"""The MPI chunk engine: a grid of samples cut into chunks, handed out over the
ranks of a communicator and gathered, checkpointed and resumed on rank 0.
Used by the workspace maps (:mod:`elastica_petsc.studies.workspace`) and the
design sweeps (:mod:`elastica_petsc.studies.design_sweep`).

A grid's chunks are fixed by the grid alone: short runs of neighbouring
points, each solved in order by one rank (a sampler may warm-start along a
chunk).  So every sample's result depends on the grid only, never on the
number of ranks or on the order in which chunks are handed out, and a run
equals its interrupted-and-resumed twin.

Distribution: chunks are handed out dynamically through an MPI one-sided
atomic counter (``Fetch_and_op`` on rank 0's window), so a rank that drew
slow chunks simply takes fewer; no rank is reserved as a master.

Output: ranks send finished chunks to rank 0 (non-blocking sends, so a
rank never waits for rank 0 to finish its own chunk), which holds the
results and checkpoints them every few seconds: the first and the last
checkpoint of a run write the whole file aside and rename it into place;
the others write in place only the rows of the chunks stored since the
previous checkpoint, then their done flags (io/inplace.py), so their cost
does not grow with the samples already in the file.  A chunk is marked
done only when all its rows are on disk, so the file on disk is always a
valid file that resumes correctly (docs/model.md §23).

Stop protocol (SIGINT/SIGTERM to any rank, to mpiexec or to its process
group; :func:`run`): the stopped rank exhausts the shared chunk counter
(one-sided, no rank waits), every rank sees it at its next sample, or inside
a long one at its next load or continuation step (core/interrupt.py), and
leaves its chunk; rank 0 writes a checkpoint at once (Open MPI's mpiexec kills the
ranks about 2 s after forwarding a signal), receives until every rank has
said it finished, and writes the last one.  No collective is entered unless
every rank is known to reach it, so no rank is left in MPI_Waitall or in
PETSc's finalisation.  A rank still busy ``STOP_GRACE`` seconds after a stop
(one sample too slow) makes rank 0 return ``stranded``; the command line
then exits without MPI finalisation and mpiexec ends the rest.  A rank
killed outright loses at most the chunks finished since the previous
checkpoint (the MPI launcher ends the job: Open MPI's mpiexec does; with
srun use ``--kill-on-bad-exit=1``).  Gathering to one writer instead of
parallel HDF5 (mpio) was chosen because the data are tiny (a few hundred
bytes per sample), the h5py of Debian 12 is serial, and HDF5 writing its
own metadata when a process dies mid-write can leave a file that does not
open: rank 0 writes a file whole (aside, renamed) and afterwards only the
raw bytes of new rows, never HDF5 metadata; the measured I/O share is reported in
the file (``timing`` attributes: ``seconds_wall`` and ``seconds_io`` up to
the start of the last write, which cannot time itself; ``ranks``).

Checkpoint interval: ``checkpoint_seconds``, 2 s by default (0: after every
chunk, as the interruption tests use).  The command line reads it
from the environment variable ``ELASTICA_PETSC_CHECKPOINT_SECONDS``; the
library reads no environment variable.

Errors in the input (a bad grid, a file to resume made for another grid or
arm) are agreed on by all ranks before any work starts and raised on every
rank as :class:`CollectiveInputError`, so the command line can report one
line and exit with status 2 without ``MPI_Abort``.
"""
from __future__ import annotations

import signal
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..core import interrupt
from ..core.errors import InputError
from ..io.workspace import continue_provenance, read_results


TAG_RESULT, TAG_FINISHED = 11, 12
CHECKPOINT_SECONDS = 2.0  # default interval between checkpoints
STOP_GRACE = 5.0          # s rank 0 waits, after a stop, for the other ranks' last samples


class CollectiveInputError(InputError):
    """An input error raised on every rank alike (see :func:`agree`)."""


def agree(comm, error: str | None) -> None:
    """Collective: raise :class:`CollectiveInputError` on every rank if any rank
    found an input error (the first one by rank), so no rank is left waiting."""
    errors = comm.allgather(error)
    first = next((e for e in errors if e), None)
    if first is not None:
        raise CollectiveInputError(first)


def check_checkpoint_seconds(seconds) -> float:
    """``seconds`` between checkpoints as a float >= 0, or :class:`InputError`."""
    try:
        value = float(seconds)
    except (TypeError, ValueError):
        value = float("nan")
    if not value >= 0:
        raise InputError(f"checkpoint interval {seconds!r}: expected seconds >= 0")
    return value


@dataclass(frozen=True)
class Grid:
    """Sample points and their fixed chunks.

    ``points`` are targets in mm (mode ``targets``) or tensions p (mode
    ``tensions``); ``chunks`` lists index arrays in warm-start order.
    """

    mode: str
    points: np.ndarray
    chunks: tuple[np.ndarray, ...]
    meta: dict = field(default_factory=dict)

    @property
    def size(self) -> int:
        return len(self.points)


def rows_to_chunks(rows: list[np.ndarray], chunk: int) -> tuple[np.ndarray, ...]:
    """Each row of sample indices cut into chunks of at most ``chunk``."""
    out = []
    for row in rows:
        for start in range(0, len(row), chunk):
            out.append(row[start:start + chunk])
    return tuple(out)


def empty_fields(schema: dict, count: int) -> dict[str, np.ndarray]:
    """Arrays for ``count`` samples of every field of ``schema`` (name -> (shape per
    sample, dtype, units, description), e.g.
    :func:`~elastica_petsc.studies.workspace.schema.fields`):
    NaN for floats, 0 for integers, b"" for strings (not computed yet)."""
    out = {}
    for name, (shape, dtype, _, _) in schema.items():
        fill = b"" if dtype.startswith("S") else (0 if dtype[0] in "i?" else np.nan)
        out[name] = np.full((count,) + shape, fill, dtype=dtype)
    return out


class ChunkResults:
    """Every sample's fields of a grid in memory (rank 0), with per-chunk done
    flags; a study's subclass writes its file (:meth:`write`)."""

    def __init__(self, grid: Grid, schema: dict):
        self.grid = grid
        self.schema = schema
        self.data = empty_fields(self.schema, grid.size)
        self.chunk_done = np.zeros(len(grid.chunks), bool)
        self._chunk_sizes = np.array([len(c) for c in grid.chunks], np.int64)
        self.stranded = False            # other ranks still busy after a stop (see run)
        self.write_error = None          # why a checkpoint could not be written (see run)
        self.unsaved: list[int] = []     # chunks stored since the last checkpoint
        self.checkpoints: list[tuple[str, int, float]] = []   # (kind, samples written, s)

    def store(self, chunk: int, values: dict) -> None:
        index = self.grid.chunks[chunk]
        for name, array in values.items():
            self.data[name][index] = array
        self.chunk_done[chunk] = True
        self.unsaved.append(chunk)

    def clear_undone(self) -> None:
        """Empty values for every sample of a chunk not done (a file read back may
        hold rows of an update that was not committed, io/inplace.py)."""
        undone = np.ones(self.grid.size, bool)
        for c in np.flatnonzero(self.chunk_done):
            undone[self.grid.chunks[c]] = False
        empty = empty_fields(self.schema, int(undone.sum()))
        for name, values in self.data.items():
            values[undone] = empty[name]

    def write(self, path: Path, attrs: dict, limits: dict, timing: dict):
        """One checkpoint of the whole file (always valid: written aside, renamed);
        returns its :class:`~elastica_petsc.io.inplace.Layout` for :meth:`update`."""
        raise NotImplementedError

    def extra_rows(self, samples: np.ndarray, limits: dict) -> list:
        """A study's own in-place rows for ``samples`` beyond ``samples/`` (e.g.
        masks), as (dataset, index, values)."""
        return []

    MARKER = None      # the field that says a sample was computed (e.g. "status")

    def update(self, layout, chunks: list[int], limits: dict, timing: dict) -> bool:
        """One checkpoint in place (io/inplace.py): the rows of the samples of
        ``chunks`` only, then (the commit) their derived rows (:meth:`extra_rows`),
        their :attr:`MARKER` field and their done flags.  False if the file
        cannot be updated so (then :meth:`write` it in full)."""
        from ..io.workspace import UPDATED_TIMING

        chunks = np.asarray(sorted(set(chunks)), np.int64)
        samples = (np.concatenate([self.grid.chunks[c] for c in chunks]) if len(chunks)
                   else np.zeros(0, np.int64))
        rows = [(f"samples/{name}", samples, self.data[name][samples]) for name in self.schema
                if name != self.MARKER]
        commit = self.extra_rows(samples, limits)
        if self.MARKER is not None:
            commit.append((f"samples/{self.MARKER}", samples, self.data[self.MARKER][samples]))
        commit += [("grid/chunk_done", chunks, np.ones(len(chunks), bool)),
                   ("samples/done", samples, np.ones(len(samples), bool))]
        attrs = {"samples_done": self.samples_done}
        attrs.update({f"timing/{key}": timing.get(key, 0.0) for key in UPDATED_TIMING})
        if not layout.covers([name for name, _, _ in rows + commit], attrs):
            return False
        return layout.write(rows, commit, attrs)

    @property
    def samples_done(self) -> int:
        return int(self._chunk_sizes[self.chunk_done].sum())


def check_out(out, resume: bool, overwrite: bool) -> Path:
    from ..io.hdf5 import check_output_path

    path = Path(out)
    if resume and path.exists():
        check_output_path(path, overwrite=True)
        return path
    return check_output_path(path, overwrite)


class Stop:
    """The stop request of a run: SIGINT/SIGTERM on this rank, or any rank's
    (seen through the shared chunk counter, which a stopping rank exhausts).

    Calling it returns True once a stop was requested; work stops at the next
    sample boundary.  The signal handler only sets a flag (no MPI call in a
    handler); the first call that sees it exhausts the counter, so the other
    ranks take no new chunk and leave their current one at its next sample.
    """

    POLL = 0.01                       # s between looks at the shared counter

    def __init__(self):
        self.counter = None           # attached by run() once the counter exists
        self.signalled = False
        self._old = {}
        self._next_poll = 0.0

    def __enter__(self):
        for sig in (signal.SIGINT, signal.SIGTERM):
            self._old[sig] = signal.signal(sig, self._handle)
        return self

    def _handle(self, signum, frame):
        self.signalled = True

    def __exit__(self, *exc):
        for sig, handler in self._old.items():
            signal.signal(sig, handler)

    def __call__(self) -> bool:
        if self.counter is None:
            return self.signalled
        if self.signalled:
            self.counter.exhaust()
            return True
        if self.counter.exhausted:
            return True
        now = time.monotonic()
        if now >= self._next_poll:
            self._next_poll = now + self.POLL
            self.counter.peek()
        return self.counter.exhausted


class _NoProgress:
    def update(self, done: int) -> None:
        pass

    close = update


class ChunkCounter:
    """Shared counter for dynamic scheduling: an atomic fetch-and-add on rank 0.

    ``exhaust()`` (any rank, on a stop) pushes it past any chunk index, so no
    rank takes a new chunk; ``peek()`` lets a busy rank see that.  Every
    operation is one-sided (passive target): no rank waits for another."""

    EXHAUSTED = 2 ** 60

    def __init__(self, comm):
        from mpi4py import MPI
        self.MPI = MPI
        self.win = MPI.Win.Allocate(8 if comm.rank == 0 else 0, 8, comm=comm)
        if comm.rank == 0:
            self.win.Lock(0)
            self.win.Put(np.zeros(1, "i8"), 0)
            self.win.Unlock(0)
        comm.Barrier()
        self._one, self._got = np.ones(1, "i8"), np.zeros(1, "i8")
        self._zero = np.zeros(1, "i8")
        self.exhausted = False

    def _add(self, value, op=None) -> int:
        self.win.Lock(0, self.MPI.LOCK_SHARED)
        self.win.Fetch_and_op(value, self._got, 0, 0, op or self.MPI.SUM)
        self.win.Unlock(0)
        k = int(self._got[0])
        if k >= self.EXHAUSTED:
            self.exhausted = True
        return k

    def next(self) -> int:
        return self._add(self._one)

    def peek(self) -> int:
        return self._add(self._zero, self.MPI.NO_OP)

    def exhaust(self) -> None:
        if not self.exhausted:
            self._add(np.full(1, self.EXHAUSTED, "i8"))
            self.exhausted = True

    def free(self) -> None:
        self.win.Free()


class LocalCounter:
    """The chunk counter of a run on one process (``comm.size == 1``): a plain
    integer with :class:`ChunkCounter`'s interface, no MPI window (a window on
    COMM_SELF of one rank of a larger job makes OpenMPI's finalisation wait
    for the other ranks forever)."""

    def __init__(self):
        self.count = 0
        self.exhausted = False

    def next(self) -> int:
        k, self.count = self.count, self.count + 1
        self.exhausted = k >= ChunkCounter.EXHAUSTED
        return k

    def peek(self) -> int:
        return self.count

    def exhaust(self) -> None:
        self.count, self.exhausted = ChunkCounter.EXHAUSTED, True

    def free(self) -> None:
        pass


class _Collector:
    """Rank 0's side: stores chunks (its own and those other ranks send), writes
    checkpoints, and knows how many ranks have finished."""

    def __init__(self, comm, counter, results: ChunkResults, out, attrs, limits,
                 checkpoint_seconds, bar):
        self.comm, self.counter, self.results, self.out = comm, counter, results, out
        self.attrs, self.limits, self.bar = attrs, limits, bar
        self.checkpoint_seconds = checkpoint_seconds
        self.finished = 1                                  # rank 0 itself, once done
        self.timing = {"ranks": comm.size, "seconds_io": 0.0}
        self.layout = None             # of the file last written in full (io/inplace.py)
        self.t_start = self.last_write = time.perf_counter()

    def checkpoint(self, full: bool = False) -> None:
        """Write the chunks stored since the last checkpoint into the file in place
        (O(new samples), io/inplace.py), or the whole file (``full``, the first and
        the last checkpoint of a run, or a file that cannot be updated in place).
        A failed write (full disk) stops the run like a signal: the file keeps
        its previous checkpoint, the error is reported at the end."""
        if self.out is None or self.results.write_error is not None:
            return
        t0 = time.perf_counter()
        self.timing["seconds_wall"] = t0 - self.t_start
        results = self.results
        new = sum(len(results.grid.chunks[c]) for c in results.unsaved)
        try:
            if (full or self.layout is None
                    or not results.update(self.layout, results.unsaved, self.limits, self.timing)):
                self.layout, new = results.write(self.out, self.attrs, self.limits,
                                                 self.timing), results.grid.size
                full = True
            results.unsaved.clear()
        except InputError as err:
            results.write_error = str(err)
            self.counter.exhaust()
        self.last_write = time.perf_counter()
        self.timing["seconds_io"] += self.last_write - t0
        results.checkpoints.append(("full" if full else "in place", new, self.last_write - t0))

    def store(self, chunk: int, values: dict) -> None:
        self.results.store(chunk, values)
        self.drain()
        if time.perf_counter() - self.last_write > self.checkpoint_seconds:
            self.checkpoint()

    def drain(self) -> None:
        """Store every chunk other ranks have sent so far (no waiting)."""
        from mpi4py import MPI

        status = MPI.Status()
        while self.comm.iprobe(source=MPI.ANY_SOURCE, tag=MPI.ANY_TAG, status=status):
            message = self.comm.recv(source=status.Get_source(), tag=status.Get_tag())
            if status.Get_tag() == TAG_FINISHED:
                self.finished += 1
            else:
                self.results.store(*message)
        self.bar.update(self.results.samples_done)

    def wait_for_ranks(self, stop) -> bool:
        """Receive until every rank has finished; after a stop at most ``STOP_GRACE``
        seconds (a stopped rank ends within one sample).  True if all finished."""
        deadline = None
        while True:
            self.drain()
            if self.finished >= self.comm.size:
                return True
            if stop():
                deadline = deadline or time.monotonic() + STOP_GRACE
                if time.monotonic() > deadline:
                    return False
            time.sleep(0.002)


def _work(grid: Grid, sampler, todo: np.ndarray, counter: ChunkCounter, stop, deliver) -> None:
    """Take chunks from the shared counter until none is left or a stop; hand each
    finished chunk to ``deliver(chunk, values)``."""
    while not stop():
        k = counter.next()
        if k >= len(todo):
            return
        chunk = int(todo[k])
        try:
            with interrupt.watching(stop):     # a stop inside a long sample, too
                values = sampler.solve_chunk(grid.points[grid.chunks[chunk]], stop)
        except interrupt.Stopped:
            values = None
        if values is None:
            return
        deliver(chunk, values)


def _load(out, attrs: dict, resume: bool, comm, new_results) -> tuple:
    """Rank 0 reads the file to resume (or starts afresh); every rank learns which
    chunks are done.  A file that cannot be resumed raises on every rank.
    ``new_results()``: the study's empty results (a :class:`ChunkResults`)."""
    results = chunk_done = error = None
    if comm.rank == 0:
        try:
            fresh = new_results()
            results = (read_results(out, attrs, fresh)
                       if resume and out is not None and out.exists() else fresh)
            chunk_done = results.chunk_done
            if out is not None and resume and out.exists():
                continue_provenance(out, attrs)
        except InputError as err:
            error = str(err)
    error, chunk_done = comm.bcast((error, chunk_done), root=0)
    if error is not None:
        raise CollectiveInputError(error)
    return results, np.flatnonzero(~chunk_done)


def run(grid: Grid, sampler, out: Path | None, attrs: dict, limits: dict, *, comm, resume: bool,
        new_results, checkpoint_seconds: float | None = None, progress=None,
        progress_label: str = "workspace", stop: "Stop | None" = None) -> ChunkResults | None:
    """Sample the whole grid over the ranks of ``comm`` (stop protocol below).

    ``sampler.solve_chunk(points, stop) -> dict of per-sample arrays`` (or
    None when ``stop()`` became true mid-chunk) is called on every rank.
    Returns the results on rank 0 (None elsewhere); ``results.chunk_done.all()``
    is False after an interruption, and ``results.stranded`` is True when other
    ranks did not finish within ``STOP_GRACE`` of a stop (the caller must then
    end the process without MPI finalisation, e.g. ``os._exit``).

    Stop protocol: a stopped rank exhausts the shared counter (one-sided), so
    every rank leaves its chunk at the next sample; rank 0 writes a checkpoint
    at once (a launcher kills the ranks ~2 s after forwarding a signal), then
    receives until every rank has finished, then writes the last one.  No
    collective is entered unless every rank is known to reach it.  ``stop``: a
    :class:`Stop` already catching signals (a study installs it before its
    set-up, so a signal there stops the run at its first sample).
    ``new_results``: a callable returning the study's empty
    :class:`ChunkResults` (its own schema and file layout).  ``attrs``: the
    file's root attributes, which a resumed file must match
    (:func:`~elastica_petsc.io.workspace.read_results`); ``limits``: passed to
    the results' :meth:`~ChunkResults.write`.  ``progress``: True (a bar on
    rank 0, ui/progress.py), None/False (none), or an object with
    ``update(done)`` and ``close(done)``.
    """
    if stop is None:
        with Stop() as stop:
            return run(grid, sampler, out, attrs, limits, comm=comm, resume=resume,
                       checkpoint_seconds=checkpoint_seconds, progress=progress,
                       progress_label=progress_label, stop=stop, new_results=new_results)
    from ..ui.progress import Progress

    checkpoint_seconds = check_checkpoint_seconds(
        CHECKPOINT_SECONDS if checkpoint_seconds is None else checkpoint_seconds)
    results, todo = _load(out, attrs, resume, comm, new_results)
    counter = stop.counter = ChunkCounter(comm) if comm.size > 1 else LocalCounter()
    if comm.rank == 0:
        bar = (Progress(grid.size, progress_label, already=results.samples_done)
               if progress is True else progress if progress else _NoProgress())
        rank0 = _Collector(comm, counter, results, out, attrs, limits, checkpoint_seconds,
                           bar)
        _work(grid, sampler, todo, counter, stop, rank0.store)
        if stop():
            rank0.drain()
            rank0.checkpoint()                         # before a launcher can kill us
        all_done = rank0.wait_for_ranks(stop)
        rank0.checkpoint(full=True)                    # complete, final timing
        bar.close(results.samples_done)
        results.stranded = not all_done
        if not all_done:
            return results                             # no collective: a peer is busy
    else:
        sends = []                                     # results on their way to rank 0
        # non-blocking: a chunk's results exceed the eager limit of shared-memory MPI,
        # and a blocking send would wait until rank 0 ends its own chunk (BENCHMARKS.md,
        # "Timing notes from the docstrings"); rank 0 receives until this rank says FINISHED
        _work(grid, sampler, todo, counter, stop,
              lambda chunk, values: sends.append(
                  comm.isend((chunk, values), dest=0, tag=TAG_RESULT)))
        from mpi4py import MPI
        MPI.Request.waitall(sends)
        comm.send(None, dest=0, tag=TAG_FINISHED)
    counter.free()                      # collective: every rank finished (rank 0 saw it)
    return results
