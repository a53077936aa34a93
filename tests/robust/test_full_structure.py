"""A full 2x4 position gain certifies no less force than the scalar structure (alpha, k1).

The synthesis LMI's uncertainty model is invariant under every rotation and reflection of the
plane (``||D|| <= sigma``, ``||Delta|| <= delta``, ``|d| <= 1``), and the LMI, the force objective
``lambda_max(K Q K^T)`` and the velocity cap are convex. Averaging a feasible ``(Q, Y)`` of the
full structure over that group gives a feasible one that commutes with it, ``Q = q kron I2``,
``Y = y kron I2``, with no larger objective: the scalar structure is optimal. This test solves
the full 4-state SDP (written here, independently of the package) and checks that its optimum
equals the scalar synthesis SDP's to solver accuracy.
"""

from __future__ import annotations

import cvxpy as cp
import numpy as np
import pytest

from auv_hinf.numerics.lmi import LYAP_STRICT_RTOL, solve
from auv_hinf.robust.synthesis import synthesise_position

#: Relative agreement of the two optima: both SDPs are solved to about 1e-8.
OPTIMUM_RTOL = 1e-4


def _full_optimum(lam: float, gain: float, sigma: float, delta: float, rate: float, vcap: float) -> float:
    i2, z2 = np.eye(2), np.zeros((2, 2))
    a = np.block([[z2, i2], [z2, lam * i2]])
    b = np.vstack([z2, i2])
    e2 = np.hstack([z2, i2])
    q = cp.Variable((4, 4), symmetric=True)
    y = cp.Variable((2, 4))
    s1, s2, u = cp.Variable(nonneg=True), cp.Variable(nonneg=True), cp.Variable(nonneg=True)
    top = a @ q + q @ a.T - gain * (b @ y + y.T @ b.T) + rate * q + (s1 + s2 + 1.0 / rate) * (b @ b.T)
    m = cp.bmat([[top, sigma * q @ e2.T, delta * y.T], [sigma * e2 @ q, -s1 * i2, z2], [delta * y, z2, -s2 * i2]])
    bound = cp.bmat([[u * i2, y], [y.T, q]])
    cons = [
        0.5 * (m + m.T) << -LYAP_STRICT_RTOL * cp.trace(q) / 2.0 * np.eye(8),
        q >> 0,
        0.5 * (bound + bound.T) >> 0,
        e2 @ q @ e2.T << vcap * i2,
    ]
    prob = cp.Problem(cp.Minimize(u), cons)
    solve(prob, "full-structure synthesis (test)")  # Clarabel with the package's retries; raises unless optimal
    return float(u.value)


@pytest.mark.parametrize(
    ("lam", "gain", "sigma", "delta", "rate", "vcap"),
    [(-1.0, 1.0, 0.8, 0.05, 0.5, 0.05), (-3.0, 1.0, 3.0, 0.1, 1.0, 0.02), (-0.3, 0.95, 0.2, 0.0, 0.1, 1.0)],
)
def test_the_full_structure_needs_as_much_force_as_the_scalar_one(lam, gain, sigma, delta, rate, vcap) -> None:
    scalar = synthesise_position(lam, gain, sigma, delta, rate, vcap)
    assert scalar is not None
    full = _full_optimum(lam, gain, sigma, delta, rate, vcap)
    assert full == pytest.approx(scalar.feedback**2, rel=OPTIMUM_RTOL)
