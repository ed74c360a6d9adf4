"""Workspace boundaries by continuation (two tendons).

W_0 (used alike by tip control, the sampled map and this module) is the set
of tips of the stable equilibria connected to the straight arm by
quasi-static loading with all P_i >= 0 (Eq. (18)): the image under the tip
map of D, the connected component of the straight arm in the stable part of
the equilibrium manifold M = {(u, p): F(u, p) = 0, p >= 0}.  D is bounded by

* the faces P_i = 0 (and P_i = P_crit when the config sets a motor limit,
  Eq. (22)),
* cable collapse, L_i = 0 (the attachment point on its routing point, beyond
  which the load direction of Eq. (3) is undefined; traced at L_i = eps =
  COLLAPSE_LENGTH, 1.2 mm on the paper's arm),
* the fold of M over tension space, where K is singular (lambda_min = 0,
  Eq. (20)): the limit points beyond which the arm snaps.

:class:`~.walker.Walker` walks once around D (a wall follower): it
follows one of these curves by pseudo-arclength continuation
(:class:`~elastica_petsc.solvers.continuation.CurveTracer`) with D on its
left in tension space until another constraint becomes active (a bound is
crossed or stability is lost), solves for that corner, and turns onto the
new curve, until it is back at the straight arm.

The tip map can fold inside D (det S = 0, S = d x_t / d p, Eq. (13)); the
boundary of W_0 = f(D) lies in the image of the loop and of these fold
curves (docs/model.md §9.1).  Each loop node carries an intrinsic tip-map
test (:meth:`CurveTracer.tangent`); its sign changes (:func:`tip_fold_crossings`)
are where fold curves meet the loop, and each is traced into D until it
leaves it (:class:`FoldTracer`); three proportional-loading rays scan D for
sign changes that no traced fold explains (:func:`scan_rays`).  W_0 is then
assembled from the faces of the plane minus these images
(:func:`classify_faces`: the preimage count along rays avoiding fold
images); :meth:`BoundaryResult.outside` proves a target outside W_0 when it
lies in the unbounded face (the verdict OUTSIDE_BOUNDARY of tip control).
On the paper's arm: six sign changes, the ends of three fold curves (one
from the straight arm, where det S = 0), all traced; the face of winding
number 0 around r_1 has no preimage (a hole), so the area is exact.

Limits found (issue 13): at a corner where a cable collapses (the tip on
r_2) several equilibria with P_1 = 0 can share the corner, and which one the
walk continues from can depend on the step sizes and the mesh; with a
routing point moved (r_1 = (-53.7, -21.6), r_2 = (81.8, 10.0) mm) the walk
took different loops at 60 and 180 elements.  A fold curve that is a closed
loop inside D missing the scan rays, and states reached only by snapping
onto another sheet, are not covered (docs/model.md §9.1).

The restricted workspace W_0 ∩ W_Y ∩ W_E ∩ W_P (Eqs. (19), (21), (22); W_S
is W_0 itself under this definition, since D holds only stable states) is
the image of the region D_r of D where also l*kappa_max <= 2 eps_Y l / h and
SE <= SE_max: the same walk with those two level curves as extra
constraints.  Where l*kappa_max switches between elements the constraint is
only piecewise smooth; the corrector copes with it (the kink is a corner).


Modules: :mod:`.walker` (the walk around D, fold curves, scan rays),
:mod:`.faces` (the loop's polygon, the faces and their preimage counts),
:mod:`.result` (:class:`BoundaryResult`), :mod:`.trace` (:func:`trace_boundary`
and the process's trace, :func:`traced_w0`), :mod:`.compare` (against a
sampled map); the plane geometry is :mod:`elastica_petsc.core.geometry`.
"""
from .compare import compare_map, compare_restricted, compare_traces, compare_with_samples
from .result import BoundaryResult
from .trace import BoundaryError, TraceCache, boundary_proof, trace_boundary, traced_w0

__all__ = ["BoundaryError", "BoundaryResult", "boundary_proof", "compare_map", "compare_traces",
           "compare_restricted", "compare_with_samples", "TraceCache", "trace_boundary",
           "traced_w0"]
