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


def chi2_isf(p: float, dof: float) -> float:
    """x with P(X > x) = p for X ~ chi-square with ``dof`` degrees of freedom (0 < p < 1),
    to a relative 1e-12: Newton's steps on log ``chi2_sf`` from the Wilson-Hilferty
    approximation, kept inside the bracket the steps have found (bisection where a step
    would leave it); a handful of ``chi2_sf`` evaluations."""
    if not 0.0 < p < 1.0:
        raise ValueError(f"p must be in (0, 1), got {p}")
    target = math.log(p)
    log_norm = math.lgamma(0.5 * dof) + 0.5 * dof * math.log(2.0)
    low, high = 0.0, math.inf
    x = _wilson_hilferty(p, dof)
    for _ in range(200):
        sf = chi2_sf(x, dof)
        if sf > p:
            low = x
        else:
            high = x
        # d log sf / dx = -pdf / sf; pdf = x^(dof/2 - 1) e^(-x/2) / (2^(dof/2) Gamma(dof/2))
        log_pdf = (0.5 * dof - 1.0) * math.log(x) - 0.5 * x - log_norm
        log_ratio = math.log(sf) - log_pdf if sf > 0.0 else math.inf
        new = x + (math.log(sf) - target) * math.exp(log_ratio) if log_ratio < 700.0 else -1.0
        if abs(new - x) <= 1e-13 * x:
            return new
        if not low < new < high:  # outside the bracket (or no step): halve it instead
            new = 0.5 * (low + high) if math.isfinite(high) else 2.0 * x
            if high - low <= 1e-13 * high:
                return new
        x = new
    return x


def _wilson_hilferty(p: float, dof: float) -> float:
    """A first x (> 0) with P(X > x) ~ p: Wilson-Hilferty's cube of a normal, its quantile
    by Abramowitz and Stegun 26.2.23 (to 4.5e-4)."""
    q = min(p, 1.0 - p)
    t = math.sqrt(-2.0 * math.log(q))
    z = t - (2.515517 + 0.802853 * t + 0.010328 * t * t) / (
        1.0 + 1.432788 * t + 0.189269 * t * t + 0.001308 * t**3
    )
    z = z if p < 0.5 else -z
    h = 2.0 / (9.0 * dof)
    cube = 1.0 - h + z * math.sqrt(h)
    return dof * cube**3 if cube > 0.1 else 1e-3 * dof
