"""HDF5 writer and reader of workspace boundaries (``elastica-petsc boundary --out``).

Layout (root attributes: provenance of :func:`elastica_petsc.io.hdf5.provenance`,
``kind = "boundary"``, ``solves``, ``seconds``, ``messages_json``)::

    <region>/                     one group per region: W0, restricted
        attrs: closed, message, area_mm2
        polygon        (k, 2)  mm       closed polygon (last vertex joins the first);
                                        orientation as the tip map gives it, the
                                        region is where its winding number is nonzero
        nodes/tip      (m, 2)  mm       continuation nodes, in order around the loop
        nodes/tensions (m, 2)  P l^2/B  tensions at the nodes
        nodes/tensions_N (m, 2) N
        nodes/curve    (m,)    1        index of the curve each node lies on
        curves         attrs: names_json (constraint of each curve, in order),
                              ends_json (why each curve ended)
    tip_folds          (f, 2)  mm       points of the W0 loop where det S changes sign
    W0/folds/<k>/tip   (m, 2)  mm       tip image of fold curve k of the tip map inside D
    W0/folds/<k>/tensions (m, 2) P l^2/B  its nodes' tensions
        attrs: end (why it ended), end_constraint (the boundary piece it was cut at)
    W0 attrs: area_lower_mm2, area_upper_mm2 (proven in W_0 / not proven outside),
              faces_json (bounded faces: point_mm, area_mm2, winding, preimages),
              untraced_json (fold crossings not traced: no OUTSIDE_BOUNDARY verdicts)
"""
from __future__ import annotations

import json

import numpy as np

from ..core import jsontext
from .hdf5 import atomic_h5, provenance, put, write_attrs


def write_boundary(path, result, overwrite: bool = False) -> None:
    """Write a :class:`~elastica_petsc.studies.boundary.BoundaryResult`: the layout
    above and the whole result under ``/result`` (``elastica_petsc.read`` returns it)."""
    from .records import RESULT_GROUP, encode

    with atomic_h5(path, overwrite) as fh:
        write_boundary_layout(fh, result)
        encode(fh, RESULT_GROUP, result)


# the continuation nodes' dimension (io/dims.py): not the mesh's nodes
NODE = {"node": (None, "1", "continuation node of the boundary's curves")}


def write_boundary_layout(fh, result) -> None:
    """The layout of the module docstring into the open file ``fh``."""
    arm = result.arm
    l_mm = arm.length_mm
    write_attrs(fh, provenance(arm, "boundary"))
    fh.attrs["solves"] = result.solves
    fh.attrs["seconds"] = result.seconds
    fh.attrs["messages_json"] = jsontext.dumps(result.messages)
    for name, region in result.regions.items():
        group = fh.create_group(name)
        group.attrs["closed"] = bool(region.closed)
        group.attrs["message"] = region.message
        group.attrs["area_mm2"] = result.areas_mm2[name]
        put(group, "polygon", result.polygons_mm[name][0], "mm",
            "closed polygon of the region's boundary; inside = nonzero winding number",
            ("vertex", "component"))
        nodes = region.nodes()
        sub = group.create_group("nodes")
        put(sub, "tip", nodes["tip"] * l_mm, "mm", "continuation nodes around the loop",
            ("node", "component"), NODE)
        put(sub, "tensions", nodes["p"], "P l^2/B", "tensions p_i at the nodes",
            ("node", "tendon"), NODE)
        put(sub, "tensions_N", arm.tensions_to_N(nodes["p"]), "N", "tensions P_i",
            ("node", "tendon"), NODE)
        put(sub, "curve", nodes["curve"], "1", "index of the curve of each node", ("node",),
            NODE)
        curves = group.create_group("curves")
        curves.attrs["names_json"] = jsontext.dumps([c.constraint for c in region.curves])
        curves.attrs["ends_json"] = jsontext.dumps([c.end for c in region.curves])
    if "W0" in fh:
        _write_folds(fh["W0"], result)
    put(fh, "tip_folds", np.reshape(result.tip_folds_mm, (-1, 2)), "mm",
        "points of the W0 loop where det(d x_t/d p) changes sign (tip-map folds)",
        ("fold_point", "component"))


def _write_folds(group, result) -> None:
    """Fold curves of the tip map, face list and area bounds of W_0."""
    lo, hi = result.area_bounds_mm2
    group.attrs["area_lower_mm2"], group.attrs["area_upper_mm2"] = lo, hi
    group.attrs["faces_json"] = jsontext.dumps(result.faces)
    group.attrs["untraced_json"] = jsontext.dumps(result.untraced_folds)
    folds = group.create_group("folds")
    for k, (curve, line) in enumerate(zip(result.fold_curves, result.fold_polylines_mm)):
        sub = folds.create_group(str(k))
        put(sub, "tip", line, "mm", "tip image of a fold curve of the tip map (Hermite-densified)",
            ("vertex", "component"))
        put(sub, "tensions", np.array([pt.w[-2:] for pt in curve.points]), "P l^2/B",
            "tensions at the fold curve's continuation nodes", ("node", "tendon"), NODE)
        sub.attrs["end"] = curve.end
        sub.attrs["end_constraint"] = curve.end_constraint or ""


def read_boundary(path) -> dict:
    """{region: {polygon, area_mm2, closed, tip, tensions, curve, names, folds,
    faces}} and tip_folds."""
    import h5py

    from ..core.errors import InputError

    try:
        with h5py.File(path, "r") as fh:
            if fh.attrs.get("kind") != "boundary":
                raise InputError(f"{path}: not a file written by `boundary --out`")
            out = {"tip_folds": fh["tip_folds"][()], "regions": {}}
            for name in ("W0", "restricted"):
                if name not in fh:
                    continue
                g = fh[name]
                out["regions"][name] = {
                    "polygon": g["polygon"][()], "area_mm2": float(g.attrs["area_mm2"]),
                    "closed": bool(g.attrs["closed"]), "tip": g["nodes/tip"][()],
                    "tensions": g["nodes/tensions"][()], "curve": g["nodes/curve"][()],
                    "names": json.loads(g["curves"].attrs["names_json"]),
                    "folds": [g["folds"][k]["tip"][()] for k in sorted(g["folds"], key=int)]
                    if "folds" in g else [],
                    "faces": json.loads(g.attrs.get("faces_json", "[]"))}
    except OSError as err:
        raise InputError(f"{path}: cannot read it as HDF5: {err}") from None
    return out
