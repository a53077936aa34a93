"""Cross-checks: care (control, scipy) vs the closed form vs cvxpy/Clarabel LMIs vs python-control."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from auv_hinf.crosscheck import crosscheck
from auv_hinf.lmi import LMI_RTOL, lmi_hinf_norm
from auv_hinf.loops import NORM_RTOL, hinf_norm, position_block, velocity_block
from auv_hinf.riccati import ARE_RTOL, riccati_alpha
from auv_hinf.design import alpha_stabilizing, gamma_min

INV_SQRT2 = 2 ** -0.5


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


@pytest.mark.parametrize("n", [2, 5, 8])
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
def test_property_crosscheck_agrees(lam, gamma):
    r = crosscheck(lam, gamma, 2)
    assert r.ok, [c for c in r.checks if not c.ok]
    if r.alpha_minimal > 0:
        assert r.alpha_lmi_minimal == pytest.approx(r.alpha_minimal, rel=LMI_RTOL)
