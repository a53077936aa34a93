"""Lyapunov LMIs of the error loops against closed forms: spectral abscissa and H-infinity norm."""

from __future__ import annotations

import numpy as np
import pytest

from auv_hinf.closed_loop.lyapunov import (
    heading_lmi_matrices,
    lmi_heading_lyapunov,
    lmi_position_lyapunov,
    position_lmi_matrix,
)
from auv_hinf.numerics.lmi import strict_nsd_gap

#: Position loop of the paper triangle's design: lam (1/s), alpha (1/s), k1 (1/s^2).
LAM, ALPHA, K1 = -2.1, 0.26, 0.5


def test_strict_nsd_gap_is_the_largest_eigenvalue_of_the_symmetric_part(rng):
    m = rng.normal(size=(4, 4))
    top, margin = strict_nsd_gap(m)
    assert top == pytest.approx(np.linalg.eigvalsh(m + m.T).max() / 2, rel=1e-12)
    assert 0 < margin < 1e-10 * np.abs(m).max()


@pytest.mark.parametrize("frac, feasible", [(0.95, True), (1.05, False)])
def test_position_lmi_is_feasible_exactly_below_the_hinf_bound(frac, feasible):
    """At beta = 0 the bounded-real lemma holds iff sigma < 1/||s/(s^2 + (alpha - lam) s + k1)||_inf.

    That transfer function peaks at w = sqrt(k1) with the value 1/(alpha - lam), so the LMI is
    feasible exactly for sigma < alpha - lam, the small-gain margin of Theorem 1.
    """
    w = np.linspace(1e-3, 10.0, 200_001)
    peak = np.abs(1j * w / (K1 - w**2 + 1j * (ALPHA - LAM) * w)).max()
    assert peak == pytest.approx(1.0 / (ALPHA - LAM), rel=1e-9)
    sigma = frac * (ALPHA - LAM)
    res = lmi_position_lyapunov(LAM, ALPHA, K1, sigma, 0.0)
    assert (res is not None) is feasible
    if res is not None:  # the returned certificate checks out independently
        mat, _ = position_lmi_matrix(res.matrix, res.multiplier, LAM, ALPHA, K1, sigma, 0.0)
        assert np.linalg.eigvalsh(mat).max() < 0 and np.linalg.eigvalsh(res.matrix).min() > 0


@pytest.mark.parametrize("frac, feasible", [(0.9, True), (1.1, False)])
def test_position_lmi_without_disturbance_decays_at_most_at_the_spectral_abscissa(frac, feasible):
    """sigma = 0: a P2 > 0 with decay beta exists iff beta < -max Re eig([[0, 1], [-k1, lam - alpha]])."""
    rate = -np.linalg.eigvals(np.array([[0.0, 1.0], [-K1, LAM - ALPHA]])).real.max()
    assert (lmi_position_lyapunov(LAM, ALPHA, K1, 0.0, frac * rate) is not None) is feasible


@pytest.mark.parametrize("frac, feasible", [(0.9, True), (1.1, False)])
def test_heading_lmi_at_one_c_decays_at_most_at_the_spectral_abscissa(frac, feasible):
    """s^2 + 2.5 s + 1.5 has roots -1 and -1.5: decay rates below 1 only."""
    assert np.sort(np.roots([1.0, 2.5, 1.5])) == pytest.approx([-1.5, -1.0])
    assert (lmi_heading_lyapunov(1.5, (2.5, 2.5), frac * 1.0) is not None) is feasible


def test_heading_lyapunov_matrix_holds_for_every_c_in_the_range():
    """Affine in c: checked at the vertices, the returned Q works at every c in between (sampled)."""
    k1psi, c_range, beta = 1.5, (1.0, 6.0), 0.1
    res = lmi_heading_lyapunov(k1psi, c_range, beta)
    assert res is not None and res.beta == beta and np.linalg.eigvalsh(res.matrix).min() > 0
    for c in np.linspace(*c_range, 101):
        [(mat, _)] = heading_lmi_matrices(res.matrix, k1psi, (c,), beta)
        assert np.linalg.eigvalsh(mat).max() < 0, c
    # outside the range the loop is slower than beta at some c: c -> 0 is undamped
    assert lmi_heading_lyapunov(k1psi, (0.0, 6.0), beta) is None
