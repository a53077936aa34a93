"""Certified sigma bounds: heading invariance, the vertex argument, Jacobi bounds."""

from __future__ import annotations

import numpy as np
import pytest

from auv_hinf.envelope import Envelope, abs_range, envelope_lambda
from auv_hinf.formation import JacobiTransform
from auv_hinf.sigma import jacobi_sigma_bounds, sigma_at_witness, sigma_grid, sigma_max_2x2, vehicle_sigma
from auv_hinf.vehicle import VehicleParams, body_block, paper2011


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
        for uu in (0.0, 2.0) for vv in (0.0, 0.5) for rr in (-0.3, 0.3)
    )
    assert b.lower == pytest.approx(expected, rel=1e-15)
    assert expected <= b.upper <= expected * (1 + 2e-12)  # only the round-off allowance
    assert b.witness["u"][0] in (0.0, 2.0)


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
    [(dict(u=(2, 1), v=(0, 1), r=(0, 1)), "envelope u is empty"),
     (dict(u=(0, float("nan")), v=(0, 1), r=(0, 1)), "envelope u must be finite"),
     (dict(u=(0, 1), v=3, r=(0, 1)), "envelope v must be a pair")],
)
def test_bad_envelope(kwargs, pattern):
    with pytest.raises(ValueError, match=pattern):
        Envelope(**kwargs)


def test_zero_damping_vehicle_lambda_zero():
    p = VehicleParams(10, 20, 5, 0, 0, 0, 0, 0, 0)
    env = Envelope(u=(0, 1), v=(0, 1), r=(0, 1))
    assert envelope_lambda(p, env) == 0.0


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
