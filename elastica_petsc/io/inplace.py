"""Checkpoints that write only what is new (issue 25): a file written once in
full (built in memory, renamed into place: :func:`~elastica_petsc.io.hdf5.atomic_h5`)
and then updated in place, row by row, without HDF5.

:class:`FullWrite` writes the whole file and records its :class:`Layout`: the
byte offset of every contiguous dataset (``h5py`` ``get_offset``) and of the
scalar attributes marked as updatable (written first as a random 8-byte
sentinel, found once in the file's image, then set to their value).  A later
checkpoint (:meth:`Layout.write`) overwrites, with plain ``pwrite`` calls,
only the rows of the samples finished since: no HDF5 metadata (object headers,
B-trees, superblock) is ever touched again, so the file stays a valid HDF5
file whatever moment a process dies at.  Order of one update: the new rows
(data), ``fsync``; then the commit (derived rows, the field that marks a
sample computed, per-chunk done flags of one byte each, the counters),
``fsync`` (``ChunkResults.update``).  A chunk flagged done therefore has all
its rows on disk; rows of chunks not flagged may hold anything and are emptied
when the file is read back (``ChunkResults.clear_undone``).  Cost: proportional to the
new rows (contiguous runs of rows are one ``pwrite`` each), independent of the
rows already in the file (BENCHMARKS.md, "Checkpoints O(new samples)").
"""
from __future__ import annotations

import io
import os
import secrets
from pathlib import Path

import numpy as np

from ..core.errors import InputError


class Layout:
    """Byte offsets of a file's contiguous datasets and updatable attributes, and
    the identity (inode, device) of the file they belong to."""

    def __init__(self, path: Path, datasets: dict, attrs: dict):
        self.path = Path(path)
        self.datasets = datasets          # name -> (offset, shape, dtype)
        self.attrs = attrs                # "group/attr" -> (offset, dtype)
        st = os.stat(self.path)
        self.identity = (st.st_ino, st.st_dev)

    def covers(self, names, attrs=()) -> bool:
        return all(n in self.datasets for n in names) and all(a in self.attrs for a in attrs)

    def write(self, rows: list, commit: list, attrs: dict) -> bool:
        """Overwrite ``rows`` (a list of (dataset, index, values): ``index`` a 1-D
        array of rows, or a tuple of arrays over the leading dimensions), fsync,
        then ``commit`` (same form) and ``attrs`` (``"group/attr"`` -> value), fsync.
        False (nothing written) if the file at the path is no longer the one
        this layout describes."""
        from .hdf5 import OutputError

        try:
            fd = os.open(self.path, os.O_WRONLY | os.O_NOFOLLOW | os.O_CLOEXEC)
        except FileNotFoundError:
            return False
        except OSError as err:
            raise OutputError(f"cannot write {self.path}: {err.strerror or err}") from None
        try:
            st = os.fstat(fd)
            if (st.st_ino, st.st_dev) != self.identity:
                return False
            for name, index, values in rows:
                self._put(fd, name, index, values)
            os.fsync(fd)
            for name, index, values in commit:
                self._put(fd, name, index, values)
            for key, value in attrs.items():
                offset, dtype = self.attrs[key]
                _pwrite_all(fd, np.asarray(value, dtype).tobytes(), offset)
            os.fsync(fd)
        except OSError as err:
            raise OutputError(f"cannot write {self.path}: {err.strerror or err}") from None
        finally:
            os.close(fd)
        return True

    def _put(self, fd: int, name: str, index, values) -> None:
        """Rows ``index`` of dataset ``name`` set to ``values``: one pwrite per run
        of consecutive rows."""
        offset, shape, dtype = self.datasets[name]
        lead = index if isinstance(index, tuple) else (index,)
        flat = (np.ravel_multi_index(lead, shape[:len(lead)]) if len(lead) > 1
                else np.asarray(lead[0], np.int64))
        if flat.size == 0:
            return
        order = np.argsort(flat, kind="stable")
        flat = flat[order]
        block = np.ascontiguousarray(np.asarray(values, dtype)[order])
        row_bytes = block.itemsize * int(np.prod(shape[len(lead):], dtype=np.int64))
        data = memoryview(block.reshape(-1)).cast("B")
        breaks = np.flatnonzero(np.diff(flat) != 1) + 1
        starts = np.concatenate(([0], breaks))
        ends = np.concatenate((breaks, [flat.size]))
        for a, b in zip(starts.tolist(), ends.tolist()):
            _pwrite_all(fd, data[a * row_bytes:b * row_bytes], offset + int(flat[a]) * row_bytes)


def _pwrite_all(fd: int, data, offset: int) -> None:
    data = memoryview(data).cast("B")
    while len(data):
        written = os.pwrite(fd, data, offset)
        data, offset = data[written:], offset + written


class FullWrite:
    """Context manager: an ``h5py.File`` to fill, written in full at ``path``
    (:func:`~elastica_petsc.io.hdf5.atomic_h5`'s way) on leaving, after which
    ``layout`` is its :class:`Layout`."""

    def __init__(self, path: Path):
        self.path = Path(path)
        self.layout = None
        self._marks = {}                  # "group/attr" -> (sentinel bytes, value, dtype)

    def __enter__(self):
        import h5py

        from .hdf5 import check_output_path, remove_orphans

        self.path = check_output_path(self.path, overwrite=True)
        remove_orphans(self.path)
        self._buffer = io.BytesIO()
        self._file = h5py.File(self._buffer, "w")
        return self

    @property
    def file(self):
        return self._file

    def mark(self, group, name: str, value, dtype: str) -> None:
        """Attribute ``name`` of ``group`` set to ``value``, updatable in place."""
        while True:
            sentinel = np.frombuffer(secrets.token_bytes(8), dtype)[0]
            if np.isfinite(sentinel) and sentinel != 0:
                break
        group.attrs[name] = sentinel
        key = f"{group.name.strip('/')}/{name}".strip("/")
        self._marks[key] = (sentinel.tobytes(), value, dtype)

    def __exit__(self, kind, err, tb) -> None:
        from .exclusive import replace_file
        from .hdf5 import OutputError

        self._file.close()
        if kind is not None:
            return
        datasets = _dataset_offsets(self._buffer)
        image = self._buffer.getbuffer()
        attrs = {}
        try:
            found = _find(image, [sentinel for sentinel, _, _ in self._marks.values()])
            for key, (sentinel, _, dtype) in self._marks.items():
                if len(found[sentinel]) != 1:
                    raise RuntimeError(f"attribute {key}: its value is not stored verbatim "
                                       "once in the HDF5 image (io/inplace.py needs HDF5's "
                                       "default file format, libver earliest)")
                attrs[key] = (found[sentinel][0], dtype)
            for key, (offset, dtype) in attrs.items():
                image[offset:offset + 8] = np.asarray(self._marks[key][1], dtype).tobytes()
            replace_file(self.path, image)
        except InputError:
            raise
        except OSError as err:
            raise OutputError(f"cannot write {self.path}: {err.strerror or err}") from None
        finally:
            image.release()
        self.layout = Layout(self.path, datasets, attrs)


def _find(image: memoryview, patterns, block: int = 1 << 26) -> dict[bytes, list[int]]:
    """Offsets of each of ``patterns`` (of 8 bytes) in ``image``, in one pass by
    blocks (no copy of the whole image)."""
    found = {pattern: set() for pattern in patterns}
    for start in range(0, len(image), block):
        piece = bytes(image[start:start + block + 7])
        for pattern, offsets in found.items():
            at = piece.find(pattern)
            while at >= 0:
                offsets.add(start + at)
                at = piece.find(pattern, at + 1)
    return {pattern: sorted(offsets) for pattern, offsets in found.items()}


def _dataset_offsets(buffer: io.BytesIO) -> dict:
    """name -> (byte offset, shape, dtype) of every contiguous dataset allocated in
    the HDF5 image ``buffer``."""
    import h5py

    out = {}

    def visit(name, obj):
        if isinstance(obj, h5py.Dataset) and obj.chunks is None and obj.shape:
            offset = obj.id.get_offset()
            if offset is not None and obj.dtype.kind in "biufS":
                out[name] = (int(offset), obj.shape, obj.dtype)

    buffer.seek(0)
    with h5py.File(buffer, "r") as fh:
        fh.visititems(visit)
    return out
