"""What every public result type shares (:class:`Result`): a short ``repr``,
``summary() -> dict`` and ``save(path)``.

A result type is a frozen dataclass declared with ``repr=False`` that derives
from :class:`Result`.  Its ``repr`` names the type and its scalar fields and
gives arrays by shape only, so ``print(result)`` never dumps arrays;
``summary()`` is a JSON-ready dict (by default the scalar fields and small
arrays; types with a richer summary, the one ``--json`` prints, override it);
``save(path)``
writes the HDF5 file that :func:`elastica_petsc.read` reads back into an
equal result (through the package's public :func:`elastica_petsc.save`, so
this numpy-only layer never imports the HDF5 layer).
"""
from __future__ import annotations

import dataclasses
import enum
from pathlib import Path

import numpy as np

SCALARS = (bool, int, float, str, np.bool_, np.integer, np.floating)
REPR_FIELDS = 8          # scalar fields shown by repr before "..."
SUMMARY_VALUES = 16      # numeric arrays up to this size appear in the default summary


def scalar_fields(result) -> dict:
    """The constructor fields of a dataclass that are numbers, strings, None or
    small numeric arrays (at most :data:`SUMMARY_VALUES` values, as lists), as
    JSON values (enums by name, numpy scalars as Python numbers)."""
    out = {}
    for field in dataclasses.fields(result):
        if field.name.startswith("_"):
            continue
        value = getattr(result, field.name)
        if isinstance(value, enum.Enum):
            out[field.name] = value.name
        elif value is None or isinstance(value, SCALARS):
            out[field.name] = value.item() if isinstance(value, np.generic) else value
        elif isinstance(value, Path):
            out[field.name] = str(value)
        elif (isinstance(value, np.ndarray) and value.size <= SUMMARY_VALUES
              and value.dtype.kind in "biuf"):
            out[field.name] = value.tolist()
    return out


def _short(value) -> str:
    if isinstance(value, np.ndarray):
        return f"array{value.shape}"
    if isinstance(value, (list, tuple, dict)):
        return f"{type(value).__name__}[{len(value)}]"
    if dataclasses.is_dataclass(value):
        return f"{type(value).__name__}(...)"
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def short_repr(result) -> str:
    """``TypeName(field=value, ..., arrays=array(shape))`` on one line."""
    shown = [f"{f.name}={_short(getattr(result, f.name))}"
             for f in dataclasses.fields(result) if not f.name.startswith("_")]
    more = len(shown) > REPR_FIELDS
    return f"{type(result).__name__}({', '.join(shown[:REPR_FIELDS])}{', ...' if more else ''})"


class Result:
    """Mixin of the public result types (declare the dataclass with ``repr=False``)."""

    def __repr__(self) -> str:
        return short_repr(self)

    def summary(self) -> dict:
        """The result's scalar fields and small arrays as a JSON-ready dict."""
        return scalar_fields(self)

    def save(self, path, *, overwrite: bool = False) -> Path:
        """Write this result to ``path`` (.h5); ``elastica_petsc.read(path)`` returns
        an equal result.  Returns the path."""
        import elastica_petsc

        return elastica_petsc.save(self, path, overwrite=overwrite)
