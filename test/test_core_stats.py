"""com_core.estimation.fits.stats: the chi-square tail and its inverse against tabulated values."""

from __future__ import annotations

import pytest

from com_core.estimation.fits.stats import chi2_isf, chi2_sf


@pytest.mark.parametrize(
    ("x", "dof", "p"),
    [(3.841458820694124, 1, 0.05), (7.814727903251178, 3, 0.05), (16.26623619623813, 3, 1e-3)],
)
def test_the_tail_and_its_inverse_match_the_tables(x, dof, p):
    assert chi2_sf(x, dof) == pytest.approx(p, rel=1e-9)
    assert chi2_isf(p, dof) == pytest.approx(x, rel=1e-9)


def test_a_probability_outside_the_open_interval_is_refused():
    with pytest.raises(ValueError, match="p must be"):
        chi2_isf(1.0, 3)
