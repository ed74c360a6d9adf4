"""The sample grids of a workspace map: targets on a square lattice (mode
``targets``, paper Fig. 4) or tensions on a lattice (mode ``tensions``), rows
walked serpentine so neighbours stay neighbours, cut into chunks
(:mod:`elastica_petsc.studies.chunks`)."""
from __future__ import annotations

import numpy as np

from ...core.errors import InputError
from ..chunks import Grid, rows_to_chunks


MAX_SAMPLES = 2_000_000        # ~0.4 GB of results on rank 0; the paper's map has 4201


def _check_size(count: float, what: str) -> None:
    if not count <= MAX_SAMPLES:
        raise InputError(f"{what} would give {count:.3g} samples; at most {MAX_SAMPLES:,} "
                         "(use a larger spacing)")


REGIONS = ("half-disc", "disc")


def target_grid(length_mm: float, spacing_mm: float, box=None, chunk: int = 24,
                region: str = "half-disc") -> Grid:
    """Targets on a square lattice of ``spacing_mm``: without ``box`` the
    half-plane y >= 0 within the arm's reach |x| <= l (``region`` "half-disc",
    paper Fig. 4) or the whole disc of reach ("disc"), else ``box`` = (xmin,
    xmax, ymin, ymax) in mm.  Rows of constant y, cut into chunks."""
    if region not in REGIONS:
        raise InputError(f"region {region!r}: expected one of {', '.join(REGIONS)}")
    if not (spacing_mm > 0 and np.isfinite(spacing_mm)):
        raise InputError(f"--spacing must be a positive number of mm, got {spacing_mm}")
    if box is not None and not np.all(np.isfinite(np.asarray(box, float))):
        raise InputError(f"--box {tuple(box)}: expected four finite numbers of mm")
    if box is None:
        rows = 2 if region == "half-disc" else 4            # quarter squares of the lattice
        _check_size(rows * (length_mm / spacing_mm + 1) ** 2, f"--spacing {spacing_mm:g}")
    else:
        _check_size((abs(box[1] - box[0]) / spacing_mm + 1) * (abs(box[3] - box[2]) / spacing_mm
                                                                + 1), f"--spacing {spacing_mm:g}")
    if box is None:
        reach = length_mm
        xs = np.arange(-np.floor(reach / spacing_mm), np.floor(reach / spacing_mm) + 1) * spacing_mm
        lowest = 0 if region == "half-disc" else -np.floor(reach / spacing_mm)
        ys = np.arange(lowest, np.floor(reach / spacing_mm) + 1) * spacing_mm
        inside = lambda x, y: x * x + y * y <= reach * reach * (1 + 1e-12)
        region = (f"half-disc y >= 0, |x| <= l = {length_mm:g} mm" if region == "half-disc"
                  else f"disc |x| <= l = {length_mm:g} mm")
    else:
        xmin, xmax, ymin, ymax = map(float, box)
        if not (xmax > xmin and ymax > ymin):
            raise InputError(f"--box {box}: need xmin < xmax and ymin < ymax")
        xs = xmin + np.arange(0, np.floor((xmax - xmin) / spacing_mm + 1e-9) + 1) * spacing_mm
        ys = ymin + np.arange(0, np.floor((ymax - ymin) / spacing_mm + 1e-9) + 1) * spacing_mm
        inside = lambda x, y: np.ones_like(x, dtype=bool)
        region = f"box x in [{xmin:g}, {xmax:g}], y in [{ymin:g}, {ymax:g}] mm"
    points, rows = [], []
    for j, y in enumerate(ys):
        row_x = xs[inside(xs, np.full_like(xs, y))]
        if j % 2:                                     # serpentine: neighbours stay neighbours
            row_x = row_x[::-1]
        rows.append(np.arange(len(points), len(points) + len(row_x)))
        points.extend((x, y) for x in row_x)
    if not points:
        raise InputError("the sampling region holds no grid point; use a smaller --spacing")
    meta = {"spacing": spacing_mm, "region": region, "chunk": chunk}
    return Grid("targets", np.array(points, float), rows_to_chunks(rows, chunk), meta)


def tension_grid(n_tendons: int, spacing: float, p_max: float, chunk: int = 24) -> Grid:
    """Tensions on a lattice 0 <= p_i <= p_max (non-dimensional), serpentine
    along the last tendon's axis."""
    if not (spacing > 0 and p_max > 0 and np.isfinite(spacing) and np.isfinite(p_max)):
        raise InputError("--tension-spacing and --tension-max must be positive numbers")
    _check_size((p_max / spacing + 1) ** n_tendons, f"--tension-spacing {spacing:g}")
    axis = np.arange(0, np.floor(p_max / spacing + 1e-9) + 1) * spacing
    mesh = np.stack(np.meshgrid(*([axis] * n_tendons), indexing="ij"), -1).reshape(-1, n_tendons)
    rows, points = [], []
    for j, start in enumerate(range(0, len(mesh), len(axis))):
        row = mesh[start:start + len(axis)]
        if j % 2:
            row = row[::-1]
        rows.append(np.arange(len(points), len(points) + len(row)))
        points.extend(row)
    meta = {"spacing": spacing, "region": f"0 <= p_i <= {p_max:g}", "chunk": chunk}
    return Grid("tensions", np.array(points, float), rows_to_chunks(rows, chunk), meta)


def make_grid(arm, disc, mode: str, spacing_mm: float, box_mm, tension_spacing: float,
              tension_max: float, chunk: int, region: str = "half-disc") -> Grid:
    """The sample grid of :func:`run_map`; :class:`InputError` for a bad request."""
    if mode not in ("targets", "tensions"):
        raise InputError(f"mode {mode!r}: expected 'targets' or 'tensions'")
    if not isinstance(chunk, (int, np.integer)) or chunk < 1:
        raise InputError(f"--chunk must be at least 1, got {chunk}")
    if mode == "targets":
        if disc.n_tendons < 2:
            raise InputError("mode targets needs at least 2 tendons (a 2-D workspace); "
                             "use --mode tensions")
        return target_grid(arm.length_mm, spacing_mm, None if box_mm is None else tuple(box_mm),
                           chunk, region)
    return tension_grid(disc.n_tendons, tension_spacing, tension_max, chunk)
