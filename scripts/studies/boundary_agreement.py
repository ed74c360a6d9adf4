#!/usr/bin/env python3
"""Agreement of the traced W_0 boundary with a sampled target map (issue 13).

    python scripts/studies/boundary_agreement.py MAP.h5 [--elements N] [--json]

MAP.h5 from `elastica-petsc workspace --spacing 11.67 --out MAP.h5` (mode
targets, the paper's Fig. 4 half-disc).  Traces the boundary of the map's arm
(W_0 with the tip-map folds, faces decided: docs/model.md §9.1) and counts:

* reached samples (status 1) not in W_0 by more than one grid spacing;
* samples whose tip control ended on P_i = 0 (status 2, a local verdict; in a
  map of the global sampler: every sample not reached, 4 and 6) in
  W_0 by more than one spacing (these are reachable states the map missed);
* not-converged samples (status 3) in W_0;
* samples of status 2 that the boundary proves outside W_0 (the verdict
  OUTSIDE_BOUNDARY of tip control: unbounded component, more than three
  cells from the curves), and those in a bounded face with no preimage (N = 0);
* the area of W_0 in y >= 0 against the sample-count estimate (row y = 0 at
  half weight) and its sampling error (half a cell per unit of boundary).
"""
from __future__ import annotations

import argparse
import json

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("map", help="a workspace file (mode targets)")
    ap.add_argument("--elements", type=int, help="mesh of the boundary (default: the arm's)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    import petsc4py
    petsc4py.init([])
    from elastica_petsc.core.fem import Discretisation
    from elastica_petsc.io.reader import file_arm, open_h5
    from elastica_petsc.plots.workspace import read_workspace
    from elastica_petsc.studies.boundary import compare_map, trace_boundary

    samples = read_workspace(args.map)
    with open_h5(args.map) as fh:
        arm = file_arm(fh)
    result = trace_boundary(arm, Discretisation.from_arm(arm, args.elements), restricted=False)
    # maps of the global sampler: every target not reached (undecided, 4, or proven
    # outside the traced boundary, 6) is counted with the local sampler's status 2
    status = np.where(np.isin(samples["status"], (4, 6)), 2, samples["status"])
    out = compare_map(result, samples["target"], status, samples["spacing"])
    status2 = samples["target"][status == 2]
    om = result.outside_map
    far = om.distance(status2) > 3 * result.cell_mm
    proven = om.outside(status2) & far if not result.untraced_folds else np.zeros(len(status2), bool)
    holes = [f["label"] for f in result.faces if f["preimages"] == 0]
    in_hole = np.isin(om.label(status2), holes) & far
    out |= {"status2_proven_outside": int(proven.sum()), "status2_in_holes": int(in_hole.sum()),
            "spacing_mm": samples["spacing"], "w0_area_mm2": result.area_mm2,
            "w0_area_bounds_mm2": list(result.area_bounds_mm2),
            "fold_curves": len(result.fold_curves), "untraced_folds": result.untraced_folds,
            "boundary_solves": result.solves, "map": args.map}
    if args.json:
        print(json.dumps(out, indent=1))
        return
    print(f"map {args.map} (spacing {out['spacing_mm']:g} mm) against the traced W_0 "
          f"({out['fold_curves']} fold curves, {out['boundary_solves']} solves):")
    print(f"  reached samples outside W_0 by more than one spacing: "
          f"{out['reached_outside']} of {out['reached']}")
    print(f"  samples ended on P_i = 0 inside W_0 by more than one spacing: "
          f"{out['needs_negative_inside']} of {out['needs_negative']}")
    print(f"  not-converged samples inside W_0: {out['not_converged_inside']}")
    print(f"  samples ended on P_i = 0 proven outside (OUTSIDE_BOUNDARY): "
          f"{out['status2_proven_outside']}; in a bounded face with no preimage: "
          f"{out['status2_in_holes']}")
    if "area_y_ge_0_mm2" in out:
        print(f"  area in y >= 0: traced {out['area_y_ge_0_mm2']:.0f} mm^2, sample count "
              f"{out['sample_area_mm2']:.0f} +- {out['sampling_error_mm2']:.0f} mm^2")


if __name__ == "__main__":
    main()
