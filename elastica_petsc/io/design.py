"""Output of ``elastica-petsc design``: the designed arm as a TOML config
(readable by ``--config``), with the optimisation history in its header."""
from __future__ import annotations

from pathlib import Path

from ..core.config import SCHEMA, arm_to_dict
from .hdf5 import check_output_path


def _value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if isinstance(v, float):
        return repr(v)
    return str(v)


def config_toml(arm, header_lines=()) -> str:
    """TOML text of an Arm in the schema of :mod:`elastica_petsc.core.config`
    (keys whose value is None are left out: their defaults apply)."""
    data = arm_to_dict(arm)
    lines = [f"# {line}" for line in header_lines]
    for section in ("arm", "motor", "limits"):
        lines += ["", f"[{section}]"]
        lines += [f"{k} = {_value(data[section][k])}" for k in SCHEMA[section]
                  if data[section].get(k) is not None]
    for tendon in data["tendon"]:
        lines += ["", "[[tendon]]"]
        lines += [f"{k} = {_value(tendon[k])}" for k in SCHEMA["tendon"]]
    return "\n".join(lines) + "\n"


def write_config(path, arm, header_lines=(), overwrite: bool = False) -> Path:
    """Write ``arm`` as TOML to ``path`` (refuses to clobber unless ``overwrite``)."""
    path = check_output_path(path, overwrite)
    path.write_text(config_toml(arm, header_lines))
    return path
