"""The one JSON encoder of the package: numpy scalars and arrays become JSON
numbers, booleans and lists wherever they sit in a summary (a tendon index
from ``np.argmax`` is an ``int64``), so no writer can fail on them."""
from __future__ import annotations

import json

import numpy as np


def _plain(value):
    """``json``'s ``default``: the Python value of a numpy scalar or array."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"Object of type {type(value).__name__} is not JSON serializable")


def dumps(data, **kw) -> str:
    return json.dumps(data, default=_plain, **kw)


def dump(data, stream, **kw) -> None:
    json.dump(data, stream, default=_plain, **kw)
