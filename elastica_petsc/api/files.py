"""Results to files and back: :func:`save` any result, :func:`read` any file
the tool wrote."""
from __future__ import annotations

from pathlib import Path

from .states import State


def save(result, path: str | Path, *, overwrite: bool = False) -> Path:
    """Write any result of this package to ``path`` (.h5, also ``result.save(path)``):
    the command line's layout where it has one, with units and provenance, and
    the whole result, so that :func:`read` returns an equal one."""
    from ..io.save import save_result

    return save_result(path, result, overwrite=overwrite)


def read(path: str | Path):
    """Load a file written by the tool back into its result: the saved type
    itself for files written by :func:`save` (``result.save(path)``) and by
    ``control --out`` (a ``ControlResult``), ``trace --out`` (a
    ``TracedSchedule``), ``boundary --out`` (a ``BoundaryResult``), ``simulate
    --out`` (a ``SimulationResult``) and ``calibrate --h5`` (a
    ``CalibrationResult``); a :class:`State` for ``solve``/``stability`` files
    (the final state), a ``WorkspaceMap`` for workspace maps, otherwise a
    dict of its datasets."""
    from ..io.reader import file_kind, open_h5, read_file
    from ..io.records import has_result, read_result

    with open_h5(path) as fh:
        if has_result(fh):
            return read_result(fh)
    if file_kind(path) == "workspace":
        from ..studies.workspace import read_map
        return read_map(path)
    return read_file(path, State)
