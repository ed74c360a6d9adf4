"""Cooperative stops inside long work (a sample of a workspace map can take
tens of seconds: a seed library, a boundary proof, a long tip-control solve).

A run that must stop quickly (under ``mpiexec``, which kills the ranks about
2 s after forwarding a signal) installs its stop test with :func:`watching`;
the solvers call :func:`check` at every load step, continuation step and
tip-control evaluation, and :func:`check` raises :class:`Stopped` once the
test is true.  The run catches :class:`Stopped` where a unit of its work
begins (studies/workspace.py: the chunk is left undone, as a stop between
samples leaves it).  Without a test installed :func:`check` does nothing.
"""
from __future__ import annotations

import contextlib

_TESTS: list = []


class Stopped(BaseException):
    """A stop was requested inside a unit of work (not an ``Exception``: no
    ``except Exception`` on the way may take it for a failed solve)."""


@contextlib.contextmanager
def watching(stop):
    """Within the block, :func:`check` raises :class:`Stopped` once ``stop()``
    is true."""
    _TESTS.append(stop)
    try:
        yield
    finally:
        _TESTS.remove(stop)


def check() -> None:
    if _TESTS and _TESTS[-1]():
        raise Stopped()
