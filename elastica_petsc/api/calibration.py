"""Calibration of an arm's parameters to measured states (docs/model.md §14)."""
from __future__ import annotations

from ..core.model import Arm
from .arguments import takes_petsc_options as _takes_petsc_options, mesh as _mesh


@_takes_petsc_options
def calibrate(arm: Arm, data, vary, *, bounds=None, input: str | None = None,
              huber_mm: float | None = None, folds: int = 5, candidates=None,
              method: str = "brgn", elements: int | None = None):
    """Fit the parameters named in ``vary`` (``bending_stiffness``,
    ``tendonK.route``, ``motorK.offset``, ``motor.spool_radius``, ``clamp.angle``,
    ``clamp.position``, ``frame.rotation``, ``frame.offset``; ``tendonK.attach``:
    searched node by node around that fit) to measured states
    ``data`` (a CSV path or a :class:`CalibrationData`); ``bounds``:
    {scalar name: (lo, hi)}; ``method``: "brgn" (exact Jacobian) or "pounders"
    (derivative-free check).  Returns a CalibrationResult: ``.arm`` the fitted
    arm, ``.parameters()`` values with standard deviations, ``.summary()``
    (docs/model.md §14)."""
    from ..core.calibration_data import CalibrationData, read_calibration_csv
    from ..core.calibration_params import ParameterModel
    from ..studies.calibrate_attach import calibrate_with_attachments, split_attach_names

    if not isinstance(data, CalibrationData):
        data = read_calibration_csv(data, arm.n_tendons, input, arm.length_mm)
    if candidates is not None and not isinstance(candidates, CalibrationData):
        candidates = read_calibration_csv(candidates, arm.n_tendons, input, arm.length_mm,
                                          measured=False)
    ParameterModel(arm, split_attach_names(vary, arm)[0], bounds)    # bad names: at once
    return calibrate_with_attachments(arm, data, vary, bounds=bounds,
                                      elements=_mesh(arm, elements).n_elements,
                                      huber_mm=huber_mm, folds=folds, candidates=candidates,
                                      method=method)
