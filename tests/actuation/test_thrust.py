"""The feedback bound on an invariant ellipsoid: sound on every sampled point, attained on the boundary."""

from __future__ import annotations

import numpy as np

from auv_hinf.actuation.thrust import ellipsoid_feedback


def test_the_ellipsoid_feedback_bound_holds_and_is_attained() -> None:
    rng = np.random.default_rng(4)
    for n in (2, 3):
        for _ in range(20):
            a = rng.normal(size=(n, n))
            p = a @ a.T + 0.1 * np.eye(n)
            c = rng.uniform(0.1, 50.0, size=n)
            level = rng.uniform(0.01, 4.0)
            bound = ellipsoid_feedback(p, c, level)
            # planar states x (n, 2) with sum over axes of x_a^T P x_a = level: on the boundary
            x = rng.normal(size=(4000, n, 2))
            v = np.einsum("ska,kl,sla->s", x, p, x)
            x *= np.sqrt(level / v)[:, None, None]
            f = np.linalg.norm(np.einsum("k,ska->sa", c, x), axis=1)
            assert f.max() <= bound * (1 + 1e-12)
            # the maximiser x_a = P^-1 c t (one axis) reaches it
            d = np.linalg.solve(p, c)
            t = np.sqrt(level / (d @ p @ d))
            assert abs(c @ d * t - bound) <= 1e-9 * bound
