"""The deflation operator of core/deflation.py (Farrell et al. 2015)."""
from __future__ import annotations

import math
import warnings

import numpy as np

from elastica_petsc.core.deflation import Deflation


def _direct(roots, h, theta):
    return math.prod(1.0 / (h * np.sum((theta - r) ** 2)) + 1.0 for r in roots)


def test_factor_and_gradient_match_the_formula_and_finite_differences():
    rng = np.random.default_rng(3)
    h = 0.01
    defl = Deflation(h)
    roots = [rng.standard_normal(100) for _ in range(3)]
    for r in roots:
        defl.add(r)
    theta, e = rng.standard_normal(100), rng.standard_normal(100)
    M, grad = defl.factor_and_gradient(theta)
    assert abs(M - _direct(roots, h, theta)) <= 1e-13 * M
    t = 1e-6
    fd = (_direct(roots, h, theta + t * e) - _direct(roots, h, theta - t * e)) / (2 * t)
    assert abs(grad @ e - fd) <= 1e-7 * max(1.0, abs(fd))


def test_no_overflow_at_or_near_a_deflated_root():
    """At a root M is +inf with a zero gradient, and no warning is printed (the
    search starts Newton from states it has deflated)."""
    rng = np.random.default_rng(4)
    defl = Deflation(1.0 / 400)
    root = rng.standard_normal(400)
    defl.add(root)
    defl.add(root + 1e-3)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for theta in (root, root + 1e-200, root + 1e-160):
            M, grad = defl.factor_and_gradient(theta)
            assert M == math.inf and np.all(grad == 0.0)
        M, grad = defl.factor_and_gradient(root + 1e-9)
        assert np.isfinite(M) and M > 1e12 and np.all(np.isfinite(grad))
