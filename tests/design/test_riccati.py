"""Riccati route: regimes (incl. the double root at gamma_min), error wrapping, consistency."""

from __future__ import annotations

import math

import numpy as np
import pytest

import auv_hinf.design.riccati as riccati
from auv_hinf.design.riccati import ARE_RTOL, riccati_alpha, root_condition
from auv_hinf.design.theorem1 import (
    DOUBLE_ROOT_RTOL,
    alpha_stabilizing,
    discriminant,
    discriminant_scale,
    gamma_min,
    riccati_c,
    riccati_regime,
    theorem1_conditions,
)
from auv_hinf.exceptions import DesignError, SolverError

INV_SQRT2 = 2**-0.5


def _residual_root(lam: float, gamma: float, alpha: float) -> float:
    """|c a^2 + 2 lam a + 1|, the scalar (37), relative to its largest term."""
    c = riccati_c(gamma)
    terms = (abs(c) * alpha**2, abs(2 * lam * alpha), 1.0)
    return abs(c * alpha**2 + 2 * lam * alpha + 1) / max(terms)


@pytest.mark.parametrize("factor", [1 - 1e-14, 1.0, 1 + 1e-14])
@pytest.mark.parametrize("lam", [-1.2, -1e-3, -1e3])
@pytest.mark.parametrize("solver", ["control", "scipy"])
def test_gamma_min_edge_is_solved_not_misjudged(lam, factor, solver):
    """gamma = gamma_min (1 +- 1e-14) passes the input check and is solved (merged roots)."""
    g = gamma_min(lam) * factor
    assert theorem1_conditions(lam, g).gamma_ok
    r = riccati_alpha(lam, g, 2, solver=solver)
    assert r.regime == "double-root" and r.solver == "closed-form"
    # merged roots: 1/|lam| up to sqrt of the admitted discriminant
    slack = math.sqrt(DOUBLE_ROOT_RTOL * discriminant_scale(lam, g)) / abs(lam)
    assert r.alpha == pytest.approx(1 / abs(lam), rel=2 * slack + 1e-15)
    # the cross-check's tolerance: the merged root is sqrt(eps)-sensitive
    assert r.alpha == pytest.approx(alpha_stabilizing(lam, g).alpha, rel=ARE_RTOL * root_condition(lam, g))
    assert _residual_root(lam, g, r.alpha) < 4 * DOUBLE_ROOT_RTOL * discriminant_scale(lam, g) / lam**2 + 1e-14


def test_input_check_and_solver_use_one_tolerance():
    """Every gamma the input check accepts is in a regime some solver branch handles."""
    lam = -1.2
    gmin = gamma_min(lam)
    for e in np.logspace(-16, -9, 15):
        for g in (gmin * (1 - e), gmin * (1 + e)):
            ok = theorem1_conditions(lam, g).gamma_ok
            disc, scale = discriminant(lam, g), discriminant_scale(lam, g)
            assert ok == (disc >= -DOUBLE_ROOT_RTOL * scale)
            if ok:
                riccati_alpha(lam, g, 2, solver="scipy")  # never raises
            else:
                with pytest.raises(DesignError, match="no real solution"):
                    riccati_alpha(lam, g, 2, solver="scipy")


@pytest.mark.parametrize("gamma", [0.7071067811865497, INV_SQRT2 * (1 - 1e-13), INV_SQRT2 * (1 + 1e-10), INV_SQRT2])
@pytest.mark.parametrize("solver", ["control", "scipy"])
def test_near_inv_sqrt2_matches_closed_form(gamma, solver):
    lam = -1.2
    r = riccati_alpha(lam, gamma, 3, solver=solver)
    assert r.regime in {"lyapunov", "R>0", "R<0"}
    assert r.regime == riccati_regime(lam, gamma)
    assert r.alpha == pytest.approx(alpha_stabilizing(lam, gamma).alpha, rel=ARE_RTOL)
    assert r.residual < 1e-12


def test_lyapunov_branch_is_accurate_at_its_edge():
    """At the edge of the Lyapunov branch the Lyapunov root is within 1e-12 of the true root."""
    lam = -1.2
    c = 0.99e-12 * lam**2
    g = 1 / math.sqrt(2 + c)
    assert riccati_regime(lam, g) == "lyapunov"
    assert -1 / (2 * lam) == pytest.approx(alpha_stabilizing(lam, g).alpha, rel=1e-12)


@pytest.mark.parametrize("lam", [-1e-6, -1e-3, -1.0, -1e3, -1e6])
@pytest.mark.parametrize("gamma_factor", [0.5, 1.0001, 3.0])
def test_scales(lam, gamma_factor):
    g = max(gamma_min(lam) * 1.0001, gamma_factor / (abs(lam) + 1))
    for solver in ("control", "scipy"):
        r = riccati_alpha(lam, g, 2, solver=solver)
        assert r.alpha == pytest.approx(alpha_stabilizing(lam, g).alpha, rel=ARE_RTOL)
        assert _residual_root(lam, g, r.alpha) < 1e-10  # QZ round-off on a pencil with entries up to 1e11


def test_backend_failure_is_wrapped(monkeypatch):
    def broken(*args, **kwargs):
        raise np.linalg.LinAlgError("Failed to find a finite solution.")

    monkeypatch.setattr(riccati.sla, "solve_continuous_are", broken)
    monkeypatch.setattr(riccati.ct, "care", broken)
    for solver in ("control", "scipy"):
        with pytest.raises(SolverError, match="finite solution") as info:
            riccati_alpha(-1.2, 2.86, 2, solver=solver)
        assert isinstance(info.value.__cause__, np.linalg.LinAlgError)


def test_unknown_solver():
    with pytest.raises(DesignError, match="Riccati solver"):
        riccati_alpha(-1.2, 2.86, 2, solver="matlab")  # type: ignore[arg-type]
