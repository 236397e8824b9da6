"""Chi-square tail probability in plain Python (the core depends on numpy only)."""

from __future__ import annotations

import math

__all__ = ["chi2_isf", "chi2_sf"]

_EPS = 1e-15
_TINY = 1e-300


def chi2_sf(x: float, dof: int) -> float:
    """P(X > x) for X ~ chi-square with ``dof`` degrees of freedom.

    The regularised upper incomplete gamma Q(dof/2, x/2): its series below a + 1, its
    continued fraction (modified Lentz) above, as in Numerical Recipes' gammq.
    """
    if dof <= 0:
        raise ValueError(f"dof must be positive, got {dof}")
    if not math.isfinite(x):
        return 0.0 if x > 0 else 1.0
    a, z = 0.5 * dof, 0.5 * x
    if z <= 0.0:
        return 1.0
    log_prefactor = -z + a * math.log(z) - math.lgamma(a)
    if z < a + 1.0:
        term = total = 1.0 / a
        ap = a
        while abs(term) > abs(total) * _EPS:
            ap += 1.0
            term *= z / ap
            total += term
        return max(0.0, 1.0 - total * math.exp(log_prefactor))
    b = z + 1.0 - a
    c = 1.0 / _TINY
    d = 1.0 / b
    h = d
    i = 0
    while True:
        i += 1
        an = -i * (i - a)
        b += 2.0
        d = an * d + b
        d = d if abs(d) > _TINY else _TINY
        c = b + an / c
        c = c if abs(c) > _TINY else _TINY
        d = 1.0 / d
        delta = d * c
        h *= delta
        if abs(delta - 1.0) < _EPS or i > 10_000:
            break
    return math.exp(log_prefactor) * h


def chi2_isf(p: float, dof: int) -> float:
    """x with P(X > x) = p for X ~ chi-square with ``dof`` degrees of freedom (0 < p < 1):
    ``chi2_sf`` inverted by bisection, to a relative 1e-12."""
    if not 0.0 < p < 1.0:
        raise ValueError(f"p must be in (0, 1), got {p}")
    low, high = 0.0, max(1.0, 2.0 * dof)
    while chi2_sf(high, dof) > p:
        low, high = high, 2.0 * high
    while high - low > 1e-12 * high:
        mid = 0.5 * (low + high)
        low, high = (mid, high) if chi2_sf(mid, dof) > p else (low, mid)
    return 0.5 * (low + high)
