"""TOML configuration files into an :class:`~elastica_petsc.core.model.Arm`.

The schema below is the single place where keys, units and defaults are
listed.  A missing required key, an unknown key or a value of the wrong type
is a :class:`ConfigError` whose one-line message names the key.
"""
from __future__ import annotations

import tomllib
from dataclasses import asdict
from importlib import resources
from pathlib import Path

from .errors import InputError
from .model import Arm, Dynamics, Limits, ModelError, Motor, Tendon

REQUIRED = object()

# section -> key -> (type, default, unit/description).  REQUIRED marks a key without default.
SCHEMA: dict[str, dict[str, tuple[type | tuple, object, str]]] = {
    "arm": {
        "length_mm": (float, REQUIRED, "arm length l [mm]"),
        "bending_stiffness_Nm2": (float, REQUIRED, "bending stiffness B [N m^2]"),
        "elements": (int, 180, "number of P1 elements"),
        "thickness_mm": (float, 3.0, "thickness h [mm], for the strain limit Eq. (19)"),
        "width_mm": (float, 40.0, "width [mm] (documentation only)"),
        "mass_per_length_kg_m": (float, None, "mass per length [kg/m], for eigenfrequencies"),
        "tip_mass_kg": (float, 0.0, "point mass at the tip [kg] (pen holder), >= 0"),
    },
    "tendon": {
        "attach_mm": (float, REQUIRED, "attachment arc length s_i [mm], 0 < s_i <= l"),
        "route_mm": (list, REQUIRED, "routing point r_i = [x, y] [mm]"),
    },
    "motor": {
        "spool_radius_mm": (float, 31.0, "spool radius [mm]"),
        "steps_per_rev": (int, 200, "full steps per motor revolution"),
        "microsteps": (int, 16, "microsteps per full step"),
        "max_tension_N": (float, None, "motor force limit P_crit [N], Eq. (22)"),
    },
    "limits": {
        "failure_strain": (float, 0.025, "failure strain eps_Y, Eq. (19)"),
        "strain_energy_max_SE0": (float, 18.0, "SE_max in units of B/(2l), Eq. (21)"),
    },
    "dynamics": {
        "damping_ratio": (float, 0.0, "damping ratio zeta_1 of the unloaded first mode"),
        "kelvin_voigt_fraction": (float, 0.5, "share of zeta_1 from Kelvin-Voigt damping, "
                                              "the rest viscous (docs/model.md §11)"),
        "rotary_inertia": (bool, False, "include the rotary inertia of the cross-section"),
    },
}


class ConfigError(InputError):
    """A configuration file that cannot describe an arm; one line, names the key."""


def paper_config_path() -> Path:
    """The arm of the paper's Fig. 1, shipped inside the package."""
    return Path(str(resources.files("elastica_petsc") / "configs" / "paper.toml"))


def load_config(path: str | Path | None = None) -> Arm:
    """Read a TOML file (default: the paper's arm) into a validated Arm."""
    path = Path(path) if path is not None else paper_config_path()
    try:
        with open(path, "rb") as fh:
            data = tomllib.load(fh)
    except FileNotFoundError:
        raise ConfigError(f"{path}: no such config file") from None
    except IsADirectoryError:
        raise ConfigError(f"{path}: is a folder, not a config file") from None
    except OSError as err:
        raise ConfigError(f"{path}: cannot read it ({err.strerror})") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as err:
        raise ConfigError(f"{path}: not valid TOML: {err}") from None
    try:
        return arm_from_dict(data)
    except (ConfigError, ModelError) as err:
        raise ConfigError(f"{path}: {err}") from None


def _section(data: dict, name: str, where: str) -> dict:
    """Typed values of one section, defaults filled in, unknown keys refused."""
    schema = SCHEMA[name]
    if not isinstance(data, dict):
        raise ConfigError(f"{where} must be a table")
    unknown = sorted(set(data) - set(schema))
    if unknown:
        raise ConfigError(f"{where}.{unknown[0]}: unknown key (known: {', '.join(schema)})")
    out = {}
    for key, (kind, default, _) in schema.items():
        if key not in data:
            if default is REQUIRED:
                raise ConfigError(f"{where}.{key}: missing required key")
            out[key] = default
            continue
        value = data[key]
        if kind is float and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        if (isinstance(value, bool) and kind is not bool) or not isinstance(value, kind):
            raise ConfigError(
                f"{where}.{key}: expected {kind.__name__}, got {type(value).__name__} {value!r}")
        out[key] = value
    return out


def arm_from_dict(data: dict) -> Arm:
    """Build an Arm from parsed TOML (mm, N m^2, N)."""
    unknown = sorted(set(data) - set(SCHEMA))
    if unknown:
        raise ConfigError(f"{unknown[0]}: unknown section (known: {', '.join(SCHEMA)})")
    if "arm" not in data:
        raise ConfigError("arm: missing required section [arm]")
    arm = _section(data["arm"], "arm", "arm")
    raw_tendons = data.get("tendon")
    if not raw_tendons:
        raise ConfigError("tendon: missing required [[tendon]] entries")
    if not isinstance(raw_tendons, list):
        raise ConfigError("tendon: must be an array of tables [[tendon]]")
    tendons = []
    for i, raw in enumerate(raw_tendons, start=1):
        values = _section(raw, "tendon", f"tendon[{i}]")
        route = values["route_mm"]
        if len(route) != 2 or not all(
                isinstance(c, (int, float)) and not isinstance(c, bool) for c in route):
            raise ConfigError(f"tendon[{i}].route_mm: expected two numbers [x, y], got {route!r}")
        tendons.append(Tendon(attach_mm=values["attach_mm"],
                              route_mm=(float(route[0]), float(route[1]))))
    motor = Motor(**_section(data.get("motor", {}), "motor", "motor"))
    limits = Limits(**_section(data.get("limits", {}), "limits", "limits"))
    dynamics = Dynamics(**_section(data.get("dynamics", {}), "dynamics", "dynamics"))
    return Arm(tendons=tuple(tendons), motor=motor, limits=limits, dynamics=dynamics, **arm)


def arm_to_dict(arm: Arm) -> dict:
    """The resolved configuration as plain data (for HDF5 attributes and JSON)."""
    data = asdict(arm)
    data["tendon"] = [dict(attach_mm=t["attach_mm"], route_mm=list(t["route_mm"]))
                      for t in data.pop("tendons")]
    def given(section: dict) -> dict:      # an unset optional key is left out, as in TOML
        return {k: v for k, v in section.items() if v is not None}

    return {"arm": given({k: data[k] for k in SCHEMA["arm"]}), "tendon": data["tendon"],
            "motor": given(data["motor"]), "limits": given(data["limits"]),
            "dynamics": data["dynamics"]}
