"""Cross-checks: care (control, scipy) vs the closed form vs cvxpy/Clarabel LMIs vs python-control."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from auv_hinf.design.blocks import NORM_RTOL, hinf_norm, position_block, velocity_block
from auv_hinf.design.brl import lmi_hinf_norm
from auv_hinf.design.crosscheck import crosscheck
from auv_hinf.design.riccati import ARE_RTOL, riccati_alpha
from auv_hinf.design.theorem1 import alpha_stabilizing, gamma_min
from auv_hinf.numerics.lmi import LMI_RTOL

INV_SQRT2 = 2**-0.5


def test_item14_four_ways():
    r = crosscheck(-1.2, 2.86, 3)
    assert r.ok, [c for c in r.checks if not c.ok]
    assert r.alpha_care == pytest.approx(0.330965, abs=5e-7)
    assert r.hinf_lmi == pytest.approx(0.6531828, rel=LMI_RTOL)
    assert r.hinf_python_control == pytest.approx(0.6531825, rel=NORM_RTOL)


@pytest.mark.parametrize("gamma, regime", [(2.86, "R>0"), (0.70, "R<0"), (INV_SQRT2, "lyapunov")])
@pytest.mark.parametrize("solver", ["control", "scipy"])
def test_riccati_regimes_return_stabilizing_root(gamma, regime, solver):
    """Below 1/sqrt2 R is negative definite; both solvers still return the stabilising root."""
    r = riccati_alpha(-1.2, gamma, 3, solver=solver)
    assert r.regime == regime
    assert r.alpha == pytest.approx(alpha_stabilizing(-1.2, gamma).alpha, rel=ARE_RTOL)
    assert r.structure_error < 1e-12 and r.residual < 1e-10


@pytest.mark.parametrize("n", range(2, 21))
def test_care_full_size(n):
    for g in (0.6, 1.5):
        r = riccati_alpha(-0.9, g, n, solver="scipy")
        assert r.alpha == pytest.approx(alpha_stabilizing(-0.9, g).alpha, rel=ARE_RTOL)


@pytest.mark.slow
@pytest.mark.parametrize("n", [2, 5, pytest.param(8, marks=pytest.mark.slow)])
def test_full_crosscheck_sizes(n):
    r = crosscheck(-0.8, 0.65, n)
    assert r.ok, [c for c in r.checks if not c.ok]


def test_boundary_gamma_min():
    r = crosscheck(-1.2, gamma_min(-1.2), 3)
    assert r.ok
    assert r.alpha_stabilizing == pytest.approx(1 / 1.2, rel=1e-6)


def test_below_gamma_min_only_minimal():
    r = crosscheck(-0.3, 0.5, 3)
    assert r.alpha_paper is None and r.alpha_care is None
    assert r.alpha_lmi_minimal == pytest.approx(1.7, rel=LMI_RTOL)
    assert r.ok


def test_lmi_norm_of_generic_system(rng):
    """BRL analysis against python-control on a random stable MIMO system."""
    a = rng.normal(size=(4, 4))
    a -= (np.abs(np.linalg.eigvals(a)).max() + 0.5) * np.eye(4)
    sys = __import__("control").ss(a, rng.normal(size=(4, 2)), rng.normal(size=(2, 4)), np.zeros((2, 2)))
    assert lmi_hinf_norm(sys).value == pytest.approx(hinf_norm(sys), rel=1e-4)


def test_state_space_models():
    v = velocity_block(-1.2, 0.33)
    assert v.nstates == 2 and np.allclose(v.A, -1.53 * np.eye(2))
    p = position_block(-1.2, 0.33, 0.2)
    assert p.nstates == 4 and np.all(np.real(p.poles()) < 0)


@settings(max_examples=8, deadline=None)
@given(lam=st.floats(-4, -0.05), gamma=st.floats(0.2, 10))
@example(lam=-1.0, gamma=0.99999)  # found by CI: alpha_minimal = 1e-5
def test_property_crosscheck_agrees(lam, gamma):
    r = crosscheck(lam, gamma, 2)
    assert r.ok, [c for c in r.checks if not c.ok]
    if r.alpha_minimal > 0:
        # relative to the quantity the LMI computes, alpha - lam (= 1/gamma here): alpha itself can
        # be a near-cancellation (lam = -1, gamma = 0.99999 gives alpha = 1e-5 from two O(1) terms)
        assert r.alpha_lmi_minimal - lam == pytest.approx(r.alpha_minimal - lam, rel=LMI_RTOL)


# ---------------------------------------------------------------------------------------
# Reliability: every check is relative to its own quantity, so a 1 % error fails at every
# scale; formerly failing inputs now give a report (with the formulation used), no traceback.
# ---------------------------------------------------------------------------------------

# gammas away from gamma_min, where the Riccati tolerances are not widened by root_condition
SCALES = [(-1e-3, 1.0), (-1.0, 0.9), (-1e3, 2e-3), (-1e6, 1.0)]


@pytest.mark.parametrize("lam, gamma", SCALES)
def test_wrong_values_fail_every_check_at_every_scale(lam, gamma):
    r = crosscheck(lam, gamma, 2)
    assert r.ok, [c for c in r.checks if not c.ok]
    assert len(r.checks) >= 8
    for c in r.checks:
        wrong = c.reference * 1.01 if c.reference != 0 else 0.01 * c.scale
        assert wrong != c.reference
        assert not c.with_value(wrong).ok, c.name
        assert c.with_value(c.reference).ok


def test_lmi_norm_at_lambda_minus_1e6_is_accurate():
    """Regression: the BRL norm was 13.7x the exact one and the check still passed."""
    r = crosscheck(-1e6, 1.0, 2)
    assert r.hinf_lmi == pytest.approx(r.hinf_exact, rel=LMI_RTOL)
    check = next(c for c in r.checks if c.name.startswith("BRL LMI"))
    assert not check.with_value(13.7 * r.hinf_exact).ok


@pytest.mark.slow
@pytest.mark.parametrize(
    "lam, gamma",
    [
        (-1e-6, 0.5),
        (-1.2, 0.7071067811865497),
        (-1.2, gamma_min(-1.2) * (1 - 1e-14)),
        (-0.002, 1 / 0.0021),
        (-1.2, INV_SQRT2 * (1 + 1e-13)),
        (-1.2, INV_SQRT2 * (1 - 1e-13)),
    ],
)
def test_former_failures_give_consistent_reports(lam, gamma):
    r = crosscheck(lam, gamma, 2)
    assert r.ok, [c for c in r.checks if not c.ok]
    d = r.to_dict()
    assert d["formulations"]["lmi_minimal"].startswith("normalised")
    if r.alpha_care is not None:
        assert d["formulations"]["riccati"].split(":")[0] == r.riccati_regime


def test_double_root_formulation_recorded():
    r = crosscheck(-1.2, gamma_min(-1.2) * (1 - 1e-14), 2)
    assert r.riccati_regime == "double-root"
    assert r.formulations["lmi_stabilizing"] == "double-root linear"
    assert "closed-form" in r.formulations["riccati"]
