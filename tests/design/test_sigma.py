"""Certified sigma bounds: heading invariance, the vertex argument, Jacobi bounds."""

from __future__ import annotations

import numpy as np
import pytest

from auv_hinf.design.jacobi_sigma import (
    DENSE_SIGMA_MAX_N,
    jacobi_apply,
    jacobi_sigma,
    jacobi_sigma_bounds,
    jacobi_sigma_lower,
    sigma_at_witness,
)
from auv_hinf.design.sigma import sigma_grid, sigma_max_2x2, vehicle_sigma
from auv_hinf.models.envelope import Envelope, abs_range, envelope_lambda
from auv_hinf.models.jacobi import JacobiTransform
from auv_hinf.models.vehicle import VehicleParams, body_block, inertial_block, paper2011


def test_closed_form_2x2_norm(rng):
    m = rng.normal(size=(1000, 2, 2))
    assert np.allclose(sigma_max_2x2(m), np.linalg.norm(m, 2, axis=(-2, -1)), rtol=1e-12)


def random_envelope(rng):
    u = np.sort(rng.uniform(-2, 4, 2))
    v = np.sort(rng.uniform(-1.5, 1.5, 2))
    r = np.sort(rng.uniform(-1, 1, 2))
    return Envelope(u=tuple(u), v=tuple(v), r=tuple(r))


@pytest.mark.parametrize("seed", range(6))
def test_upper_bound_is_sound_against_dense_sampling(vehicle, seed):
    rng = np.random.default_rng(seed)
    env = random_envelope(rng)
    lam = envelope_lambda(vehicle, env)
    b = vehicle_sigma(vehicle, env, lam, 3)
    u = rng.uniform(*env.u, 200_000)
    v = rng.uniform(*env.v, 200_000)
    r = rng.uniform(*env.r, 200_000)
    sampled = sigma_max_2x2(body_block(vehicle, u, v, r) - lam * np.eye(2)).max()
    assert b.upper >= sampled
    assert b.upper >= b.lower
    assert sigma_at_witness(vehicle, b) == pytest.approx(b.lower, rel=1e-12)


def test_straddling_zero():
    """u in [-1, 2] contains |u| = 0: the bound must include the zero-speed vertex."""
    p = paper2011()
    env = Envelope(u=(-1.0, 2.0), v=(-0.2, 0.5), r=(-0.3, 0.3))
    assert abs_range(-1.0, 2.0) == (0.0, 2.0)
    lam = envelope_lambda(p, env)
    assert lam == pytest.approx(-(70 + 200) / 200)
    b = vehicle_sigma(p, env, lam)
    expected = max(
        sigma_max_2x2(body_block(p, uu, vv, rr) - lam * np.eye(2))
        for uu in (0.0, 2.0)
        for vv in (0.0, 0.5)
        for rr in (-0.3, 0.3)
    )
    assert b.lower == pytest.approx(expected, rel=1e-15)
    assert expected <= b.upper <= expected * (1 + 2e-12)  # only the round-off allowance
    assert b.witness.u[0] in (0.0, 2.0)


@pytest.mark.parametrize("kind", ["paper", "orthonormal"])
def test_jacobi_bounds(kind):
    p = paper2011()
    env = Envelope(u=(0, 2), v=(-1, 1), r=(-0.5, 0.5))
    t = JacobiTransform(3, kind)
    veh = vehicle_sigma(p, env, -1.35, 3)
    jac = jacobi_sigma_bounds(p, env, -1.35, t, samples=3000)
    assert jac.lower <= jac.upper <= t.cond * veh.upper * (1 + 1e-9)
    assert jac.lower >= veh.lower * (1 - 1e-9) or kind == "orthonormal"
    assert sigma_at_witness(p, jac, t) == pytest.approx(jac.lower, rel=1e-10)


def test_paper_notes_item6_jacobi_exceeds_vehicle():
    """With the unnormalised Phi a search finds sigma ~1.5 where the vehicle value is 1.09."""
    p = paper2011()
    env = Envelope(u=(0, 2), v=(-1, 1), r=(-0.5, 0.5))
    veh = vehicle_sigma(p, env, -1.35)
    jac = jacobi_sigma_bounds(p, env, -1.35, JacobiTransform(3), samples=20000)
    assert veh.upper == pytest.approx(1.09, abs=0.01)
    assert jac.lower > 1.4


def test_grid_matches_bound():
    p = paper2011()
    env = Envelope(u=(0, 3.5), v=(-1, 1), r=(-0.5, 0.5))
    lam = envelope_lambda(p, env)
    g = sigma_grid(p, lam, np.linspace(0, 3.5, 50), np.linspace(-0.5, 0.5, 41), other=1.0)
    assert g.shape == (41, 50)
    assert g.max() <= vehicle_sigma(p, env, lam).upper


@pytest.mark.parametrize(
    "kwargs, pattern",
    [
        (dict(u=(2, 1), v=(0, 1), r=(0, 1)), "envelope u is empty"),
        (dict(u=(0, float("nan")), v=(0, 1), r=(0, 1)), "envelope u must be finite"),
        (dict(u=(0, 1), v=3, r=(0, 1)), "envelope v must be a pair"),
    ],
)
def test_bad_envelope(kwargs, pattern):
    with pytest.raises(ValueError, match=pattern):
        Envelope(**kwargs)


def test_zero_damping_vehicle_lambda_zero():
    p = VehicleParams(10, 20, 5, 0, 0, 0, 0, 0, 0)
    env = Envelope(u=(0, 1), v=(0, 1), r=(0, 1))
    assert envelope_lambda(p, env) == 0.0


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["paper", "orthonormal"])
def test_jacobi_branch_and_bound_is_sound(kind):
    """The refined Jacobi bound is certified: >= a dense random search, <= the cond bound."""
    p = paper2011()
    env = Envelope(u=(0, 2), v=(-1, 1), r=(-0.5, 0.5))
    t = JacobiTransform(3, kind)
    veh = vehicle_sigma(p, env, -1.35)
    coarse = jacobi_sigma_bounds(p, env, -1.35, t, samples=20000, seed=3)
    fine = jacobi_sigma_bounds(p, env, -1.35, t, samples=200, refine_jacobi=True, budget=800_000)
    assert "branch-and-bound" in fine.method
    assert fine.upper >= coarse.lower and fine.upper >= fine.lower
    assert fine.upper < t.cond * veh.upper
    assert sigma_at_witness(p, fine, t) == pytest.approx(fine.lower, rel=1e-10)


# --- matrix-free Jacobi sigma against the dense reference ---------------------------------

#: The witnessed value is ||M x|| at a unit x: never above ||M|| beyond round-off of the
#: O(N) maps and of the dense SVD (a few ulps times cond(Phi)^2 <= 100 here).
LOWER_ROUNDOFF = 1e-12
#: 24 Krylov steps reach the top singular value to about machine precision at these sizes.
KRYLOV_MATCH_RTOL = 1e-8


def random_vertices(rng, env, m, n):
    a, b = abs_range(*env.u), abs_range(*env.v)
    return (
        rng.uniform(-np.pi, np.pi, (m, n)),
        np.asarray(a)[rng.integers(0, 2, (m, n))],
        np.asarray(b)[rng.integers(0, 2, (m, n))],
        np.asarray(env.r)[rng.integers(0, 2, (m, n))],
    )


@pytest.mark.parametrize("kind", ["paper", "orthonormal"])
@pytest.mark.parametrize("n", [2, 3, 7, 20, 50])
def test_matrix_free_operator_matches_dense(kind, n, rng):
    p = paper2011()
    t = JacobiTransform(n, kind)
    psi, u, v, r = (rng.uniform(-1, 1, n) for _ in range(4))
    g = inertial_block(p, psi, u, v, r) + 1.35 * np.eye(2)
    dense = np.kron(t.phi, np.eye(2)) @ block_diag(g) @ np.kron(np.linalg.inv(t.phi), np.eye(2))
    x = rng.normal(size=(n, 2))
    assert_close(jacobi_apply(g, kind, x).ravel(), dense @ x.ravel())
    assert_close(jacobi_apply(g, kind, x, transpose=True).ravel(), dense.T @ x.ravel())


def block_diag(g):
    n = len(g)
    out = np.zeros((2 * n, 2 * n))
    for i in range(n):
        out[2 * i : 2 * i + 2, 2 * i : 2 * i + 2] = g[i]
    return out


def assert_close(a, b):
    assert np.allclose(a, b, rtol=0, atol=1e-11 * max(1.0, np.abs(b).max()))


@pytest.mark.parametrize("kind", ["paper", "orthonormal"])
@pytest.mark.parametrize("n", [2, 3, 7, 20, 50])
def test_matrix_free_lower_bound_matches_dense_svd(kind, n):
    p = paper2011()
    env = Envelope(u=(0, 2), v=(-1, 1), r=(-0.5, 0.5))
    rng = np.random.default_rng(n)
    t = JacobiTransform(n, kind)
    psi, u, v, r = random_vertices(rng, env, 40, n)
    dense = jacobi_sigma(p, -1.35, t, psi, u, v, r)
    lower, x = jacobi_sigma_lower(p, -1.35, t, psi, u, v, r, rng=rng)
    assert np.all(lower <= dense * (1 + LOWER_ROUNDOFF))  # a valid lower bound
    assert np.allclose(lower, dense, rtol=KRYLOV_MATCH_RTOL, atol=0)  # and a tight one
    assert np.allclose(np.linalg.norm(x.reshape(40, -1), axis=1), 1.0, rtol=1e-14)


def test_matrix_free_bound_is_valid_even_with_one_step():
    """One step is a plain power-iteration Rayleigh quotient: smaller, but still below the norm."""
    p = paper2011()
    env = Envelope(u=(0, 2), v=(-1, 1), r=(-0.5, 0.5))
    rng = np.random.default_rng(4)
    t = JacobiTransform(30)
    psi, u, v, r = random_vertices(rng, env, 20, 30)
    dense = jacobi_sigma(p, -1.35, t, psi, u, v, r)
    one, _ = jacobi_sigma_lower(p, -1.35, t, psi, u, v, r, dim=1, rng=rng)
    full, _ = jacobi_sigma_lower(p, -1.35, t, psi, u, v, r, rng=rng)
    assert np.all(one <= dense * (1 + LOWER_ROUNDOFF)) and np.all(one < full)


@pytest.mark.parametrize("kind", ["paper", "orthonormal"])
def test_jacobi_bounds_matrix_free_path(kind):
    """Above DENSE_SIGMA_MAX_N: upper = cond * sigma_vehicle, lower witnessed and re-evaluable."""
    p = paper2011()
    env = Envelope(u=(0, 2), v=(-1, 1), r=(-0.5, 0.5))
    n = DENSE_SIGMA_MAX_N + 18
    t = JacobiTransform(n, kind)
    veh = vehicle_sigma(p, env, -1.35, n)
    jac = jacobi_sigma_bounds(p, env, -1.35, t, samples=60)
    cond = np.sqrt(2 * n if kind == "paper" else n)
    assert jac.upper == pytest.approx(cond * veh.upper, rel=1e-9)
    assert jac.lower <= jac.upper
    assert "matrix-free" in jac.method and len(jac.witness.vector or ()) == 2 * n
    assert sigma_at_witness(p, jac, t) == pytest.approx(jac.lower, rel=1e-12)
    w = jac.witness
    exact = jacobi_sigma(p, -1.35, t, *(np.asarray(getattr(w, k)) for k in ("psi", "u", "v", "r")))
    assert jac.lower <= float(exact) * (1 + LOWER_ROUNDOFF)
    assert jac.lower == pytest.approx(float(exact), rel=KRYLOV_MATCH_RTOL)
