"""Theorem 1/2 gain design and the paper's errata (see docs/errata.md)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from auv_hinf.design.theorem1 import (
    alpha_minimal,
    alpha_paper,
    alpha_stabilizing,
    design_alpha,
    gamma_min,
    position_loop,
    theorem1_conditions,
)

INV_SQRT2 = 2**-0.5
# Closed forms are evaluated in a handful of flops: round-off tolerance.
CLOSED_FORM_RTOL = 1e-12


def test_paper_notes_item14_values():
    d = alpha_paper(-1.2, 2.86)
    assert d.alpha == pytest.approx(0.330965, abs=5e-7)
    assert d.closed_loop_hinf == pytest.approx(0.653183, abs=5e-7)
    assert d.alpha == pytest.approx(alpha_stabilizing(-1.2, 2.86).alpha, rel=1e-12)
    assert d.flags == ()


def test_erratum_eq32_at_inv_sqrt2():
    """Erratum (docs/errata.md): eq. (32) gives alpha = 0 at gamma = 1/sqrt2, residual 1."""
    lam = -1.2
    d = alpha_paper(lam, INV_SQRT2)
    assert d.alpha == 0.0
    assert d.are_residual == pytest.approx(1.0, rel=1e-12)
    assert any(f.startswith("eq32-at-1/sqrt2") for f in d.flags)
    s = alpha_stabilizing(lam, INV_SQRT2)
    assert s.alpha == pytest.approx(-1 / (2 * lam), rel=CLOSED_FORM_RTOL)
    assert abs(s.are_residual) < 1e-12


def test_stabilizing_continuous_through_inv_sqrt2():
    lam = -0.7
    left = alpha_stabilizing(lam, INV_SQRT2 * (1 - 1e-9)).alpha
    right = alpha_stabilizing(lam, INV_SQRT2 * (1 + 1e-9)).alpha
    mid = alpha_stabilizing(lam, INV_SQRT2).alpha
    assert left == pytest.approx(mid, rel=1e-7) and right == pytest.approx(mid, rel=1e-7)


def test_erratum_wrong_branch_below_inv_sqrt2():
    """Erratum (docs/errata.md): lam=-1.2, g=0.70 gives 58.4 (paper) vs 0.419 (stabilising)."""
    p, s = alpha_paper(-1.2, 0.70), alpha_stabilizing(-1.2, 0.70)
    assert p.alpha == pytest.approx(58.38, abs=0.01)
    assert s.alpha == pytest.approx(0.4197, abs=1e-4)
    assert not p.are_stabilizing and s.are_stabilizing
    assert p.meets_bound and s.meets_bound  # both satisfy ||T|| <= gamma
    assert any(f.startswith("eq32-wrong-branch") for f in p.flags)
    assert abs(p.are_residual) < 1e-9 and abs(s.are_residual) < 1e-12


def test_roots_meet_at_gamma_min():
    lam = -1.2
    g = gamma_min(lam)
    assert g == pytest.approx(1 / math.sqrt(lam**2 + 2))
    assert alpha_paper(lam, g).alpha == pytest.approx(alpha_stabilizing(lam, g).alpha, rel=1e-6)
    assert alpha_stabilizing(lam, g).alpha == pytest.approx(1 / abs(lam), rel=1e-6)


@pytest.mark.parametrize("method", ["paper", "stabilizing"])
def test_below_gamma_min_is_clear_error(method):
    with pytest.raises(ValueError, match="below the Theorem 1 bound"):
        design_alpha(-1.2, 0.5, method)


@pytest.mark.parametrize(
    "lam, gamma, pattern",
    [
        (0.5, 1.0, "lambda must be < 0"),
        (-1.0, -1.0, "gamma must be > 0"),
        (math.nan, 1.0, "lambda must be finite"),
        (-1.0, math.inf, "gamma must be finite"),
    ],
)
def test_bad_inputs(lam, gamma, pattern):
    with pytest.raises(ValueError, match=pattern):
        alpha_stabilizing(lam, gamma)


def test_unknown_method():
    with pytest.raises(ValueError, match="gain method must be one of"):
        design_alpha(-1, 1, "magic")  # type: ignore[arg-type]


def test_minimal_alpha_no_bound_and_zero():
    d = alpha_minimal(-1.2, 0.5)  # below gamma_min: still fine
    assert d.alpha == pytest.approx(0.8) and d.closed_loop_hinf == pytest.approx(0.5)
    assert alpha_minimal(-1.2, 2.86).alpha == 0.0


def test_singular_case_flagged():
    g = 0.8
    lam = -(1 / g - g)
    c = theorem1_conditions(lam, g)
    assert c.singular_case and not c.all_ok
    s = alpha_stabilizing(lam, g)
    assert s.closed_loop_hinf == pytest.approx(g, rel=1e-9)


def test_position_loop_peak():
    pl = position_loop(-1.2, 0.33, 0.2)
    assert pl.hinf == pytest.approx(1 / 1.53)
    assert pl.peak_frequency == pytest.approx(math.sqrt(0.2))
    # evaluate |s/(s^2 + b s + k1)| on a grid: the maximum is 1/b at sqrt(k1)
    w = np.logspace(-3, 3, 20001)
    mag = np.abs(1j * w / (-(w**2) + 1.53j * w + 0.2))
    assert mag.max() == pytest.approx(pl.hinf, rel=1e-6)
    with pytest.raises(ValueError, match="k1 must be > 0"):
        position_loop(-1.2, 0.33, 0.0)


@given(lam=st.floats(-10, -0.01), gamma=st.floats(0.05, 50))
def test_property_designs(lam, gamma):
    m = alpha_minimal(lam, gamma)
    assert m.meets_bound
    if m.alpha > 0:
        assert m.closed_loop_hinf == pytest.approx(gamma, rel=1e-9)  # equality
    assume(gamma >= gamma_min(lam) * (1 + 1e-6))
    s = alpha_stabilizing(lam, gamma)
    p = alpha_paper(lam, gamma)
    assert s.are_stabilizing and s.meets_bound and s.alpha > 0
    assert abs(s.are_residual) < 1e-9 * max(1.0, s.alpha**2 / gamma**2)
    assert s.alpha >= m.alpha - 1e-12  # the K = -L restriction never beats the minimum
    if gamma > INV_SQRT2 * (1 + 1e-9):
        assert p.alpha == pytest.approx(s.alpha, rel=1e-6)
    elif gamma < INV_SQRT2 * (1 - 1e-9):
        assert p.alpha >= s.alpha * (1 - 1e-9)


def test_regimes_and_gamma_ok_share_the_discriminant_tolerance():
    from auv_hinf.design.theorem1 import DOUBLE_ROOT_RTOL, discriminant, discriminant_scale, riccati_regime

    for lam in (-1e-3, -1.2, -1e3):
        gmin = gamma_min(lam)
        assert riccati_regime(lam, gmin) == "double-root"
        inside = gmin * (1 - 0.4 * DOUBLE_ROOT_RTOL)  # within the admitted band
        outside = gmin * (1 - 4 * DOUBLE_ROOT_RTOL)
        assert theorem1_conditions(lam, inside).gamma_ok and riccati_regime(lam, inside) == "double-root"
        assert not theorem1_conditions(lam, outside).gamma_ok
        assert discriminant(lam, outside) < -DOUBLE_ROOT_RTOL * discriminant_scale(lam, outside)
        # the double root is 1/|lam|, reached continuously
        assert alpha_stabilizing(lam, inside).alpha == pytest.approx(1 / abs(lam), rel=1e-5)
    assert riccati_regime(-1.2, INV_SQRT2) == "lyapunov"
    # c = -6e-15: the Lyapunov root is exact to 1e-15 relative
    assert riccati_regime(-1.2, 0.7071067811865497) == "lyapunov"
    assert riccati_regime(-1.2, INV_SQRT2 * (1 + 1e-6)) == "R>0"
