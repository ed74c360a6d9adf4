"""Any result object as an HDF5 group, and back: the ``result`` group of a saved file.

:func:`~elastica_petsc.io.save.save_result` writes a result the way the
command line writes it (where the command has a layout) and, beside it, the
whole result under ``/result`` (:func:`encode`), so that :func:`read_result`
returns the same type with the same fields.

Encoding of ``/result`` (every node carries an attribute ``kind``):

* ``dataclass``: a group with attribute ``type`` (``module:qualname``) and one
  child per constructor field (fields named ``_...`` are caches: not stored;
  a field declared ``repr=False`` that holds a live solver object, such as
  the constraint a boundary curve followed, is stored as None with attribute
  ``dropped`` naming its type: it is a working reference, not data);
* ``array``: a dataset (strings: fixed-length UTF-8 bytes, attribute
  ``strings``: True, or "object" for an object array of str);
* ``none``, ``bool``, ``int``, ``float``, ``str``, ``path``: a scalar dataset;
* ``list``, ``tuple``: a group of children ``0``, ``1``, ...;
* ``dict``: a group of children ``0``, ``1``, ... and attribute ``keys_json``
  (keys are strings or integers);
* ``enum``: an integer dataset with attribute ``type``;
* ``loading``: a :class:`~elastica_petsc.core.loading.Loading` as its
  vertices (dataset ``vertices``, attribute ``n_tendons``).

Equality after a round trip is exact: floats are stored as float64, arrays
with their dtype.
"""
from __future__ import annotations

import dataclasses
import enum
import json
from importlib import import_module
from pathlib import Path

import numpy as np

from ..core.errors import InputError
from ..core.loading import Loading

RESULT_GROUP = "result"


# --- writing -------------------------------------------------------------------------
def encode(group, name: str, value) -> None:
    """``value`` as child ``name`` of the h5py ``group``."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        _encode_dataclass(group.create_group(name), value)
    elif isinstance(value, Loading):
        node = group.create_group(name)
        node.attrs["kind"] = "loading"
        node.attrs["n_tendons"] = len(value.p)
        node.create_dataset("vertices", data=value.vertices())
    elif isinstance(value, (list, tuple)):
        node = group.create_group(name)
        node.attrs["kind"] = type(value).__name__
        for i, item in enumerate(value):
            encode(node, str(i), item)
    elif isinstance(value, dict):
        node = group.create_group(name)
        node.attrs["kind"] = "dict"
        keys = list(value)
        if not all(isinstance(k, (str, int)) and not isinstance(k, bool) for k in keys):
            raise TypeError(f"{name}: dict keys must be strings or integers")
        node.attrs["keys_json"] = json.dumps(keys)
        for i, item in enumerate(value.values()):
            encode(node, str(i), item)
    else:
        _encode_leaf(group, name, value)


def _encode_dataclass(node, value) -> None:
    cls = type(value)
    node.attrs["kind"] = "dataclass"
    node.attrs["type"] = f"{cls.__module__}:{cls.__qualname__}"
    for field in dataclasses.fields(value):
        if field.init and not field.name.startswith("_"):
            item = getattr(value, field.name)
            if not field.repr and _is_working_object(item):
                _encode_leaf(node, field.name, None)      # a live solver object: not data
                node[field.name].attrs["dropped"] = type(item).__name__
            else:
                encode(node, field.name, item)


def _is_working_object(value) -> bool:
    """A live object (a solver's constraint, ...) rather than data: fields declared
    ``repr=False`` that hold one are stored as None (attribute ``dropped``)."""
    data = (np.ndarray, list, tuple, dict, str, Path, int, float, bool, np.generic, Loading,
            enum.Enum, type(None))
    return not isinstance(value, data) and not dataclasses.is_dataclass(value)


def _encode_leaf(group, name: str, value) -> None:
    if isinstance(value, enum.Enum):
        node = group.create_dataset(name, data=value.value)
        node.attrs["type"] = f"{type(value).__module__}:{type(value).__qualname__}"
        kind = "enum"
    elif value is None:
        node, kind = group.create_dataset(name, data=0), "none"
    elif isinstance(value, (bool, np.bool_)):
        node, kind = group.create_dataset(name, data=bool(value)), "bool"
    elif isinstance(value, (int, np.integer)):
        node, kind = group.create_dataset(name, data=int(value)), "int"
    elif isinstance(value, (float, np.floating)):
        node, kind = group.create_dataset(name, data=float(value)), "float"
    elif isinstance(value, (str, Path)):
        kind = "path" if isinstance(value, Path) else "str"
        node = group.create_dataset(name, data=str(value))
    elif isinstance(value, np.ndarray):
        node, kind = _encode_array(group, name, value), "array"
    else:
        raise TypeError(f"{name}: cannot store a {type(value).__name__} in a result file")
    node.attrs["kind"] = kind


def _encode_array(group, name: str, value: np.ndarray):
    if value.dtype.kind == "U":
        node = group.create_dataset(name, data=_utf8(value))
        node.attrs["strings"] = True
        return node
    if value.dtype.kind == "O":
        if not all(isinstance(item, str) for item in value.flat):
            raise TypeError(f"{name}: cannot store an array of Python objects in a result file")
        node = group.create_dataset(name, data=_utf8(value))
        node.attrs["strings"] = "object"                      # an object array of str
        return node
    return group.create_dataset(name, data=value)


def _utf8(strings: np.ndarray) -> np.ndarray:
    """An array of str as fixed-length UTF-8 bytes (``S1`` when empty)."""
    encoded = [str(item).encode("utf-8") for item in strings.flat]
    return np.array(encoded or [b""], dtype=bytes)[: len(encoded)].reshape(strings.shape)


# --- reading -------------------------------------------------------------------------
def decode(node):
    """The value :func:`encode` stored as the h5py ``node``."""
    kind = node.attrs["kind"]
    if kind == "dataclass":
        cls = _import(node.attrs["type"])
        return cls(**{name: decode(child) for name, child in node.items()})
    if kind in ("list", "tuple"):
        items = [decode(node[str(i)]) for i in range(len(node))]
        return items if kind == "list" else tuple(items)
    if kind == "dict":
        keys = json.loads(node.attrs["keys_json"])
        return {key: decode(node[str(i)]) for i, key in enumerate(keys)}
    if kind == "loading":
        vertices = node["vertices"][()]
        n = int(node.attrs["n_tendons"])
        return Loading.from_vertices(vertices) if len(vertices) else Loading.straight(n)
    return _decode_leaf(node, kind)


def _decode_leaf(node, kind: str):
    value = node[()]
    if kind == "none":
        return None
    if kind == "bool":
        return bool(value)
    if kind == "int":
        return int(value)
    if kind == "float":
        return float(value)
    if kind in ("str", "path"):
        text = value.decode() if isinstance(value, bytes) else str(value)
        return Path(text) if kind == "path" else text
    if kind == "enum":
        return _import(node.attrs["type"])(int(value))
    strings = node.attrs.get("strings", False)
    if strings:
        text = np.array([item.decode("utf-8") for item in value.flat] or [""],
                        dtype=str)[: value.size].reshape(value.shape)
        return text.astype(object) if strings == "object" else text
    return value


def _import(qualified: str):
    module, _, qualname = str(qualified).partition(":")
    if not module.startswith("elastica_petsc."):
        raise InputError(f"result file names a type outside elastica_petsc: {qualified}")
    value = import_module(module)
    for part in qualname.split("."):
        value = getattr(value, part)
    return value


# --- files ---------------------------------------------------------------------------
def has_result(fh) -> bool:
    """Whether an open file holds a ``/result`` group (:func:`save_result`)."""
    return RESULT_GROUP in fh


def read_result(fh):
    """The result stored in the open file ``fh`` by :func:`save_result`."""
    return decode(fh[RESULT_GROUP])
