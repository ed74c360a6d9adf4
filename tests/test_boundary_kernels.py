"""The fast kernels behind `boundary` (issue 13, speed) against plain
reference implementations: the sign of det B from the SuperLU factors
against a dense LU, the permutation sign, the one-pass linearisation of fem
against its three separate kernels, and the vectorised geometry (winding
numbers, self-intersections, union area, Hermite densification, deepest
points of faces) against per-element loops."""
from __future__ import annotations

import numpy as np
import pytest

from elastica_petsc.core.model import load_config
from elastica_petsc.core.fem import Discretisation
from elastica_petsc.solvers.continuation import (CurveTracer, TensionBound, TensionRay,
                                                 permutation_sign)
from elastica_petsc.core.geometry import (hermite_densify, self_intersections, union_area,
                                         winding_number)
from elastica_petsc.studies.boundary.faces import OutsideMap


@pytest.fixture(scope="module")
def disc():
    return Discretisation.from_arm(load_config(), 60)


def _random_state(disc, rng, p):
    u = disc.consistent_state(np.concatenate(([0.0], np.cumsum(rng.normal(0, 0.05,
                                                                     disc.n_elements)))))
    u[disc.n_elements:] += rng.normal(0, 1e-3, 2 * disc.n_tendons)     # off the manifold
    return u, np.asarray(p, float)


def test_linearisation_equals_the_separate_kernels(disc):
    rng = np.random.default_rng(0)
    for _ in range(5):
        u, p = _random_state(disc, rng, rng.uniform(0, 80, 2))
        F, J, L = disc.linearisation(u, p)
        assert np.array_equal(F, disc.residual(u, p))
        assert np.array_equal(J, disc.jacobian_values(u, p))
        assert np.array_equal(L, disc.load_derivative(u))


def test_permutation_sign_against_cycle_count():
    def reference(perm):
        seen, sign = np.zeros(len(perm), bool), 1.0
        for i in range(len(perm)):
            length, j = 0, i
            while not seen[j]:
                seen[j], j, length = True, perm[j], length + 1
            sign *= -1.0 if length and length % 2 == 0 else 1.0
        return sign

    rng = np.random.default_rng(1)
    perms = [rng.permutation(n) for n in (1, 2, 3, 5, 8, 64, 186, 187)]
    perms += [np.arange(10)[::-1], np.roll(np.arange(7), 1)]
    assert [permutation_sign(q) for q in perms] == [reference(q) for q in perms]


def test_determinant_sign_from_superlu_matches_dense_lu(disc):
    """sign det B of the extended matrix (faces, a ray, near-singular rows)
    from the SuperLU factors of B^T against numpy's dense slogdet."""
    rng = np.random.default_rng(2)
    with CurveTracer(disc) as tracer:
        mf, pattern = tracer.mf, tracer.A.pattern
        signs = []
        for k in range(12):
            u, p = _random_state(disc, rng, rng.uniform(0, 60, 2))
            w = np.concatenate((u, p))
            c = TensionBound(mf, k % 2, 0.0) if k % 3 else TensionRay(mf, 0.3 * k)
            orient = rng.normal(size=mf.m) * (1e-9 if k == 5 else 1.0)
            values = pattern.values(mf.jacobian_values(w), mf.load_columns(w),
                                    np.array([c.gradient(w), mf.metric * orient]))
            dense = np.zeros((pattern.n, pattern.n))
            rows = np.repeat(np.arange(pattern.n), np.diff(pattern.csr[0]))
            dense[rows, pattern.csr[1]] = values
            expected = np.linalg.slogdet(dense)[0]
            got = pattern.determinant_sign(pattern.lu_of_transpose(values))
            assert got == expected
            signs.append(got)
    assert set(signs) == {-1.0, 1.0}                  # both signs exercised


def _winding_reference(poly, point):
    total = 0
    for a, b in zip(poly, np.roll(poly, -1, axis=0)):
        cross = (b[0] - a[0]) * (point[1] - a[1]) - (point[0] - a[0]) * (b[1] - a[1])
        if a[1] <= point[1] < b[1] and cross > 0:
            total += 1
        elif b[1] <= point[1] < a[1] and cross < 0:
            total -= 1
    return total


def _crossings_reference(poly):
    n, count = len(poly), 0
    for i in range(n):
        for j in range(i + 2, n):
            if i == 0 and j == n - 1:
                continue
            p, r = poly[i], poly[(i + 1) % n] - poly[i]
            q, s = poly[j], poly[(j + 1) % n] - poly[j]
            denom = r[0] * s[1] - r[1] * s[0]
            if denom == 0:
                continue
            t = ((q - p)[0] * s[1] - (q - p)[1] * s[0]) / denom
            v = ((q - p)[0] * r[1] - (q - p)[1] * r[0]) / denom
            count += 0 < t < 1 and 0 < v < 1
    return count


def test_winding_numbers_and_self_intersections_against_loops():
    rng = np.random.default_rng(3)
    for k in range(12):
        n = int(rng.integers(3, 40))
        poly = rng.normal(size=(n, 2)) if k % 2 else np.cumsum(rng.normal(size=(n, 2)), axis=0)
        points = rng.normal(size=(50, 2)) * 2
        if k % 3 == 0:                       # vertices, ties and horizontal edges
            poly, points = np.round(poly), np.vstack((np.round(points), np.round(poly)))
        expected = [_winding_reference(poly, y) for y in points]
        assert winding_number(poly, points).tolist() == expected
        assert self_intersections(poly) == _crossings_reference(poly)


def test_union_area_of_known_shapes_and_a_doubly_wound_loop():
    square = np.array([[0, 0], [3, 0], [3, 2], [0, 2]], float)
    assert union_area(square) == pytest.approx(6.0, rel=1e-12)
    assert union_area(square[::-1]) == pytest.approx(6.0, rel=1e-12)
    twice = np.vstack((square, square))      # wound twice: counted once
    assert union_area(twice) == pytest.approx(6.0, rel=1e-12)
    angle = np.linspace(0, 2 * np.pi, 400, endpoint=False)
    disc = np.column_stack((np.cos(angle), np.sin(angle)))
    inscribed = 0.5 * 400 * np.sin(2 * np.pi / 400)
    assert union_area(disc, step=1e-4) == pytest.approx(inscribed, rel=1e-6)


def test_hermite_densify_against_per_segment_formula():
    rng = np.random.default_rng(4)
    tip, vel = rng.normal(size=(7, 2)), rng.normal(size=(7, 2))
    vel[3] = 0.0                                # a segment pair falls back to the nodes
    tip[5] = tip[4]                             # a zero chord
    out = [tip[:1]]
    for a in range(6):
        chord = np.linalg.norm(tip[a + 1] - tip[a])
        na, nb = np.linalg.norm(vel[a]), np.linalg.norm(vel[a + 1])
        if chord == 0 or na == 0 or nb == 0:
            out.append(tip[a + 1:a + 2])
            continue
        s = np.linspace(0, 1, 9)[1:, None]
        out.append((2 * s**3 - 3 * s**2 + 1) * tip[a] + (s**3 - 2 * s**2 + s) * vel[a] / na * chord
                   + (-2 * s**3 + 3 * s**2) * tip[a + 1] + (s**3 - s**2) * vel[a + 1] / nb * chord)
    assert np.allclose(hermite_densify(tip, vel), np.vstack(out), rtol=0, atol=1e-14)


def test_bounded_faces_deepest_points():
    """Each face's point is a cell of greatest wall distance within the face
    (the first in C order among ties), its area the face's cells."""
    from scipy import ndimage

    ring = np.array([[0, 0], [10, 0], [10, 10], [0, 10]], float)
    bar = np.array([[5, -1], [5, 11]], float)            # splits the square in two
    om = OutsideMap([ring, bar], 0.25, closed=(0,))
    faces = om.bounded_faces()
    assert len(faces) == 2
    free = (om.labels > 0) & ~om.outside_cells
    depth = ndimage.distance_transform_edt(free)
    for point, area, label in faces:
        ij = tuple(np.floor((point - om.origin) / om.cell).astype(int))
        cells = om.labels == label
        assert om.labels[ij] == label and depth[ij] == depth[cells].max()
        first = np.argmax(np.where(cells, depth, -1.0))
        assert np.ravel_multi_index(ij, om.labels.shape) == first
        assert area == pytest.approx(cells.sum() * om.cell**2)
        assert 30.0 < area < 50.0                        # half the square, less the walls


def test_monotone_slopes_reproduce_lines_and_do_not_overshoot():
    """The slopes of the node values' cubic Hermite interpolation along a curve
    (``faces.loop_polygon(..., monotone=True)``): linear values are reproduced
    exactly on uneven spacings, and a step stays within its two levels."""
    from elastica_petsc.core.geometry import monotone_slopes

    lengths = np.array([0.5, 2.0, 1.0, 0.25])
    s = np.concatenate(([0.0], np.cumsum(lengths)))
    line = np.column_stack((3.0 * s - 1.0, -0.5 * s))
    assert np.allclose(monotone_slopes(line, lengths), [[3.0, -0.5]] * 5, rtol=0, atol=1e-14)
    step = np.array([0.0, 0.0, 1.0, 1.0, 1.0])
    m = monotone_slopes(step, lengths)
    t = np.linspace(0, 1, 101)
    for k, L in enumerate(lengths):
        h00, h10 = 2 * t**3 - 3 * t**2 + 1, t**3 - 2 * t**2 + t
        h01, h11 = -2 * t**3 + 3 * t**2, t**3 - t**2
        v = h00 * step[k] + h10 * L * m[k] + h01 * step[k + 1] + h11 * L * m[k + 1]
        assert np.all(v >= -1e-15) and np.all(v <= 1 + 1e-15)
        assert np.all(np.diff(v) >= -1e-15)
