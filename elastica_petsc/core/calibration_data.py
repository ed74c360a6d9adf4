"""Measured static states of an arm for calibration: the CSV format (docs/model.md §14).

One row per measured equilibrium.  Inputs, per tendon K = 1..n (the names of
the schedule CSV that ``schedule`` writes, :mod:`elastica_petsc.core.schedule`):

    tension_K_N    the cable tension (a load cell)                      [N]
    length_K_mm    the commanded cable length |r_K - x_K|               [mm]
    steps_K        motor microsteps from the straight, unloaded arm
                   (> 0 pays cable out, as in a schedule)               [steps]

Each row fills exactly one of the three groups for every tendon (cells of the
other groups left empty); with ``kind`` given (``--input``) only that group is
read and the others are ignored (a schedule CSV carries all three).
Optionally ``loading``: the order in which the tendons were loaded (``2,1``:
tendon 2 first), where the branch matters; an empty cell means "not known".
Outputs: ``tip_x_mm, tip_y_mm`` (required), and markers at known arc lengths
``marker_S_x_mm, marker_S_y_mm`` (s = S mm along the arm; an empty pair: not
measured in that row).  Other columns of a schedule CSV are ignored; any
other column is refused, so that a misspelt name is not silently dropped.
"""
from __future__ import annotations

import csv
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .calibration_params import said
from .errors import InputError

KINDS = ("tension", "length", "steps")
INPUT_COLUMNS = {"tension": "tension_{}_N", "length": "length_{}_mm", "steps": "steps_{}"}
_INPUT_RE = re.compile(r"^(tension_(\d+)_N|length_(\d+)_mm|steps_(\d+))$")
_MARKER_RE = re.compile(r"^marker_([0-9.]+)_([xy])_mm$")
_SCHEDULE_RE = re.compile(r"^(tension_\d+_p|revolutions_\d+|step_increment_\d+|"
                          r"rounding_error_\d+_mm)$")
IGNORED = {"row", "phase", "point", "time_s", "duration_s", "limited_by", "reached",
           "target_x_mm", "target_y_mm", "note"}


class DataError(InputError):
    """A calibration data file that cannot be used; one line naming row and column."""


@dataclass(frozen=True)
class CalibrationData:
    """Measured states (mm, N, steps).

    kinds : (m,) "tension", "length" or "steps": which input the row gives.
    inputs : (m, n) tensions [N], commanded lengths [mm] or microsteps.
    tips_mm : (m, 2) measured tips.
    marker_s_mm : (k,) arc lengths of the markers.
    markers_mm : (m, k, 2) measured marker positions (NaN: not measured).
    loading : (m,) loading order per row, a tuple of tendon numbers, or None.
    lines : (m,) line numbers of the rows in the file (for messages).
    """

    kinds: np.ndarray
    inputs: np.ndarray
    tips_mm: np.ndarray
    marker_s_mm: np.ndarray
    markers_mm: np.ndarray
    loading: tuple
    lines: tuple
    source: str = ""

    @property
    def n_rows(self) -> int:
        return len(self.kinds)

    @property
    def n_tendons(self) -> int:
        return self.inputs.shape[1]

    def observed(self) -> np.ndarray:
        """(m, 1 + k) bool: tip (always) and each marker measured in the row."""
        marks = np.all(np.isfinite(self.markers_mm), axis=2)
        return np.column_stack((np.ones(self.n_rows, bool), marks))

    def points_mm(self) -> np.ndarray:
        """(m, 1 + k, 2): tip then markers."""
        return np.concatenate((self.tips_mm[:, None, :], self.markers_mm), axis=1)

    def subset(self, rows) -> "CalibrationData":
        rows = np.asarray(rows, int)
        return CalibrationData(self.kinds[rows], self.inputs[rows], self.tips_mm[rows],
                               self.marker_s_mm, self.markers_mm[rows],
                               tuple(self.loading[r] for r in rows),
                               tuple(self.lines[r] for r in rows), self.source)

    def with_points(self, points_mm) -> "CalibrationData":
        """The same commands with other measured points (m, 1 + k, 2)."""
        pts = np.asarray(points_mm, float)
        return CalibrationData(self.kinds, self.inputs, pts[:, 0].copy(), self.marker_s_mm,
                               pts[:, 1:].copy(), self.loading, self.lines, self.source)

    def columns(self) -> list[str]:
        cols = []
        for kind in KINDS:
            if np.any(self.kinds == kind):
                cols += [INPUT_COLUMNS[kind].format(i) for i in range(1, self.n_tendons + 1)]
        cols += ["loading", "tip_x_mm", "tip_y_mm"]
        for s in self.marker_s_mm:
            cols += [f"marker_{s:g}_x_mm", f"marker_{s:g}_y_mm"]
        return cols


def _number(text: str, line: int, column: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise DataError(f"line {line}, column {column}: not a number: {text!r}") from None
    if not math.isfinite(value):
        raise DataError(f"line {line}, column {column}: not a finite number: {text!r}")
    return value


def _loading(text: str, line: int, n_tendons: int):
    text = text.strip()
    if not text:
        return None
    try:
        order = tuple(int(t) for t in text.replace(";", ",").split(","))
    except ValueError:
        raise DataError(f"line {line}, column loading: expected tendon numbers such as "
                        f"'2,1', got {text!r}") from None
    if sorted(order) != list(range(1, n_tendons + 1)):
        raise DataError(f"line {line}, column loading: {text!r} is not an order of the "
                        f"tendons 1..{n_tendons}")
    return order


def _header(names, n_tendons: int) -> tuple[dict, list[float]]:
    """Input columns found per kind, and the marker arc lengths; refuses the rest."""
    if len(set(names)) != len(names):
        dup = next(c for c in names if names.count(c) > 1)
        raise DataError(f"column {dup!r} appears twice")
    found = {kind: set() for kind in KINDS}
    markers: dict[float, set] = {}
    for name in names:
        m = _INPUT_RE.match(name)
        if m:
            k = int(next(g for g in m.groups()[1:] if g))
            if not 1 <= k <= n_tendons:
                raise DataError(f"column {name}: the arm has tendons 1..{n_tendons}")
            found[KINDS[[g is not None for g in m.groups()[1:]].index(True)]].add(k)
            continue
        mk = _MARKER_RE.match(name)
        if mk:
            markers.setdefault(float(mk.group(1)), set()).add(mk.group(2))
            continue
        if name in IGNORED or name in ("loading", "tip_x_mm", "tip_y_mm") \
                or _SCHEDULE_RE.match(name):
            continue
        raise DataError(f"column {name!r} is not a calibration column (inputs tension_K_N, "
                        "length_K_mm or steps_K; tip_x_mm, tip_y_mm; marker_S_x_mm, "
                        "marker_S_y_mm; loading)")
    for col in ("tip_x_mm", "tip_y_mm"):
        if col not in names:
            raise DataError(f"missing column {col}")
    for s, axes in markers.items():
        if axes != {"x", "y"}:
            miss = ({"x", "y"} - axes).pop()
            raise DataError(f"missing column marker_{s:g}_{miss}_mm (markers need x and y)")
    for kind, ks in found.items():
        if ks and len(ks) != n_tendons:
            miss = min(set(range(1, n_tendons + 1)) - ks)
            raise DataError(f"missing column {INPUT_COLUMNS[kind].format(miss)} (an input "
                            "group needs a column for every tendon)")
    kinds = tuple(k for k in KINDS if found[k])
    if not kinds:
        raise DataError("missing input columns: give tension_K_N, length_K_mm or steps_K "
                        "for every tendon K")
    return kinds, sorted(markers)


def read_calibration_csv(path, n_tendons: int, kind: str | None = None,
                         arm_length_mm: float | None = None,
                         measured: bool = True, options: dict | None = None) -> CalibrationData:
    """Parse and validate a calibration CSV (module docstring) for an arm of
    ``n_tendons`` tendons; ``kind`` reads only that input group.  With
    ``measured=False`` (candidate commands) the tip columns may be missing or empty;
    ``options``: how messages name the options (core/calibration_params.py ``said``)."""
    path = Path(path)
    if kind is not None and kind not in KINDS:
        raise DataError(f"input kind must be one of {', '.join(KINDS)}, got {kind!r}")
    try:
        with open(path, newline="") as fh:
            table = list(csv.reader(fh))
    except FileNotFoundError:
        raise DataError(f"{path}: no such data file") from None
    except (OSError, UnicodeDecodeError) as err:
        raise DataError(f"{path}: cannot read it ({err})") from None
    table = [(number, r) for number, r in enumerate(table, start=1)
             if any(c.strip() for c in r) and not r[0].lstrip().startswith("#")]
    if not table:
        raise DataError(f"{path}: empty file (need a header line and rows)")
    names = [c.strip() for c in table[0][1]]
    try:
        groups, marker_s = _header(names if measured else names + [
            c for c in ("tip_x_mm", "tip_y_mm") if c not in names], n_tendons)
        if kind is not None:
            if kind not in groups:
                raise DataError(f"{said(options, 'input', kind)}: the file has no "
                                f"{INPUT_COLUMNS[kind].format('K')} columns")
            groups = (kind,)
        rows = _rows(table[1:], names, groups, marker_s, n_tendons, arm_length_mm, measured,
                     options)
    except DataError as err:
        raise DataError(f"{path}: {err}") from None
    if not rows[0]:
        raise DataError(f"{path}: no data rows")
    kinds, inputs, tips, marks, loading, lines = rows
    return CalibrationData(np.array(kinds), np.array(inputs, float), np.array(tips, float),
                           np.array(marker_s, float),
                           np.array(marks, float).reshape(len(kinds), len(marker_s), 2),
                           tuple(loading), tuple(lines), str(path))


def _rows(body, names, groups, marker_s, n_tendons, arm_length_mm, measured=True,
          options=None):
    col = {c: j for j, c in enumerate(names)}
    kinds, inputs, tips, marks, loading, lines = [], [], [], [], [], []
    for number, raw in body:
        cells = [c.strip() for c in raw] + [""] * (len(names) - len(raw))
        if len(raw) > len(names):
            raise DataError(f"line {number}: {len(raw)} cells for {len(names)} columns")
        filled = [g for g in groups if any(
            cells[col[INPUT_COLUMNS[g].format(i)]] for i in range(1, n_tendons + 1))]
        if len(filled) != 1:
            what = "no input" if not filled else "inputs of several kinds (" + \
                ", ".join(filled) + f"; choose one with {said(options, 'input')})"
            raise DataError(f"line {number}: {what}")
        kind = filled[0]
        values = []
        for i in range(1, n_tendons + 1):
            name = INPUT_COLUMNS[kind].format(i)
            if not cells[col[name]]:
                raise DataError(f"line {number}, column {name}: empty")
            values.append(_number(cells[col[name]], number, name))
        _check_inputs(kind, values, number)
        kinds.append(kind)
        inputs.append(values)
        if measured:
            tips.append([_number(cells[col[c]], number, c) if cells[col[c]] else
                         _missing(number, c) for c in ("tip_x_mm", "tip_y_mm")])
        else:
            tips.append([0.0, 0.0])
        for s in marker_s:
            pair = [cells[col[f"marker_{s:g}_{a}_mm"]] for a in "xy"]
            if arm_length_mm is not None and not 0 < s <= arm_length_mm:
                raise DataError(f"marker at s = {s:g} mm: not on the arm (0 < s <= "
                                f"{arm_length_mm:g} mm)")
            if not any(pair):
                marks.append([math.nan, math.nan])
                continue
            marks.append([_number(v, number, f"marker_{s:g}_{a}_mm") if v else
                          _missing(number, f"marker_{s:g}_{a}_mm") for v, a in zip(pair, "xy")])
        loading.append(_loading(cells[col["loading"]], number, n_tendons)
                       if "loading" in col else None)
        lines.append(number)
    return kinds, inputs, tips, marks, loading, lines


def _missing(line: int, column: str):
    raise DataError(f"line {line}, column {column}: empty")


def _check_inputs(kind: str, values, line: int) -> None:
    for i, v in enumerate(values, start=1):
        if kind == "tension" and v < 0:
            raise DataError(f"line {line}, column tension_{i}_N: negative ({v:g}): a cable "
                            "cannot push")
        if kind == "length" and v <= 0:
            raise DataError(f"line {line}, column length_{i}_mm: must be positive, got {v:g}")
        if kind == "steps" and v != int(v):
            raise DataError(f"line {line}, column steps_{i}: not a whole number ({v:g})")


def write_calibration_csv(path, data: CalibrationData, header_lines=()) -> Path:
    """Write ``data`` in the format read by :func:`read_calibration_csv`, after
    ``# `` comment lines (``header_lines``: e.g. that the data are synthetic)."""
    path = Path(path)
    with open(path, "w", newline="") as fh:
        for line in header_lines:
            fh.write(f"# {line}\n")
        writer = csv.writer(fh)
        writer.writerow(data.columns())
        for r in range(data.n_rows):
            row = []
            for kind in KINDS:
                if np.any(data.kinds == kind):
                    row += [_fmt(v, kind) if data.kinds[r] == kind else ""
                            for v in data.inputs[r]]
            order = data.loading[r]
            row += [",".join(map(str, order)) if order else "", *map(_fmt, data.tips_mm[r])]
            for mark in data.markers_mm[r]:
                row += ["" if not np.all(np.isfinite(mark)) else _fmt(v) for v in mark]
            writer.writerow(row)
    return path


def _fmt(v, kind: str = "") -> str:
    return str(int(v)) if kind == "steps" else f"{v:.12g}"
