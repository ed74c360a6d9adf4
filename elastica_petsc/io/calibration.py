"""Outputs of ``elastica-petsc calibrate``: the fitted arm as TOML (readable by
``--config``; what the schema cannot hold, such as motor offsets and the
measurement frame, is in its header comments) and an HDF5 file::

    parameters/names, start, value, sigma, lower, upper   (P,)   units per name
    parameters/units                                      (P,)
    parameters/covariance, correlation                    (P, P)
    parameters/singular_values                            (P,)  of the scaled Jacobian
    rows/line, kind, inputs (m, n), measured_mm (m, 1+k, 2), predicted_mm,
        error_mm (m,), weight (m,), taut (m, n), tip_covariance_mm2 (m, 2, 2),
        cv_error_mm (m,)
    root attributes: provenance (io/hdf5.py), summary_json
    result/   the whole CalibrationResult (io/records.py; ``elastica_petsc.read`` returns it)
"""
from __future__ import annotations

import math

import numpy as np

from ..core import jsontext
from .design import write_config
from .hdf5 import atomic_h5, provenance, put, write_attrs
from .records import RESULT_GROUP, encode


def _fmt(value, sigma) -> str:
    return f"{value:.8g}" + ("" if sigma is None else f" +- {sigma:.3g}")


def toml_header(result) -> list[str]:
    """Comment lines: what was fitted, to which data, and how well."""
    data = result.data
    rms = result.stats["rms_mm"]
    lines = [f"Calibrated by elastica-petsc calibrate from {data.source or 'data'} "
             f"({data.n_rows} rows): RMS point error {rms:.4g} mm.",
             f"Fitted on {result.elements or result.arm.elements} elements; routes are in "
             "the arm's own frame (clamp at the origin along +x).",
             "Fitted parameters (value +- one standard deviation):"]
    for p in result.parameters():
        lines.append(f"  {p['name']} = {_fmt(p['value'], p['sigma'])} {p['unit']}")
    if result.report["undetermined"]:
        lines.append("Not determined by the data (left at their start values): "
                     + ", ".join(result.report["undetermined"]))
    return lines


def write_fitted_toml(path, result, overwrite: bool = False):
    return write_config(path, result.arm, toml_header(result), overwrite)


def write_calibration_h5(path, result, overwrite: bool = False) -> None:
    """The HDF5 file of the module docstring: provenance, :func:`calibration_layout`
    and the whole result under ``/result``."""
    with atomic_h5(path, overwrite) as fh:
        write_attrs(fh, provenance(result.arm, "calibration"))
        calibration_layout(fh, result)
        encode(fh, RESULT_GROUP, result)


def calibration_layout(fh, result) -> None:
    """The groups ``parameters``, ``rows`` and ``summary_json`` in the open file ``fh``
    (named dimensions: parameter, row, tendon, measured_point, component)."""
    rows = result.data
    params = result.parameters()
    fh.attrs["summary_json"] = jsontext.dumps(result.summary())
    g = fh.create_group("parameters")
    names = np.array([p["name"] for p in params], dtype=str)
    PAR = ("parameter",)
    coords = {"parameter": (names, "1", "calibration parameter"),
              "parameter_j": (names, "1", "calibration parameter (second index)")}
    put(g, "names", names, "1", "parameters", PAR, coords)
    put(g, "units", np.array([p["unit"] for p in params], dtype=str), "1", "their units",
        PAR, coords)
    for key in ("start", "value", "lower", "upper"):
        put(g, key, np.array([p[key] for p in params], float), "see units", key, PAR, coords)
    put(g, "sigma", np.array([math.nan if p["sigma"] is None else p["sigma"]
                              for p in params]), "see units",
        "standard deviation (NaN: not determined by the data)", PAR, coords)
    put(g, "covariance", result.report["covariance"], "units_i units_j",
        "Gauss-Newton covariance scaled by the residual variance", PAR + ("parameter_j",),
        coords)
    put(g, "correlation", result.report["correlation"], "1", "correlation matrix",
        PAR + ("parameter_j",), coords)
    put(g, "singular_values", result.report["singular_values"], "mm per scale",
        "singular values of the Jacobian with columns scaled by each parameter's scale",
        ("singular_value",))
    r = fh.create_group("rows")
    R, RT = ("row",), ("row", "tendon")
    RP = ("row", "measured_point", "component")
    points = {"measured_point": (None, "1", "measured point: 0 the tip, then the markers")}
    put(r, "line", np.array(rows.lines), "1", "line of the row in the data file", R)
    put(r, "kind", np.array(rows.kinds, dtype=str), "1", "input kind", R)
    put(r, "inputs", rows.inputs, "N | mm | steps", "tensions, lengths or steps", RT)
    put(r, "measured_mm", rows.points_mm(), "mm", "tip then markers (NaN: not measured)",
        RP, points)
    put(r, "predicted_mm", result.fit.evaluation.points_mm, "mm", "fitted model's points",
        RP, points)
    put(r, "error_mm", result.stats["per_row_mm"], "mm", "largest point error of the row", R)
    put(r, "weight", result.fit.row_weights, "1", "Huber weight (1: not down-weighted)", R)
    put(r, "taut", result.fit.evaluation.taut, "1", "cable carries tension", RT)
    put(r, "tip_covariance_mm2", result.tip_covariance_mm2, "mm^2",
        "covariance of the predicted tip from the parameters' covariance",
        ("row", "component", "component_j"), {"component_j": (list("xy"), "1",
                                                               "vector component (x, y)")})
    cv = result.cross_validation
    if cv is not None and "per_row_mm" in cv:
        put(r, "cv_error_mm", cv["per_row_mm"], "mm",
            "error of the row predicted by the fit without its fold", R)
