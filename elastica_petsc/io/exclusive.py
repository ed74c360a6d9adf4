"""Files that only this tool creates beside an output: the output lock and the
temporaries that are renamed into place.

Both are created with ``O_CREAT | O_EXCL | O_NOFOLLOW``: never through a
symbolic link, never truncating a file that is already there (a
``.out.h5.lock`` planted as a link to another file leaves that file as it
was).  The lock is an ``flock`` (released by the kernel when the process
dies); the lock file of a run that died is recognised (no process holds its
flock, it holds a process id or nothing) and replaced by a new one.  Every
command that writes takes the lock of each output before computing
(:func:`lock_outputs`); a lock is re-entrant within a process, so the
writers below it (``atomic_h5``, the workspace's checkpoints) take it again
freely.
"""
from __future__ import annotations

import contextlib
import os
import secrets
import stat
from pathlib import Path

from ..core.errors import InputError

CREATE = os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC
_HELD: dict[str, list] = {}          # real path of the output -> [fd, lock path, count]


class LockError(InputError):
    """An output that another run is writing, or whose lock file is not ours."""


def lock_path(path: Path) -> Path:
    return path.with_name(f".{path.name}.lock")


def _open_lock(lock: Path) -> tuple[int, bool]:
    """(fd, created): a new lock file, or the existing regular file at ``lock``."""
    try:
        return os.open(lock, CREATE | os.O_RDWR, 0o644), True
    except FileExistsError:
        pass
    try:
        fd = os.open(lock, os.O_RDWR | os.O_NOFOLLOW | os.O_CLOEXEC)
    except OSError as err:
        raise LockError(f"{lock}: the output's lock file is a symbolic link or cannot be "
                        f"opened ({err.strerror}); remove it") from None
    if not stat.S_ISREG(os.fstat(fd).st_mode):
        os.close(fd)
        raise LockError(f"{lock}: the output's lock file is not a regular file; remove it")
    return fd, False


def _acquire(path: Path) -> int:
    """The flock of ``path``'s lock file, holding this process id (see module doc)."""
    import fcntl

    lock = lock_path(path)
    for _ in range(8):
        fd, created = _open_lock(lock)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            owner = os.pread(fd, 32, 0).decode(errors="replace").strip() or "?"
            os.close(fd)
            raise LockError(f"{path} is being written by another run (pid {owner}); wait for "
                            "it to end or choose another output name") from None
        here, now = os.fstat(fd), _lstat(lock)
        if now is None or (now.st_ino, now.st_dev) != (here.st_ino, here.st_dev):
            os.close(fd)                     # replaced meanwhile: try again
            continue
        if created:
            os.pwrite(fd, str(os.getpid()).encode(), 0)
            return fd
        content = os.pread(fd, 64, 0).decode(errors="replace").strip()
        if content and not content.isdigit():
            os.close(fd)
            raise LockError(f"{lock}: exists and is not a lock file of this tool; remove it "
                            "or choose another output name")
        os.unlink(lock)                      # the lock of a run that died: a new one
        os.close(fd)
    raise LockError(f"{lock}: could not take the output's lock (it keeps changing)")


def _lstat(path: Path):
    try:
        return os.lstat(path)
    except FileNotFoundError:
        return None


class OutputLock:
    """Exclusive ownership of an output file for the duration of a run (module
    doc); a second run on the same file is refused with :class:`LockError`."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self.key = os.path.realpath(self.path)
        held = _HELD.get(self.key)
        if held is not None:
            held[2] += 1
        else:
            _HELD[self.key] = [_acquire(self.path), lock_path(self.path), 1]
        self.held = True

    def release(self) -> None:
        if not self.held:
            return
        self.held = False
        held = _HELD[self.key]
        held[2] -= 1
        if held[2] == 0:
            del _HELD[self.key]
            with contextlib.suppress(OSError):
                os.unlink(held[1])
            os.close(held[0])                # closing releases the flock

    def __enter__(self) -> "OutputLock":
        return self

    def __exit__(self, *exc) -> None:
        self.release()


def lock_outputs(paths) -> list[OutputLock]:
    """The locks of every output path (None and '' skipped), all or none."""
    locks = []
    try:
        for path in paths:
            if path:
                locks.append(OutputLock(path))
    except BaseException:
        for lock in locks:
            lock.release()
        raise
    return locks


@contextlib.contextmanager
def temporary_beside(path: Path, mode: int = 0o666):
    """A new temporary file ``.<name>.tmp-<random>-<pid>`` beside ``path``,
    created exclusively (no link followed, nothing truncated): yields
    (binary file object, its path); the caller renames it into place; it is
    removed if still there afterwards."""
    tmp = path.with_name(f".{path.name}.tmp-{secrets.token_hex(4)}-{os.getpid()}")
    fd = os.open(tmp, CREATE | os.O_WRONLY, mode)
    try:
        with os.fdopen(fd, "wb") as raw:
            yield raw, tmp
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)


def replace_file(path: Path, data) -> None:
    """Put ``data`` (bytes) at ``path`` atomically: under the output's lock,
    written to an exclusive temporary, synced and renamed into place."""
    with OutputLock(path), temporary_beside(path) as (raw, tmp):
        raw.write(data)
        raw.flush()
        os.fsync(raw.fileno())
        os.replace(tmp, path)
