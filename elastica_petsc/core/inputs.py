"""Checks of user input shared by the library (api/) and the command line.

Every check takes the name the user typed (``"lengths_mm"`` in the library,
``"--lengths"`` on the command line) and reports in the user's units, with
one line through :class:`~elastica_petsc.core.errors.InputError`.  Sizes that
would exhaust memory or time are refused before anything is allocated; the
limits can be raised with the environment variables named in the message.
"""
from __future__ import annotations

import math

import numpy as np

from .errors import InputError

MAX_TARGET_DISTANCE = 100.0       # arm lengths: farther, E of Eq. (10) overflows
MAX_PATH_POINTS_ENV = "ELASTICA_PETSC_MAX_PATH_POINTS"
MAX_PATH_POINTS = 1_000_000       # targets of a traced path (~0.2 GB of results)
MAX_ELEMENTS_ENV = "ELASTICA_PETSC_MAX_ELEMENTS"
MAX_ELEMENTS = 100_000            # ~1 kB per element for a solve, ~2 kB for stability
MAX_DESIGN_POINTS_ENV = "ELASTICA_PETSC_MAX_DESIGN_POINTS"
MAX_DESIGN_POINTS = 2_000         # path targets per design: each is traced per evaluation
MAX_TENSION = 1e4                 # p = P l^2/B: far beyond a cable's collapse (p ~ 140 on the
                                  # paper's arm) and any motor; load stepping grows with p
MAX_ITERATIONS = 1_000            # optimiser iterations (a design's default: 20)
MAX_CELLS = 1_000                 # re-sampling cells per tension axis ((K+1)^2 solves)


_RAISED: dict[str, int] = {}      # limits raised by the command line (configure_limits)


def configure_limits(environ) -> None:
    """Raise the size limits from ``environ``, a mapping of the command line's
    environment (the library itself reads no environment variable): each of
    ``ELASTICA_PETSC_MAX_*`` present must be a whole number >= 1."""
    for env in (MAX_PATH_POINTS_ENV, MAX_ELEMENTS_ENV, MAX_DESIGN_POINTS_ENV):
        text = environ.get(env, "").strip()
        if not text:
            _RAISED.pop(env, None)
            continue
        try:
            value = int(text)
        except ValueError:
            raise InputError(f"{env}={text!r}: expected a whole number") from None
        if value < 1:
            raise InputError(f"{env}={text!r}: expected a whole number >= 1")
        _RAISED[env] = value


def limit(env: str, default: int) -> int:
    """A size limit: ``default`` unless :func:`configure_limits` raised it."""
    return _RAISED.get(env, default)


def numbers(values, name: str, unit: str = "", count: int | None = None) -> np.ndarray:
    """Finite real numbers (not strings, not booleans), flattened; ``count`` of them."""
    array = (values if isinstance(values, np.ndarray) else np.asarray(values, dtype=object))
    if array.dtype.kind not in "iuf":
        for v in array.ravel():
            if isinstance(v, (bool, np.bool_)) or not isinstance(
                    v, (int, float, np.integer, np.floating)):
                raise InputError(f"{name}: expected numbers{' in ' + unit if unit else ''}, "
                                 f"got {v!r}")
    out = array.astype(float).ravel()
    if count is not None and out.size != count:
        raise InputError(f"{name}: expected {count} number{'s' * (count != 1)}"
                         f"{' in ' + unit if unit else ''}, got {out.size}")
    if not np.all(np.isfinite(out)):
        k = int(np.argmin(np.isfinite(out)))
        where = f" (value {k + 1} of {out.size})" if out.size > 1 else ""
        raise InputError(f"{name}: expected finite numbers{' in ' + unit if unit else ''}, "
                         f"got {out[k]:g}{where}")
    return out


def number(value, name: str, unit: str = "") -> float:
    """One finite real number (not a list of one)."""
    if np.ndim(value) != 0:
        raise InputError(f"{name}: expected one number{' in ' + unit if unit else ''}, got "
                         f"{value!r}")
    return float(numbers([value], name, unit, count=1)[0])


def positive(value, name: str, unit: str = "", at_least: float = 0.0,
             at_most: float = math.inf) -> float:
    """A finite number > 0 (>= ``at_least`` if given) and <= ``at_most``."""
    v = number(value, name, unit)
    u = " " + unit if unit else ""
    if not v > 0 or v < at_least:
        least = f"at least {at_least:g}{u}" if at_least else "positive"
        raise InputError(f"{name} must be {least}, got {v:g}{u}")
    if v > at_most:
        raise InputError(f"{name} must be at most {at_most:g}{u}, got {v:g}{u}")
    return v


def choice(value, name: str, allowed) -> str:
    if value not in allowed:
        raise InputError(f"{name} must be one of {', '.join(map(repr, allowed))}, got {value!r}")
    return value


def integer(value, name: str, minimum: int, maximum: int | None = None,
            why: str = "") -> int:
    """A whole number in [minimum, maximum] (``why`` explains the maximum)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise InputError(f"{name} must be a whole number, got {value!r}")
    if value < minimum:
        raise InputError(f"{name} must be at least {minimum}, got {value}")
    if maximum is not None and value > maximum:
        raise InputError(f"{name} must be at most {maximum}{why}, got {value}")
    return int(value)


def elements(value, name: str) -> int | None:
    """A finite-element count (None: the config's), within the memory limit."""
    if value is None:
        return None
    most = limit(MAX_ELEMENTS_ENV, MAX_ELEMENTS)
    return integer(value, name, 2, most, f" (about 1-2 kB of memory per element; set "
                                         f"{MAX_ELEMENTS_ENV} to raise the limit)")


def modes(value, n_elements: int, name: str) -> int:
    """A number of stiffness eigenvalues: 1 to N (K of N elements has N)."""
    return integer(value, name, 1, n_elements, f" (the stiffness of {n_elements} elements "
                                               f"has {n_elements} eigenvalues)")


def tensions(values, n_tendons: int, name: str, unit: str, scale: float = 1.0) -> np.ndarray:
    """One finite non-negative tension per tendon, at most :data:`MAX_TENSION`
    (p; ``scale``: the user's unit per unit p, B/l^2 in N), in the user's
    ``unit`` (``"N"`` or ``"P l^2/B"``); returned as given (not converted)."""
    out = numbers(values, name, unit)
    if out.size != n_tendons:
        raise InputError(f"{name}: expected {n_tendons} tensions in {unit} (one per tendon), "
                         f"got {out.size}")
    if np.any(out < 0):
        i = int(np.argmax(out < 0))
        raise InputError(f"{name}: tension of tendon {i + 1} is negative ({out[i]:g} {unit}): "
                         "a cable cannot push")
    most = MAX_TENSION * scale
    if np.any(out > most):
        i = int(np.argmax(out > most))
        raise InputError(f"{name}: tension of tendon {i + 1} ({out[i]:g} {unit}) exceeds "
                         f"{most:.4g} {unit} (p = {MAX_TENSION:g}), far beyond a cable's "
                         "collapse onto its routing point")
    return out


def target_mm(arm, values, name: str) -> np.ndarray:
    """A tip target [x, y] in mm within 100 arm lengths of the clamp (farther,
    E of Eq. (10) would overflow; nothing there is reachable anyway)."""
    target = numbers(values, name, "mm", count=2)
    if math.hypot(*target) > MAX_TARGET_DISTANCE * arm.length_mm:
        raise InputError(f"{name} ({target[0]:g}, {target[1]:g}) mm lies more than "
                         f"{MAX_TARGET_DISTANCE:g} arm lengths from the clamp; the arm reaches "
                         f"{arm.length_mm:g} mm")
    return target


def cable_lengths_mm(arm, values, name: str) -> np.ndarray:
    """Positive cable lengths, one per tendon, each short enough to be taut in
    some state: the attachment x_i lies within s_i of the clamp (inextensible
    arm), so |r_i - x_i| <= |r_i| + s_i; a longer cable is slack in every state
    (and the continuation towards it would take steps growing with the length)."""
    L = numbers(values, name, "mm")
    if L.size != arm.n_tendons:
        raise InputError(f"{name}: expected {arm.n_tendons} cable lengths in mm (one per "
                         f"tendon), got {L.size}")
    for i, (tendon, v) in enumerate(zip(arm.tendons, L), 1):
        if not v > 0:
            raise InputError(f"{name}: cable length of tendon {i} must be a positive number "
                             f"of mm, got {v:g}")
        longest = math.hypot(*tendon.route_mm) + tendon.attach_mm
        if v > longest:
            raise InputError(f"{name}: cable {i} cannot be {v:g} mm long and taut: its "
                             f"longest possible span is |r_{i}| + s_{i} = {longest:.1f} mm")
    return L


def points_mm(values, name: str, arm=None) -> np.ndarray:
    """Path points, shape (K, 2), finite, in mm (with ``arm``: each within
    :data:`MAX_TARGET_DISTANCE` arm lengths of the clamp, as a target)."""
    try:
        points = values if isinstance(values, np.ndarray) else np.asarray(values, dtype=object)
    except ValueError:
        raise InputError(f"{name} must be an array of shape (K, 2) in mm") from None
    if points.ndim != 2 or points.shape[1] != 2 or len(points) < 1:
        raise InputError(f"{name} must be an array of shape (K, 2) in mm, got shape "
                         f"{points.shape}")
    out = numbers(points, name, "mm").reshape(-1, 2)
    if arm is not None:
        far = np.hypot(out[:, 0], out[:, 1]) > MAX_TARGET_DISTANCE * arm.length_mm
        if np.any(far):
            k = int(np.argmax(far))
            raise InputError(f"{name}: point {k + 1} ({out[k, 0]:g}, {out[k, 1]:g}) mm lies "
                             f"more than {MAX_TARGET_DISTANCE:g} arm lengths from the clamp; "
                             f"the arm reaches {arm.length_mm:g} mm")
    return out


def path_step_mm(points, step_mm, name: str, step_name: str) -> float:
    """A positive step that cuts the path into at most the limit's targets."""
    step = positive(step_mm, step_name, "mm")
    most = limit(MAX_PATH_POINTS_ENV, MAX_PATH_POINTS)
    steps = np.diff(np.asarray(points, float), axis=0)
    length = float(np.sum(np.hypot(steps[:, 0], steps[:, 1])))
    if not (np.isfinite(length) and length / step + len(points) <= most):
        raise InputError(f"{step_name} {step:g} mm would cut the {length:.6g} mm {name} into "
                         f"more than {most:,} targets; use a larger {step_name} (or set "
                         f"{MAX_PATH_POINTS_ENV} to raise the limit)")
    return step


def design_points_limit() -> int:
    return limit(MAX_DESIGN_POINTS_ENV, MAX_DESIGN_POINTS)


def design_points(points, name: str) -> None:
    """A path to design for: each of its targets is traced at every evaluation."""
    most = design_points_limit()
    if len(points) > most:
        raise InputError(f"{name} has more than {most:,} targets; a design traces every one "
                         f"at each evaluation (thin the path, or set {MAX_DESIGN_POINTS_ENV} "
                         "to raise the limit)")


def box_mm(values, name: str) -> np.ndarray:
    """A box (xmin, xmax, ymin, ymax) in mm with xmin < xmax and ymin < ymax."""
    box = numbers(values, name, "mm", count=4)
    if not (box[0] < box[1] and box[2] < box[3]):
        raise InputError(f"{name} ({', '.join(f'{v:g}' for v in box)}): need xmin < xmax and "
                         "ymin < ymax")
    return box


def tip_tolerance_mm(arm, value, name: str) -> float:
    """A tip tolerance: positive and below the arm's length (larger is meaningless,
    and its square, the TAO stopping test, would overflow)."""
    return positive(value, name, "mm", at_most=arm.length_mm)


def design_options(names: dict, *, iterations=None, reach_mm=None, clearance_mm=None,
                   margin=None, resample_cells=None) -> None:
    """The settings of a design (``names``: what the user calls each)."""
    if iterations is not None:
        integer(iterations, names["iterations"], 1, MAX_ITERATIONS)
    if reach_mm is not None:
        positive(reach_mm, names["reach_mm"], "mm", at_most=1e6)
    if clearance_mm is not None and number(clearance_mm, names["clearance_mm"], "mm") < 0:
        raise InputError(f"{names['clearance_mm']} must be >= 0 mm, got {clearance_mm:g}")
    if margin is not None:
        positive(margin, names["margin"], at_most=100.0)
    if resample_cells is not None:
        integer(resample_cells, names["resample_cells"], 2, MAX_CELLS,
                 " ((K+1)^2 forward solves)")
