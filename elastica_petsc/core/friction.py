"""Capstan friction at the guides: one tension per cable segment, stick and slip
at every guide as a complementarity problem (docs/model.md §27).  Numpy only,
non-dimensional (l = 1, B = 1, p = P l^2/B).

Segment a of a tendon joins point a (a guide or the end) to its predecessor
(the routing point for the first).  At guide a the cable turns through

    beta_a = |angle(e_a, e_{a+1})|,   e_a = z_a / |z_a|  (chord of segment a),

and the material of the cable between guide a and the end has length
S_a = sum_{b > a} l_b (the end is attached).  Over one increment of a load
path S_a changes by dS_a = S_a - S_a^ref and the capstan law with maximal
dissipation is the variational inequality (Coulomb friction wound round the
guide)

    dS_a < 0 (reeling in, slip toward the motor): P_{a+1} = P_a exp(-mu beta_a)
    dS_a > 0 (paying out, slip toward the end):   P_{a+1} = P_a exp(+mu beta_a)
    P_a exp(-mu beta_a) < P_{a+1} < P_a exp(mu beta_a):  dS_a = 0 (stick),

written without smoothing as the semismooth equation (c > 0 any scale)

    Phi_a = P_{a+1} - clip(P_{a+1} + c dS_a, P_a exp(-mu beta_a), P_a exp(mu beta_a)) = 0.

Each branch of the clip is a mode (SLIP_IN, STICK, SLIP_OUT); in a fixed mode
Phi is smooth and :meth:`CapstanKernel.jacobian_values` is its exact derivative.

The unknowns are w = (u, q): u the bordered state of core/guided.py (angles
and chords) and q the tensions of every segment after a guide, then those of
the motor segments of the length-controlled tendons (a force-controlled
motor's segment carries its given tension).  The equations are the guided
equilibrium with segment tensions (f_a = P_a e_a - P_{a+1} e_{a+1}), one Phi
per guide and L_i = Lbar_i per length-controlled tendon.  With mu = 0 the clip
interval is {P_a}: every tension equals the motor's and the state is the
frictionless one.  Optionally the cables are elastic (compliance eps = B/(EA l^2)):
segment b then holds the unstretched material l_b / (1 + eps P_b), the slip at a guide
is the change of the material beyond it and a length-controlled motor holds its
cable's material (docs/model.md §27.6); eps = 0 is the inextensible cable above.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple

import numpy as np

from .errors import InputError
from .guided import GuidedDiscretisation

# c of Phi (units B/l^3: tension per length of slip).  The solution does not depend on
# it; Newton's first modes do: c dS must outweigh the tension's change of one increment
# (docs/model.md §27.3: c = 30..1000 took 65-74 iterations on a path where c = 1 took 247).
DEFAULT_SCALE = 100.0
SLIP_IN, STICK, SLIP_OUT = -1, 0, 1


class IncrementStart(NamedTuple):
    """What the slip of an increment is measured against: the cable material beyond
    every guide at its start (S_a for inextensible cables)."""

    material: np.ndarray


def guide_friction(arm) -> np.ndarray:
    """The configured friction coefficient of every guide (``[[tendon]]
    friction_coefficient``), in the kernel's order: each cable's guides from its motor,
    tendon by tendon."""
    return np.array([t.friction_coefficient for t in arm.tendons for _ in t.guides], float)


def check_frictionless(arm, study: str) -> None:
    """Refuse an arm configured with friction at its guides for a study that models
    frictionless guides (all but the friction load path: docs/model.md §27.5)."""
    for i, tendon in enumerate(arm.tendons, start=1):
        if tendon.friction_coefficient > 0:
            raise InputError(
                f"tendon[{i}].friction_coefficient = {tendon.friction_coefficient:g}: {study} "
                "models frictionless guides (friction has no potential: no stability, control "
                "or maps with it); friction is followed only by `elastica-petsc friction` / "
                "ep.friction_path, or set the coefficient to 0")


def _perp(v: np.ndarray) -> np.ndarray:
    return np.column_stack((-v[:, 1], v[:, 0]))


@dataclass(frozen=True)
class CapstanKernel:
    """Residual and Jacobian of a guided arm with capstan friction at its guides.

    ``mu``: the friction coefficient of every guide (a scalar, or one value per
    guide in the order of the arm's points); ``scale``: the constant c of Phi.
    """

    disc: GuidedDiscretisation
    mu: np.ndarray
    scale: float = DEFAULT_SCALE
    length_control: np.ndarray | None = None    # per tendon: its motor holds a cable length
    compliance: float = 0.0     # eps = B/(EA l^2) of the cables (0: inextensible)

    @classmethod
    def of(cls, disc: GuidedDiscretisation, mu, scale: float = DEFAULT_SCALE,
           length_control=None, compliance: float = 0.0) -> "CapstanKernel":
        if not getattr(disc, "has_paths", False):
            raise InputError("capstan friction needs an arm whose cables run through guides")
        n_guides = int(np.count_nonzero(~disc.last_point))
        mu = np.atleast_1d(np.asarray(mu, float))
        if mu.size not in (1, n_guides):
            raise InputError(f"give one friction coefficient or one per guide ({n_guides}), "
                             f"got {mu.size}")
        mu = np.broadcast_to(mu.ravel(), (n_guides,)).copy()
        if not np.isfinite(mu).all() or (mu < 0).any():
            bad = mu[~(np.isfinite(mu) & (mu >= 0))][0]
            raise InputError(f"friction coefficient must be finite and >= 0, got {bad:g}")
        if n_guides == 0:
            raise InputError("capstan friction needs at least one guide on a cable")
        control = np.zeros(disc.n_tendons, bool) if length_control is None else \
            np.broadcast_to(np.asarray(length_control, bool), (disc.n_tendons,)).copy()
        if not (np.isfinite(compliance) and compliance >= 0):
            raise InputError(f"cable compliance must be finite and >= 0, got {compliance!r}")
        return cls(disc, mu, float(scale), control, float(compliance))

    # --- layout -----------------------------------------------------------------------
    @cached_property
    def guides(self) -> np.ndarray:
        """The arm point of each guide (every point but the cables' ends)."""
        return np.flatnonzero(~self.disc.last_point)

    @property
    def n_guides(self) -> int:
        return len(self.guides)

    @cached_property
    def first_segments(self) -> np.ndarray:
        """The motor segment of each tendon (from its routing point)."""
        return np.asarray(self.disc.path_starts[:-1])

    @property
    def lengths_held(self) -> np.ndarray:
        """The tendons whose motor holds a cable length (its tension is unknown)."""
        return np.flatnonzero(self.length_control)

    @property
    def size(self) -> int:
        return self.disc.size + self.n_guides + len(self.lengths_held)

    @cached_property
    def unknown_of_segment(self) -> np.ndarray:
        """Index in q of each segment's tension, -1 for a force-controlled motor's
        segment (given): the segments after the guides, then the motor segments
        of the length-controlled tendons."""
        out = np.full(self.disc.n_points, -1)
        out[self.guides + 1] = np.arange(self.n_guides)
        out[self.first_segments[self.lengths_held]] = self.n_guides + np.arange(
            len(self.lengths_held))
        return out

    def split(self, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return w[:self.disc.size], w[self.disc.size:]

    def segment_tensions(self, w: np.ndarray, motor) -> np.ndarray:
        """P_a of every segment: ``motor`` (per tendon: the tension of a force-controlled
        motor, the cable length of a length-controlled one) on the first segments of
        force control, q on the others."""
        out = np.empty(self.disc.n_points)
        given = ~self.length_control
        out[self.first_segments[given]] = np.asarray(motor, float)[given]
        unknown = self.unknown_of_segment >= 0
        out[unknown] = self.split(w)[1][self.unknown_of_segment[unknown]]
        return out

    def frictionless_state(self, u: np.ndarray, p) -> np.ndarray:
        """w of a frictionless state u at tensions p: every segment at its motor's."""
        p = np.asarray(p, float)
        return np.concatenate((u, p[self.disc.point_tendon][self.guides + 1],
                               p[self.lengths_held]))

    def cable_lengths(self, w: np.ndarray) -> np.ndarray:
        """L_i of every tendon, from the chords of w."""
        return self.disc.cables(self.disc.split(self.split(w)[0])[1])[0]

    # --- geometry of the cables ------------------------------------------------------
    def _after(self, per_segment: np.ndarray) -> np.ndarray:
        """sum_{b>a} of a per-segment quantity over the same cable, at every guide a."""
        after = np.empty_like(per_segment)
        starts = self.disc.path_starts
        for i in range(self.disc.n_tendons):
            part = per_segment[starts[i]:starts[i + 1]]
            after[starts[i]:starts[i + 1]] = np.cumsum(part[::-1])[::-1] - part
        return after[self.guides]

    def segment_lengths(self, w: np.ndarray) -> np.ndarray:
        return self.disc.segments(self.disc.split(self.split(w)[0])[1])[0]

    def beyond(self, w: np.ndarray) -> np.ndarray:
        """S_a of every guide: the cable length from guide a to its end, sum_{b>a} l_b."""
        return self._after(self.segment_lengths(w))

    def _stretch(self, w: np.ndarray, motor) -> np.ndarray:
        """1 + eps P_b of every segment: its length over its unstretched material."""
        return 1.0 + self.compliance * self.segment_tensions(w, motor)

    def material(self, w: np.ndarray, motor) -> np.ndarray:
        """The unstretched cable material of every segment, l_b / (1 + eps P_b)."""
        return self.segment_lengths(w) / self._stretch(w, motor)

    def cable_material(self, w: np.ndarray, motor) -> np.ndarray:
        """The material of every cable (what a length-controlled motor holds; L_i when
        inextensible)."""
        return np.add.reduceat(self.material(w, motor), list(self.disc.path_starts[:-1]))

    def start_of(self, w: np.ndarray, motor) -> IncrementStart:
        """What an increment from the state w (at the motor values ``motor``) measures from."""
        return IncrementStart(self._after(self.material(w, motor)))

    def slip(self, w: np.ndarray, motor, start: IncrementStart) -> np.ndarray:
        """The cable material drawn through each guide toward its end since ``start``
        (docs/model.md §27.1, §27.6)."""
        return self._after(self.material(w, motor)) - start.material

    def turning(self, e: np.ndarray) -> np.ndarray:
        """Signed angle from e_a to e_{a+1} at each guide (its modulus is beta_a)."""
        a, b = e[self.guides], e[self.guides + 1]
        return np.arctan2(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0], np.sum(a * b, axis=1))

    def wrap_angles(self, w: np.ndarray) -> np.ndarray:
        """beta_a of every guide."""
        e = self.disc.segments(self.disc.split(self.split(w)[0])[1])[1]
        return np.abs(self.turning(e))

    # --- the complementarity ----------------------------------------------------------
    def _bounds(self, w, motor):
        """Segment lengths and directions, tensions, signed turns, P_a and P_{a+1} at each
        guide and the interval [P_a e^{-mu beta}, P_a e^{mu beta}]."""
        seg_len, e = self.disc.segments(self.disc.split(self.split(w)[0])[1])
        tension = self.segment_tensions(w, motor)
        tau = self.turning(e)
        beta = np.abs(tau)
        pa, pb = tension[self.guides], tension[self.guides + 1]
        lo, hi = pa * np.exp(-self.mu * beta), pa * np.exp(self.mu * beta)
        return seg_len, e, tension, tau, pa, pb, lo, hi

    def modes(self, w: np.ndarray, motor, start: IncrementStart) -> np.ndarray:
        """The branch of the clip at w: SLIP_IN, STICK or SLIP_OUT per guide (ties to slip,
        so that mu = 0 is never a stick)."""
        *_, pb, lo, hi = self._bounds(w, motor)
        trial = pb + self.scale * self.slip(w, motor, start)
        return np.where(trial <= lo, SLIP_IN, np.where(trial >= hi, SLIP_OUT, STICK))

    def guide_residual(self, w, motor, start: IncrementStart, modes) -> np.ndarray:
        """Phi of every guide in the given modes."""
        *_, pb, lo, hi = self._bounds(w, motor)
        stick = -self.scale * self.slip(w, motor, start)
        return np.where(modes == SLIP_IN, pb - lo, np.where(modes == SLIP_OUT, pb - hi, stick))

    def residual(self, w: np.ndarray, motor, start: IncrementStart, modes=None) -> np.ndarray:
        """F(w): the guided equilibrium with segment tensions, then Phi per guide
        (``modes`` None: the modes of w, :meth:`modes`)."""
        modes = self.modes(w, motor, start) if modes is None else np.asarray(modes)
        u = self.split(w)[0]
        terms = self.disc.segment_terms(u, self.segment_tensions(w, motor))
        held = self.lengths_held
        return np.concatenate((self.disc.residual(u, None, terms=terms),
                               self.guide_residual(w, motor, start, modes),
                               self.cable_material(w, motor)[held] - np.asarray(motor, float)[held]))

    # --- the Jacobian: the guided pattern, the q columns and the Phi rows ----------------
    @cached_property
    def _coo(self):
        """(rows, cols) of every stored entry, and the order that sorts them into CSR."""
        disc, n_u = self.disc, self.disc.size
        indptr, indices, _ = disc.pattern
        rows = [np.repeat(np.arange(n_u), np.diff(indptr))]
        cols = [np.asarray(indices)]
        chord, grow = disc.entries[:2]
        on_q = self.unknown_of_segment[chord] >= 0
        rows.append(grow[on_q])                                       # dF_theta / dq
        cols.append(n_u + self.unknown_of_segment[chord[on_q]])
        for j, a in enumerate(self.guides):                           # dPhi_j / d(z, q)
            last = disc.path_starts[disc.point_tendon[a] + 1]
            zc = disc.n_elements + np.arange(2 * a, 2 * last)
            qc = [n_u + k for k in self.unknown_of_segment[a:last] if k >= 0]
            rows.append(np.full(len(zc) + len(qc), n_u + j))
            cols.append(np.concatenate((zc, qc)))
        for r, i in enumerate(self.lengths_held):     # dL_i / d(z, q): every segment's
            lo, hi = disc.path_starts[i], disc.path_starts[i + 1]
            zc = disc.n_elements + np.arange(2 * lo, 2 * hi)
            qc = [n_u + k for k in self.unknown_of_segment[lo:hi] if k >= 0]
            rows.append(np.full(len(zc) + len(qc), n_u + self.n_guides + r))
            cols.append(np.concatenate((zc, qc)))
        rows, cols = np.concatenate(rows), np.concatenate(cols)
        order = np.lexsort((cols, rows))
        return rows, cols, order, on_q

    @cached_property
    def pattern(self) -> tuple[np.ndarray, np.ndarray]:
        """CSR (indptr, indices) of the Jacobian, int32."""
        rows, cols, order, _ = self._coo
        indptr = np.searchsorted(rows[order], np.arange(self.size + 1)).astype(np.int32)
        return indptr, cols[order].astype(np.int32)

    def jacobian_values(self, w: np.ndarray, motor, start: IncrementStart,
                        modes) -> np.ndarray:
        """Entries of dF/dw in the order of :attr:`pattern`, in the fixed ``modes``."""
        disc = self.disc
        u = self.split(w)[0]
        tension = self.segment_tensions(w, motor)
        t = disc.segment_terms(u, tension)
        dg = disc.segment_gradients(t.theta, (t.c, t.s))
        chord = disc.entries[0]
        _, _, order, on_q = self._coo
        parts = [disc.jacobian_values(u, None, t, dg)]
        # dF_theta/dP_a = grad_theta l_a = -D_a^T e_a (docs/model.md §11.3, per segment)
        parts.append(-np.sum(dg[on_q] * t.e[chord[on_q]], axis=1))
        stretch = self._stretch(w, motor)
        # d material_b = e_b . dz_b / (1 + eps P_b) - eps l_b dP_b / (1 + eps P_b)^2
        dm_dz = t.e / stretch[:, None]
        dm_dp = -self.compliance * t.seg_len / stretch ** 2
        parts.extend(self._guide_rows(w, motor, np.asarray(modes), dm_dz, dm_dp))
        starts = disc.path_starts
        for i in self.lengths_held:
            lo, hi = starts[i], starts[i + 1]
            unknown = self.unknown_of_segment[lo:hi] >= 0
            parts.append(np.concatenate((dm_dz[lo:hi].ravel(), dm_dp[lo:hi][unknown])))
        return np.concatenate(parts)[order]

    def _guide_rows(self, w, motor, modes, dm_dz, dm_dp) -> list[np.ndarray]:
        """dPhi_j/d(z_a..z_last, P_a..P_last) in the column order of :attr:`_coo`
        (``dm_dz``, ``dm_dp``: the derivatives of each segment's material)."""
        disc = self.disc
        seg_len, e, _, tau, pa, _, lo, hi = self._bounds(w, motor)
        # d beta / d z: phi_a = angle of z_a, d phi_a/d z_a = e_a^perp / l_a
        sign = np.sign(tau)[:, None]
        dphi = _perp(e) / seg_len[:, None]
        out = []
        for j, a in enumerate(self.guides):
            last = disc.path_starts[disc.point_tendon[a] + 1]
            dz = np.zeros((last - a, 2))
            q_own = [] if self.unknown_of_segment[a] < 0 else [0.0]
            if modes[j] == STICK:                     # Phi = -c (material beyond a - start)
                dz[1:] = -self.scale * dm_dz[a + 1:last]
                out.append(np.concatenate((dz.ravel(), q_own,
                                           -self.scale * dm_dp[a + 1:last])))
                continue
            bound = lo[j] if modes[j] == SLIP_IN else hi[j]
            rate = modes[j] * self.mu[j]              # Phi = P_{a+1} - P_a exp(rate beta)
            dz[0] = bound * rate * sign[j] * dphi[a]
            dz[1] = -bound * rate * sign[j] * dphi[a + 1]
            q_own = [] if not q_own else [-bound / pa[j] if pa[j] != 0.0 else
                                          -np.exp(rate * abs(tau[j]))]
            out.append(np.concatenate((dz.ravel(), q_own, [1.0], np.zeros(last - a - 2))))
        return out
