"""python-control loop models, hinf_norm and hinf_norm_peak against closed forms and sweeps;
python-control's hinfsyn (slycot) as an outside reference for Theorem 1."""

from __future__ import annotations

import math

import control as ct
import numpy as np
import pytest

from auv_hinf.design.blocks import NORM_RTOL, hinf_norm, hinf_norm_peak, position_block, velocity_block
from auv_hinf.design.theorem1 import alpha_stabilizing, gamma_min
from auv_hinf.exceptions import DesignError


def _sigma(sys: ct.StateSpace, w: np.ndarray) -> np.ndarray:
    a, b, c, d = (np.asarray(m, dtype=float) for m in (sys.A, sys.B, sys.C, sys.D))
    mats = 1j * np.asarray(w)[:, None, None] * np.eye(a.shape[0]) - a  # batched resolvents
    g = c @ np.linalg.solve(mats, np.broadcast_to(b, (len(w), *b.shape))) + d
    return np.linalg.norm(g, 2, axis=(1, 2))


@pytest.mark.parametrize("a", [1e-3, 0.7, 1e4])
def test_first_order_peak_at_zero(a):
    p = hinf_norm_peak(ct.ss([[-a]], [[1.0]], [[1.0]], [[0.0]]))
    assert p.omega_peak == 0.0
    assert p.norm == pytest.approx(1 / a, rel=1e-12)
    assert p.norm <= p.upper <= p.norm * (1 + 1e-9)


@pytest.mark.parametrize("b, k1", [(1.53, 0.2), (0.1, 4.0), (3.0, 0.5), (1e-3, 1e4)])
def test_position_loop_peak(b, k1):
    """s/(s^2 + b s + k1) peaks at sqrt(k1) with value 1/b (real or complex poles)."""
    lam = -1.0
    alpha = b + lam
    p = hinf_norm_peak(position_block(lam, alpha, k1))
    assert p.norm == pytest.approx(1 / b, rel=1e-9)
    # the peak is quadratic in w, so its location is known to ~sqrt(rtol)
    assert p.omega_peak == pytest.approx(math.sqrt(k1), rel=1e-4)
    assert hinf_norm(position_block(lam, alpha, k1)) == pytest.approx(1 / b, rel=NORM_RTOL)


@pytest.mark.slow
def test_peak_against_brute_force_sweep(rng):
    for _ in range(10):
        n, m, p = 5, 2, 3
        a = rng.normal(size=(n, n))
        a -= (np.abs(np.linalg.eigvals(a)).max() + 0.2) * np.eye(n)
        sys = ct.ss(a, rng.normal(size=(n, m)), rng.normal(size=(p, n)), rng.normal(size=(p, m)))
        peak = hinf_norm_peak(sys)
        w = np.concatenate([[0.0], np.logspace(-4, 4, 20001)])
        brute = _sigma(sys, w).max()
        assert peak.norm >= brute * (1 - 1e-12)  # never below a point evaluation
        assert peak.norm == pytest.approx(brute, rel=1e-4)
        if math.isfinite(peak.omega_peak):
            assert _sigma(sys, np.array([peak.omega_peak]))[0] == pytest.approx(peak.norm, rel=1e-12)
        else:
            assert peak.norm == pytest.approx(np.linalg.norm(np.asarray(sys.D), 2), rel=1e-12)
        assert peak.norm == pytest.approx(hinf_norm(sys), rel=NORM_RTOL)


def test_feedthrough_dominated_peak_at_infinity():
    sys = ct.ss([[-1.0]], [[1.0]], [[-1.0]], [[2.0]])  # 2 - 1/(s+1): |G| rises to 2
    p = hinf_norm_peak(sys)
    assert p.norm == pytest.approx(2.0, rel=1e-12) and math.isinf(p.omega_peak)


def test_peak_rejects_unstable():
    with pytest.raises(DesignError, match="stable"):
        hinf_norm_peak(ct.ss([[0.5]], [[1.0]], [[1.0]], [[0.0]]))


def test_velocity_block_norm():
    assert hinf_norm_peak(velocity_block(-1.2, 0.33)).norm == pytest.approx(1 / 1.53, rel=1e-12)


# ----------------------------------------------------------------------------------------
# Outside reference: python-control's hinfsyn (SLICOT sb10ad via slycot).
#
# Plant (one channel of Theorem 1): x' = lam x + w1 + u, performance z = [x; u/sqrt2], so
# D12 = [0; 1/sqrt2], D12^T D12 = 1/2. The state-feedback H-infinity ARE
#     A^T X + X A + X (B1 B1^T / g^2 - B2 (D12^T D12)^-1 B2^T) X + C1^T C1 = 0
# is 2 lam X + (1/g^2 - 2) X^2 + 1 = 0, i.e. eq. (37) with X = alpha; a solution exists iff
# g >= gamma_min = 1/sqrt(lam^2 + 2), and the central controller is
#     u = -(D12^T D12)^-1 B2^T X x = -2 alpha x,
# twice the paper's gain K = -L = -alpha. sb10ad needs D21 of full row rank, so the state is
# measured through a vanishing noise: y = x + delta w2 (B1 = [1, 0], D21 = [0, delta]). Its
# filter ARE has the root Y ~ delta, so for small delta the optimal gamma is the
# state-feedback one exactly and the controller tends to the static gain -2 alpha (error
# O(delta)). python-control's sign convention is u = K y (positive feedback).
# ----------------------------------------------------------------------------------------

DELTA = 1e-8


def _partitioned_plant(lam: float, delta: float = DELTA) -> ct.StateSpace:
    a = [[lam]]
    b = [[1.0, 0.0, 1.0]]  # inputs [w1, w2, u]
    c = [[1.0], [0.0], [1.0]]  # outputs [z1 = x, z2 = u/sqrt2, y]
    d = [[0.0, 0.0, 0.0], [0.0, 0.0, 2**-0.5], [0.0, delta, 0.0]]
    return ct.ss(a, b, c, d)


@pytest.mark.parametrize("lam", [-0.3, -1.2, -3.0])
def test_hinfsyn_optimal_gamma_is_gamma_min(lam):
    pytest.importorskip("slycot")
    _, closed, gam, _ = ct.hinfsyn(_partitioned_plant(lam), 1, 1)
    assert gam == pytest.approx(gamma_min(lam), rel=1e-6)
    assert np.all(closed.poles().real < 0)


@pytest.mark.parametrize("lam, gamma", [(-1.2, 2.86), (-1.2, 0.8), (-0.3, 2.0), (-3.0, 0.6)])
def test_hinfsyn_central_gain_is_twice_alpha(lam, gamma):
    slycot = pytest.importorskip("slycot")
    plant = _partitioned_plant(lam)
    a, b, c, d = (np.asarray(m, dtype=float) for m in (plant.A, plant.B, plant.C, plant.D))
    out = slycot.sb10ad(1, 3, 3, 1, 1, gamma, a, b, c, d, job=4)  # job 4: suboptimal at gamma
    ctrl = ct.ss(*out[1:5])
    gain = -float(np.real(ctrl(1j * 1e-3)))  # u = K y, so the gain is -K at low frequency
    assert gain == pytest.approx(2 * alpha_stabilizing(lam, gamma).alpha, rel=1e-6)
