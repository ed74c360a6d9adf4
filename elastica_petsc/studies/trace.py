"""Target paths for the tip (Fig. 3) and tracing them with warm starts (Sec. 4.5 (v)).

Shapes are arrays of points in mm, shape (k, 2), in the arm's coordinate
system (clamp at the origin, undeformed arm along +x).  :func:`trace` solves
the tip-control problem at every point, each warm-started from the previous
solution (its tensions as the initial guess, its equilibrium as the SNES
start), and checks the premise of the paper's length-controlled experiments
(Sec. 4.1): cable lengths and tensions vary monotonically together, i.e. a
cable that is reeled in (dL_i < 0) carries more tension (dP_i > 0).
"""
from __future__ import annotations

import csv
import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.model import Arm
from ..core.results import Result
from ..solvers.control import ControlResult, Evaluation, TipController
from ..solvers.tip_problem import needs_arm
from ..core.errors import InputError


class PathError(InputError):
    """A malformed path (file or arguments); the message says where."""


# --- shapes (mm) ------------------------------------------------------------------
def _as_point(center, name: str = "center") -> np.ndarray:
    c = np.asarray(center, dtype=float).ravel()
    if c.shape != (2,) or not np.all(np.isfinite(c)):
        raise PathError(f"{name} must be two finite numbers (x, y) in mm, got {center!r}")
    return c


def line(a, b, n: int = 2) -> np.ndarray:
    """``n`` equally spaced points from ``a`` to ``b`` (both included), mm."""
    a, b = _as_point(a, "a"), _as_point(b, "b")
    if n < 2:
        raise PathError(f"a line needs n >= 2 points, got {n}")
    t = np.linspace(0.0, 1.0, n)[:, None]
    return (1.0 - t) * a + t * b


def circle(center, radius: float, n: int = 73, start_angle_deg: float = 90.0,
           clockwise: bool = False) -> np.ndarray:
    """Closed circle (first point repeated at the end), ``n`` points, mm."""
    c = _as_point(center)
    if not (radius > 0 and math.isfinite(radius)):
        raise PathError(f"circle radius must be positive, got {radius!r}")
    if n < 4:
        raise PathError(f"a circle needs n >= 4 points, got {n}")
    sign = -1.0 if clockwise else 1.0
    angles = np.deg2rad(start_angle_deg) + sign * np.linspace(0.0, 2.0 * np.pi, n)
    pts = c + radius * np.column_stack((np.cos(angles), np.sin(angles)))
    pts[-1] = pts[0]
    return pts


def triangle_vertices(center, circumradius: float = 80.0, start_angle_deg: float = 90.0):
    """Vertices of the equilateral triangle inscribed in the circle of
    ``circumradius`` about ``center`` (first vertex at ``start_angle_deg``)."""
    c = _as_point(center)
    angles = np.deg2rad(start_angle_deg + np.array([0.0, 120.0, 240.0]))
    return c + circumradius * np.column_stack((np.cos(angles), np.sin(angles)))


def paper_triangle(center, circumradius: float = 80.0, points_per_edge: int = 2,
                   points_per_circle: int = 73, start_angle_deg: float = 90.0) -> np.ndarray:
    """The drawing of Fig. 3a, mm: an equilateral triangle of side
    sqrt(3) R (R = 80 mm: 80 sqrt(3) ~ 138.56 mm) traced edge by edge from
    its top vertex, then its incircle (radius R/2 = 40 mm, starting at the
    tangent point of the first edge, reached from the last vertex along the
    radius), then its circumcircle (radius R, starting at the first vertex),
    all about ``center``.  Consecutive duplicate points are dropped; use
    :func:`densify` to set the spacing."""
    c = _as_point(center)
    v = triangle_vertices(c, circumradius, start_angle_deg)
    parts = [line(v[k], v[(k + 1) % 3], points_per_edge) for k in range(3)]
    # incircle: tangent to edge v0-v1 at its midpoint
    mid = 0.5 * (v[0] + v[1])
    a0 = math.degrees(math.atan2(mid[1] - c[1], mid[0] - c[0]))
    parts.append(line(v[0], mid, 2))
    parts.append(circle(c, 0.5 * circumradius, points_per_circle, start_angle_deg=a0))
    parts.append(line(mid, v[0], 2))
    parts.append(circle(c, circumradius, points_per_circle, start_angle_deg=start_angle_deg))
    pts = np.vstack(parts)
    keep = np.ones(len(pts), dtype=bool)
    keep[1:] = np.any(np.abs(np.diff(pts, axis=0)) > 1e-12, axis=1)
    return pts[keep]


def convoluted_curve(center, width: float = 170.0, amplitude: float = 35.0, waves: float = 2.5,
                     n: int = 400) -> np.ndarray:
    """Our stand-in for the paper's Fig. 3b (whose points are not published): a
    connected, non-self-intersecting meander about ``center`` (mm) — a sine of
    ``waves`` periods across ``width`` mm whose amplitude grows from 40 % to
    100 % of ``amplitude``, followed back along a parallel sine shifted down
    by 2.6 amplitudes, so the tip sweeps right, turns and sweeps left through
    alternating curvature.  Any large tracking error would show as a
    self-intersection, as the paper notes."""
    c = _as_point(center)
    t = np.linspace(0.0, 1.0, n)
    envelope = amplitude * (0.4 + 0.6 * t)
    out_x = c[0] - width / 2 + width * t
    out_y = c[1] + 1.3 * amplitude + envelope * np.sin(2 * np.pi * waves * t)
    back_x = out_x[::-1]
    back_y = c[1] - 1.3 * amplitude + (envelope * np.sin(2 * np.pi * waves * t + np.pi))[::-1]
    turn = np.linspace(out_y[-1], back_y[0], 20)[1:-1]
    return np.vstack((np.column_stack((out_x, out_y)),
                      np.column_stack((np.full_like(turn, out_x[-1]), turn)),
                      np.column_stack((back_x, back_y))))


def densify(points, step_mm: float) -> np.ndarray:
    """Insert points on the straight segments between consecutive points so
    that consecutive points are at most ``step_mm`` apart (original points kept)."""
    pts = np.asarray(points, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 1:
        raise PathError(f"points must be an array of shape (k, 2), got shape {pts.shape}")
    if not (step_mm > 0 and math.isfinite(step_mm)):
        raise PathError(f"step must be a positive length in mm, got {step_mm!r}")
    out = [pts[:1]]
    for a, b in zip(pts[:-1], pts[1:]):
        k = max(1, int(math.ceil(np.linalg.norm(b - a) / step_mm * (1 - 1e-12))))
        t = np.arange(1, k + 1)[:, None] / k
        out.append(a + t * (b - a))
    return np.vstack(out)


def read_csv(path, max_rows: int | None = None) -> np.ndarray:
    """Points from a CSV file, shape (k, 2): columns read by the header's names
    ``x_mm`` and ``y_mm`` (in either order; any other or a missing name is
    refused), or, without a header line, ``x_mm,y_mm`` by position.  Blank
    lines and ``#`` comments are ignored.  ``max_rows``: stop after that many
    points (a caller with a limit need not parse a huge file to refuse it)."""
    path = Path(path)
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise PathError(f"{path}: no such path file") from None
    except (OSError, UnicodeDecodeError) as err:
        raise PathError(f"{path}: cannot read: {err}") from None
    rows, columns = [], None
    for lineno, row in enumerate(csv.reader(text.splitlines()), start=1):
        if not row or not "".join(row).strip() or row[0].lstrip().startswith("#"):
            continue
        cells = [c.strip() for c in row]
        if columns is None:
            columns = _csv_columns(path, lineno, cells)
            if columns is not None:
                continue                     # the header line
            columns = (0, 1)
        if len(cells) != 2:
            raise PathError(f"{path}:{lineno}: expected 2 columns x_mm,y_mm, got {len(cells)}")
        try:
            x, y = float(cells[columns[0]]), float(cells[columns[1]])
        except ValueError:
            raise PathError(f"{path}:{lineno}: not a number: {','.join(cells)!r}") from None
        if not (math.isfinite(x) and math.isfinite(y)):
            raise PathError(f"{path}:{lineno}: non-finite coordinate {','.join(cells)!r}")
        rows.append((x, y))
        if max_rows is not None and len(rows) >= max_rows:
            break
    if not rows:
        raise PathError(f"{path}: no points (expected lines x_mm,y_mm)")
    return np.array(rows)


def _csv_columns(path: Path, lineno: int, cells: list[str]) -> tuple[int, int] | None:
    """The (x, y) column indices named by a header line, or None for a data line."""
    try:
        [float(c) for c in cells]
        return None
    except ValueError:
        pass
    names = [c.lower() for c in cells]
    unknown = [c for c in cells if c.lower() not in ("x_mm", "y_mm")]
    if unknown or sorted(names) != ["x_mm", "y_mm"]:
        raise PathError(f"{path}:{lineno}: header {','.join(cells)!r}: expected the columns "
                        "x_mm and y_mm (in mm, either order)"
                        + (f"; unknown: {', '.join(unknown)}" if unknown else ""))
    return names.index("x_mm"), names.index("y_mm")


# --- tracing ------------------------------------------------------------------------
@dataclass(frozen=True, repr=False)
class TraceResult(Result):
    """Tip control along a path.  mm and newtons (converted with the arm's
    l and B / l^2); per point i = 0..k-1, per tendon j."""

    targets_mm: np.ndarray          # (k, 2)
    tips_mm: np.ndarray             # (k, 2)
    tensions_N: np.ndarray          # (k, n)
    p: np.ndarray                   # (k, n) non-dimensional tensions P l^2 / B
    cable_lengths_mm: np.ndarray    # (k, n)
    iterations: np.ndarray          # (k,) optimiser iterations
    evaluations: np.ndarray         # (k,) equilibrium solves
    E: np.ndarray                   # (k,) final objective (non-dimensional)
    converged: np.ndarray           # (k,) bool
    tip_errors_mm: np.ndarray       # (k,)
    seconds: float                  # wall time of the whole trace
    results: tuple[ControlResult, ...] = ()
    arm: Arm | None = None          # the arm traced (saved as provenance)

    @property
    def all_converged(self) -> bool:
        return bool(np.all(self.converged))

    @property
    def n_points(self) -> int:
        return len(self.targets_mm)

    def to_vtk(self, directory, *, times_s=None) -> list[Path]:
        """One state per point in ``directory`` (``trace.pvd``, time ``times_s`` or
        the point index) and the path ``trace_path.vtu``, as ``trace --vtk``
        writes them; needs ``arm`` and the per-point results."""
        from ..io.vtk import write_trace

        return write_trace(directory, needs_arm(self), self, times_s=times_s)

    def to_xarray(self):
        """The traced path as an ``xarray.Dataset`` (xarray optional), dimensions
        ``point``, ``tendon``, ``component`` as in the HDF5 file's ``path/``."""
        from ..io.dims import xarray_dataset

        P2, PT = ("point", "component"), ("point", "tendon")
        return xarray_dataset({
            "target": (P2, self.targets_mm, "mm", "target tip positions, in tracing order"),
            "tip": (P2, self.tips_mm, "mm", "tip positions reached"),
            "tip_error": (("point",), self.tip_errors_mm, "mm", "|tip - target|"),
            "tensions": (PT, self.p, "P l^2/B", "non-dimensional tensions"),
            "tensions_N": (PT, self.tensions_N, "N", "tensions"),
            "cable_lengths": (PT, self.cable_lengths_mm, "mm", "cable lengths |r_i - x_i|"),
            "iterations": (("point",), self.iterations, "1", "optimiser iterations per point"),
            "converged": (("point",), self.converged, "1", "tip within tolerance of the target"),
        }, coords={"point": np.arange(self.n_points)}, attrs={"seconds": self.seconds})

    def monotonic_fraction(self, tol_mm: float = 1e-9, tol_N: float = 1e-12) -> np.ndarray:
        """Per tendon: fraction of steps i -> i+1 in which the cable length and
        the tension change with opposite signs (dL_j dP_j < 0, Sec. 4.1).
        Steps where either change is negligible (below the tolerances) are
        not counted (NaN if none is left)."""
        return monotonic_fraction(self.cable_lengths_mm, self.tensions_N, tol_mm, tol_N)

    def work_fraction(self) -> float:
        """Fraction of steps with sum_j dL_j dP_j < 0: the cables as a whole
        shorten where they pull harder.  For small steps this holds whenever
        the arm is stable: with Pi*(p) = Pi(theta(p), p) the potential at
        equilibrium (docs/model.md §2), L = dPi*/dp, so dL/dp = d^2 Pi*/dp^2 =
        -B^T K^{-1} B is symmetric negative definite when K is.  A per-tendon
        sign change (:meth:`monotonic_fraction` < 1) comes from the coupling
        between the tendons."""
        dL = np.diff(self.cable_lengths_mm, axis=0)
        dP = np.diff(self.tensions_N, axis=0)
        if len(dL) == 0:
            return float("nan")
        return float(np.mean(np.sum(dL * dP, axis=1) < 0))

    def summary(self) -> dict:
        """What ``trace --json`` prints about the path (without the motor schedule)."""
        from ..io.summaries import trace_summary

        return trace_summary(self)


def monotonic_fraction(lengths, tensions, tol_L: float = 1e-9, tol_P: float = 1e-12):
    """Fraction per column of consecutive steps with dL dP < 0 (see TraceResult)."""
    dL = np.diff(np.asarray(lengths, float), axis=0)
    dP = np.diff(np.asarray(tensions, float), axis=0)
    counted = (np.abs(dL) > tol_L) & (np.abs(dP) > tol_P)
    opposite = counted & (dL * dP < 0)
    n = counted.sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > 0, opposite.sum(axis=0) / np.maximum(n, 1), np.nan)


def trace(controller: TipController, targets_mm, *, p0=None, start=None,
          start_loading=None, keep_results: bool = False, stop_on_failure: bool = False,
          on_point=None, global_search: bool = True, sharer=None,
          floors=None) -> TraceResult:
    """Tip control at each target in turn (mm), warm-started from the previous
    point's tensions and equilibrium (Sec. 4.5 (v)).

    p0, start : initial guess and equilibrium for the first point (default:
        unloaded straight arm).  A point that does not converge still
        provides the warm start for the next one only if its equilibrium is
        converged (it always is: the controller returns the last good state).
    start_loading : the loading path of ``start`` (so every point's
        ``loading`` is known; with ``start`` but without it, loadings are None).
    stop_on_failure : stop at the first point that is not reached.
    on_point : called with the number of points done after each point (progress).
    global_search : a point the warm-started local solve does not reach is
        passed to the global strategies of :mod:`elastica_petsc.solvers.reach`
        (their cost is paid only by such points).
    sharer : a :class:`~elastica_petsc.solvers.share.TensionSharer` (n >= 3
        tendons): each point's tensions are the shared ones (minimum norm or
        strain energy, p >= p_min), followed from the previous point's shared
        state by :meth:`TensionSharer.follow` (one SQP on the KKT system per
        point; the plain path is untouched without it).
    floors : with ``sharer``, a per-point floor p_min (non-dimensional, length
        k; default the sharer's), e.g. ramped along an approach from the straight arm.
    """
    from ..solvers.reach import Reacher
    from ..solvers.share import WarmStart

    reacher, warm = Reacher(controller), WarmStart()     # the sharer's, point to point
    targets = np.asarray(targets_mm, dtype=float)
    if targets.ndim != 2 or targets.shape[1] != 2 or len(targets) == 0:
        raise PathError(f"targets must have shape (k, 2) in mm, got {targets.shape}")
    if floors is not None and len(floors) != len(targets):
        raise InputError(f"floors must have one value per target ({len(targets)}), "
                         f"got {len(floors)}")
    results = []
    t0 = time.perf_counter()
    loading = start_loading
    previous = None if sharer is None or start is None else controller.evaluate(
        start.p, start=start, start_loading=start_loading)
    for k, x_d in enumerate(targets):
        if sharer is None:
            res = reacher.reach(x_d / controller.length_mm, p0=p0, start=start,
                                start_loading=loading, global_search=global_search)
            p0, start, loading = res.p, res.equilibrium, res.loading
        else:
            res = sharer.follow(x_d / controller.length_mm, previous, reacher, p0=p0,
                                start=start, start_loading=loading,
                                floor=None if floors is None else floors[k],
                                global_search=global_search, warm=warm)
            if res.converged:          # the next point starts from the last shared state
                previous = Evaluation(res.p, res.equilibrium, res.sensitivity, res.loading)
        results.append(res)
        if on_point is not None:
            on_point(len(results))
        if stop_on_failure and not res.converged:
            break
    seconds = time.perf_counter() - t0
    k = len(results)
    return TraceResult(
        targets_mm=targets[:k].copy(),
        tips_mm=np.array([r.tip_mm for r in results]),
        tensions_N=np.array([r.tensions_N for r in results]),
        p=np.array([r.p for r in results]),
        cable_lengths_mm=np.array([r.cable_lengths_mm for r in results]),
        iterations=np.array([r.iterations for r in results]),
        evaluations=np.array([r.evaluations for r in results]),
        E=np.array([r.E for r in results]),
        converged=np.array([r.converged for r in results]),
        tip_errors_mm=np.array([r.tip_error_mm for r in results]),
        seconds=seconds,
        results=tuple(results) if keep_results else (), arm=controller.arm)
