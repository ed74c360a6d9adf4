"""The checks and conversions every study of the library shares: the arm, the
mesh, tensions in newtons or p, the sharing floor, ``progress=``, and
``petsc_options=`` (:func:`takes_petsc_options`).  The study modules import
them under their former private names (``_mesh``...), so their bodies read
as before ``api`` became a package."""
from __future__ import annotations

import functools
import inspect

import numpy as np

from ..core import inputs
from ..core.errors import InputError
from ..core.fem import Discretisation
from ..core.model import Arm
from ..solvers.options import call_options


def check_arm(arm) -> Arm:
    """``arm`` if it is an :class:`Arm`, else an InputError saying what it is."""
    if not isinstance(arm, Arm):
        raise InputError(f"arm must be an ep.Arm (Arm.paper() or Arm.from_toml(path)), got "
                         f"{type(arm).__name__}")
    return arm


def takes_petsc_options(study):
    """Give ``study`` the keyword ``petsc_options=`` (the docstring of
    :mod:`elastica_petsc.api`)."""
    @functools.wraps(study)
    def with_options(*args, petsc_options=None, **kwargs):
        with call_options(petsc_options):
            return study(*args, **kwargs)

    signature = inspect.signature(study)
    option = inspect.Parameter("petsc_options", inspect.Parameter.KEYWORD_ONLY, default=None)
    with_options.__signature__ = signature.replace(
        parameters=[*signature.parameters.values(), option])
    return with_options


def mesh(arm: Arm, elements: int | None, friction: bool = False) -> Discretisation:
    """The arm's mesh with ``elements`` (checked; None: the arm's own); an arm with
    friction at its guides only for the friction path (``friction``)."""
    from ..core.friction import check_frictionless

    if not friction:
        check_frictionless(check_arm(arm), "this study")
    return Discretisation.from_arm(check_arm(arm), inputs.elements(elements, "elements"))


def tensions_p(arm: Arm, tensions_N, tensions, names=("tensions_N", "tensions")) -> np.ndarray:
    """Non-dimensional tensions from exactly one of newtons or p, checked in the
    unit given (``names``: the arguments, newtons first)."""
    if (tensions_N is None) == (tensions is None):
        raise InputError(f"give exactly one of {names[0]}= (newtons) or {names[1]}= "
                         "(p = P l^2/B)")
    if tensions is None:
        return arm.tensions_from_N(inputs.tensions(tensions_N, arm.n_tendons, names[0], "N",
                                                   arm.force_scale_N))
    return inputs.tensions(tensions, arm.n_tendons, names[1], "P l^2/B")


def guess_p(arm: Arm, guess_N, guess) -> np.ndarray | None:
    """Initial tensions from ``guess_N`` (N) or ``guess`` (p), or None."""
    if guess_N is None and guess is None:
        return None
    return tensions_p(arm, guess_N, guess, ("guess_N", "guess"))


def floor_N(min_tension_N) -> float:
    """The pretension floor P_min (N) of tension sharing: a number >= 0."""
    value = inputs.number(min_tension_N, "min_tension_N", "N")
    if value < 0:
        raise InputError(f"min_tension_N (the minimum tension of every cable) must be >= 0 N, "
                         f"got {value:g}")
    return value


def progress_bar(progress, label: str, unit: str, delay: float = 0.0):
    """``progress=`` of the long studies as a context: True draws the command
    line's bar (lines in logs; ui/progress.py; on a terminal only after
    ``delay`` seconds), a callable is called as ``progress(done, note)``,
    None/False report nothing."""
    from contextlib import nullcontext

    from ..ui.progress import Progress

    if progress is True:
        return Progress(None, label, unit=unit, delay=delay)
    return nullcontext(progress or None)


def loading_label(order) -> str:
    """How a state was loaded: "proportional" or "order 2,1"."""
    return "proportional" if order is None else "order " + ",".join(map(str, order))


def sharer_for(arm: Arm, controller, share: str | None, min_tension_N: float):
    """The TensionSharer asked for (n >= 3 tendons), or None."""
    from ..solvers.share import TensionSharer, share_rule

    share = share_rule(share, min_tension_N)
    if share == "none":
        return None
    return TensionSharer(controller, share, float(arm.tensions_from_N(min_tension_N)))


def points_mm(points_mm, arm: Arm | None = None, name: str = "points_mm") -> np.ndarray:
    """Target points (k, 2) in mm, checked (on the arm's scale when given)."""
    return inputs.points_mm(points_mm, name, arm)
