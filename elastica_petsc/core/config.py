"""TOML configuration files of an arm: the schema, the file read and its values
checked (:func:`read_config`, :func:`config_values`), and an arm back into the
same layout (:func:`arm_to_dict`).  The :class:`~elastica_petsc.core.model.Arm`
is built from the values in core/model.py (:func:`~elastica_petsc.core.model.load_config`).

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

REQUIRED = object()

# section -> key -> (type, default, unit/description).  REQUIRED marks a key without default.
SCHEMA: dict[str, dict[str, tuple[type | tuple, object, str]]] = {
    "arm": {
        "length_mm": (float, REQUIRED, "arm length l [mm]"),
        "bending_stiffness_Nm2": (float, None, "bending stiffness B [N m^2] (or the material)"),
        "youngs_modulus_Pa": (float, None, "Young's modulus E [Pa]: B = E w h^3 / 12"),
        "density_kg_m3": (float, None, "density rho [kg/m^3]: mass per length rho w h"),
        "elements": (int, 180, "number of P1 elements"),
        "thickness_mm": (float, 3.0, "thickness h [mm], for the strain limit Eq. (19)"),
        "width_mm": (float, 40.0, "strip width w [mm], for B and mass from the material"),
        "guide_radius_mm": (float, None, "largest offset of a guide or cable end from the "
                            "centreline [mm] (the spacer disks' radius); unset: width_mm/2, "
                            "deprecated"),
        "mass_per_length_kg_m": (float, None,
                                 "mass per length [kg/m], for eigenfrequencies and weight"),
        "gravity_m_s2": (list, None, "gravity [gx, gy] [m/s^2], clamp frame, arm along +x"),
        "tip_mass_kg": (float, 0.0, "mass at the tip [kg], >= 0"),
    },
    "tendon": {
        "attach_mm": (float, REQUIRED, "attachment arc length s_i [mm], 0 < s_i <= l"),
        "route_mm": (list, REQUIRED, "routing point r_i = [x, y] [mm] (the motor end)"),
        "attach_offset_mm": (float, 0.0, "end point's offset along the left normal [mm]"),
        "guides": (list, [], "guides from the motor end: [{s_mm = .., offset_mm = ..}, ...]"),
        "friction_coefficient": (float, 0.0, "Coulomb coefficient mu where the cable wraps its "
                                 "guides (only the friction command models it)"),
    },
    "guide": {
        "s_mm": (float, REQUIRED, "arc length of the guide [mm], 0 < s <= l"),
        "offset_mm": (float, 0.0, "offset along the left normal [mm]"),
    },
    "motor": {
        "spool_radius_mm": (float, 31.0, "spool radius [mm]"),
        "steps_per_rev": (int, 200, "full steps per motor revolution"),
        "microsteps": (int, 16, "microsteps per full step"),
        "max_tension_N": (float, None, "motor force limit P_crit [N], Eq. (22)"),
        "max_speed_steps_s": ((float, list), None,
                              "motor speed limit [microsteps/s], one or one per tendon"),
        "max_accel_steps_s2": ((float, list), None,
                               "motor acceleration limit [microsteps/s^2], one or per tendon"),
    },
    "limits": {
        "failure_strain": (float, 0.025, "failure strain eps_Y, Eq. (19)"),
        "strain_energy_max_SE0": (float, 18.0, "SE_max in units of B/(2l), Eq. (21)"),
    },
    "dynamics": {
        "damping_ratio": (float, 0.0, "damping ratio zeta_1 of the unloaded first mode"),
        "kelvin_voigt_fraction": (float, 0.5, "share of zeta_1 from Kelvin-Voigt damping, "
                                              "the rest viscous (docs/model.md §16)"),
        "rotary_inertia": (bool, False, "include the rotary inertia of the cross-section"),
    },
}


# the file's sections; "guide" is the schema of each entry of a tendon's guides
SECTIONS = ("arm", "tendon", "motor", "limits", "dynamics")


class ConfigError(InputError):
    """A configuration file that cannot describe an arm; one line, names the key."""


def paper_config_path() -> Path:
    """The arm of the paper's Fig. 1, shipped inside the package."""
    return Path(str(resources.files("elastica_petsc") / "configs" / "paper.toml"))


def read_config(path: str | Path | None = None) -> tuple[Path, dict]:
    """(path, parsed TOML) of a config file (default: the paper's arm)."""
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
    return path, data


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
        out[key] = _typed(data[key], kind, f"{where}.{key}")
    return out


def _typed(value, kind, where: str):
    """``value`` as ``kind`` (an int is a float; (float, list): a number or a list of them)."""
    if kind == (float, list) and isinstance(value, list):
        return tuple(_typed(v, float, where) for v in value)
    kind = float if kind == (float, list) else kind
    if kind is float and isinstance(value, int) and not isinstance(value, bool):
        value = float(value)
    if (isinstance(value, bool) and kind is not bool) or not isinstance(value, kind):
        raise ConfigError(
            f"{where}: expected {kind.__name__}, got {type(value).__name__} {value!r}")
    return value


MATERIAL_TOLERANCE = 1e-3       # relative: a value given and the material's must agree


def _materials(arm: dict, given: dict) -> dict:
    """B = E w h^3 / 12 and mass per length rho w h (w, h in m) where the material
    is given; a value given as well must agree with it (docs/model.md §13)."""
    derived = {"bending_stiffness_Nm2": ("youngs_modulus_Pa", 3, "E w h^3 / 12", 1 / 12),
               "mass_per_length_kg_m": ("density_kg_m3", 1, "rho w h", 1.0)}
    for key, (material, power, formula, factor) in derived.items():
        if arm[material] is None:
            continue
        if not arm[material] > 0:
            raise ConfigError(f"arm.{material} must be positive, got {arm[material]!r}")
        for size in ("width_mm", "thickness_mm"):
            if size not in given:
                raise ConfigError(f"arm.{material} needs arm.{size} (the cross-section)")
        w_m, h_m = arm["width_mm"] * 1e-3, arm["thickness_mm"] * 1e-3
        value = factor * arm[material] * w_m * h_m ** power
        if arm[key] is None:
            arm[key] = value
        elif abs(arm[key] - value) > MATERIAL_TOLERANCE * value:
            raise ConfigError(f"arm.{key} = {arm[key]:g} disagrees with arm.{material} "
                              f"({formula} = {value:.6g}): give one of them")
    if arm["bending_stiffness_Nm2"] is None:
        raise ConfigError("arm.bending_stiffness_Nm2: missing required key (or give "
                          "youngs_modulus_Pa with width_mm and thickness_mm)")
    return arm


def _pair(value, where: str):
    """Two numbers [x, y] as a tuple of floats (None stays None)."""
    if value is None:
        return None
    if len(value) != 2 or not all(
            isinstance(c, (int, float)) and not isinstance(c, bool) for c in value):
        raise ConfigError(f"{where}: expected two numbers [x, y], got {value!r}")
    return (float(value[0]), float(value[1]))


def config_values(data: dict) -> dict:
    """The checked values of parsed TOML (mm, N m^2, N), defaults filled in:
    {"arm": keyword arguments of Arm, "tendons": [{"attach_mm", "route_mm",
    "attach_offset_mm", "guides": ({"s_mm", "offset_mm"}, ...)}], "motor": ...,
    "limits": ...}."""
    unknown = sorted(set(data) - set(SECTIONS))
    if unknown:
        raise ConfigError(f"{unknown[0]}: unknown section (known: {', '.join(SECTIONS)})")
    if "arm" not in data:
        raise ConfigError("arm: missing required section [arm]")
    arm = _materials(_section(data["arm"], "arm", "arm"), data["arm"])
    arm["gravity_m_s2"] = _pair(arm["gravity_m_s2"], "arm.gravity_m_s2")
    raw_tendons = data.get("tendon")
    if not raw_tendons:
        raise ConfigError("tendon: missing required [[tendon]] entries")
    if not isinstance(raw_tendons, list):
        raise ConfigError("tendon: must be an array of tables [[tendon]]")
    tendons = []
    for i, raw in enumerate(raw_tendons, start=1):
        values = _section(raw, "tendon", f"tendon[{i}]")
        route = _pair(values["route_mm"], f"tendon[{i}].route_mm")
        guides = tuple(_section(g, "guide", f"tendon[{i}].guides[{j}]")
                       for j, g in enumerate(values["guides"], start=1))
        tendons.append({"attach_mm": values["attach_mm"], "route_mm": route,
                        "attach_offset_mm": values["attach_offset_mm"], "guides": guides,
                        "friction_coefficient": values["friction_coefficient"]})
    return {"arm": arm, "tendons": tendons,
            "motor": _section(data.get("motor", {}), "motor", "motor"),
            "limits": _section(data.get("limits", {}), "limits", "limits"),
            "dynamics": _section(data.get("dynamics", {}), "dynamics", "dynamics")}


def arm_to_dict(arm) -> dict:
    """The resolved configuration of an :class:`~elastica_petsc.core.model.Arm` as
    plain data in this file's layout (for HDF5 attributes and JSON)."""
    data = asdict(arm)
    data["tendon"] = [_tendon_dict(t) for t in data.pop("tendons")]

    def given(section: dict) -> dict:      # an unset optional key is left out, as in TOML
        return {k: list(v) if isinstance(v, tuple) else v for k, v in section.items()
                if v is not None and not (k == "tip_mass_kg" and v == 0.0)}

    return {"arm": given({k: data[k] for k in SCHEMA["arm"]}), "tendon": data["tendon"],
            "motor": given(data["motor"]), "limits": given(data["limits"]),
            "dynamics": data["dynamics"]}


def _tendon_dict(t: dict) -> dict:
    """One [[tendon]] as plain data; keys at their defaults left out (today's files
    and attributes unchanged for the paper's cables)."""
    out = dict(attach_mm=t["attach_mm"], route_mm=list(t["route_mm"]))
    if t["attach_offset_mm"] != 0.0:
        out["attach_offset_mm"] = t["attach_offset_mm"]
    if t["guides"]:
        out["guides"] = [dict(g) for g in t["guides"]]
    if t.get("friction_coefficient", 0.0) != 0.0:
        out["friction_coefficient"] = t["friction_coefficient"]
    return out
