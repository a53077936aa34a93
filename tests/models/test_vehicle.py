"""Tests of the 3-DOF vehicle model (eqs. 1-10)."""

from __future__ import annotations

import math
from dataclasses import replace

import control as ct
import numpy as np
import pytest
import sympy as sp
from hypothesis import given
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from auv_hinf.design.sigma import vehicle_sigma
from auv_hinf.models.envelope import Envelope, envelope_lambda
from auv_hinf.models.vehicle import (
    VehicleParams,
    body_block,
    coriolis_damping_matrix,
    inertial_block,
    input_matrix,
    paper2011,
    preset,
    remus100,
    rhs,
    rotation,
    vehicle_nlsys,
)

# Round-off tolerance for identities evaluated in double precision on O(1) entries.
EXACT_RTOL = 1e-12
# ct.linearize uses forward finite differences (step 1e-6): the truncation error is
# step * |second derivative| / 2, i.e. ~1e-6 relative for REMUS's 1310 kg/m sway drag.
FD_ATOL = 1e-6
FD_RTOL = 1e-5


def printed_eq20_entries(m11, m22, d11, d22, r, c, s):
    """Eq. (20) exactly as printed in the paper, from c = cos(psi) and s = sin(psi)."""
    g11 = -d11 / m11 * c**2 + (m11 / m22 - m22 / m11) * r * s * c - d22 / m22 * s**2
    g12 = (-d11 / m11 + d22 / m22) * s * c + m11 / m22 * r * s**2 + m22 / m11 * r * c**2 - r
    g21 = (-d11 / m11 + d22 / m22) * s * c - m11 / m22 * r * c**2 - m22 / m11 * r * s**2 + r
    g22 = -d11 / m11 * s**2 + (m22 / m11 - m11 / m22) * r * s * c - d22 / m22 * c**2
    return g11, g12, g21, g22


def printed_eq20(m11, m22, d11, d22, r, psi):
    """Eq. (20) as stacked numpy 2x2 matrices."""
    g11, g12, g21, g22 = printed_eq20_entries(m11, m22, d11, d22, r, np.cos(psi), np.sin(psi))
    return np.stack([np.stack([g11, g12], -1), np.stack([g21, g22], -1)], -2)


def test_eq20_equals_eq8_numerically(vehicle, rng):
    n = 500
    psi = rng.uniform(-np.pi, np.pi, n)
    u, v, r = rng.uniform(-3, 3, n), rng.uniform(-1, 1, n), rng.uniform(-0.5, 0.5, n)
    d11, d22, _ = vehicle.damping(u, v, r)
    expected = printed_eq20(vehicle.m11, vehicle.m22, d11, d22, r, psi)
    assert_allclose(inertial_block(vehicle, psi, u, v, r), expected, rtol=EXACT_RTOL, atol=1e-12)


@pytest.mark.slow
def test_eq20_equals_eq8_symbolically():
    m11, m22, d11, d22 = sp.symbols("m11 m22 d11 d22", positive=True)
    r, psi = sp.symbols("r psi", real=True)
    rot = sp.Matrix([[sp.cos(psi), -sp.sin(psi)], [sp.sin(psi), sp.cos(psi)]])
    skew = sp.Matrix([[0, -r], [r, 0]])
    d1 = sp.Matrix([[d11, -m22 * r], [m11 * r, d22]])
    eq8 = rot * (skew - sp.diag(m11, m22).inv() * d1) * rot.T
    eq20_m = sp.Matrix(2, 2, printed_eq20_entries(m11, m22, d11, d22, r, sp.cos(psi), sp.sin(psi)))
    assert sp.simplify(eq8 - eq20_m) == sp.zeros(2, 2)


def test_body_block_closed_form(vehicle, rng):
    u, v, r = rng.uniform(-2, 2, 50), rng.uniform(-1, 1, 50), rng.uniform(-1, 1, 50)
    d11, d22, _ = vehicle.damping(u, v, r)
    m11, m22 = vehicle.m11, vehicle.m22
    expected = np.stack(
        [
            np.stack([-d11 / m11, (m22 - m11) * r / m11], -1),
            np.stack([(m22 - m11) * r / m22, -d22 / m22], -1),
        ],
        -2,
    )
    assert_allclose(body_block(vehicle, u, v, r), expected, rtol=EXACT_RTOL)


def test_shift_norm_is_heading_invariant(vehicle, rng):
    """||G_i - lam I||_2 does not depend on psi (R is orthogonal and lam I commutes with it)."""
    u, v, r = 1.3, -0.4, 0.3
    lam = -1.35
    norms = [
        np.linalg.norm(inertial_block(vehicle, psi, u, v, r) - lam * np.eye(2), 2)
        for psi in rng.uniform(-np.pi, np.pi, 20)
    ]
    assert np.ptp(norms) < 1e-12 * max(norms)


def test_input_matrix(vehicle):
    psi = 0.7
    expected = rotation(psi) @ np.diag([1 / vehicle.m11, 1 / vehicle.m22])
    assert_allclose(input_matrix(vehicle, psi), expected, rtol=EXACT_RTOL)


def test_rhs_matches_eq10(vehicle, rng):
    """p'' computed by differentiating the rhs equals G p' + H tau (eq. 10)."""
    state = np.column_stack(
        [
            rng.normal(size=(20, 2)),
            rng.uniform(-3, 3, 20),
            rng.uniform(0.2, 2, 20),
            rng.uniform(-1, 1, 20),
            rng.uniform(-0.5, 0.5, 20),
        ]
    )
    tau = rng.normal(scale=50, size=(20, 3))
    d = rhs(vehicle, state, tau)
    psi, u, v, r = state[:, 2], state[:, 3], state[:, 4], state[:, 5]
    # p'' = d/dt [R(psi) gamma] = R S(r) gamma + R gamma'
    rot = rotation(psi)
    gam = np.stack([u, v], -1)
    gam_dot = d[:, 3:5]
    s_gam = np.stack([-r * v, r * u], -1)
    p_ddot = np.einsum("nij,nj->ni", rot, s_gam + gam_dot)
    p_dot = d[:, 0:2]
    expected = np.einsum("nij,nj->ni", inertial_block(vehicle, psi, u, v, r), p_dot) + np.einsum(
        "nij,nj->ni", input_matrix(vehicle, psi), tau[:, :2]
    )
    assert_allclose(p_ddot, expected, rtol=1e-10, atol=1e-10)
    assert_allclose(np.linalg.norm(p_dot, axis=1), np.linalg.norm(gam, axis=1), rtol=EXACT_RTOL)


@pytest.mark.parametrize("trim", [(1.5, 0.3, 0.2, 0.4), (2.0, -0.2, -0.1, -1.0), (0.8, 0.5, 0.3, 2.5)])
def test_linearize_matches_analytic_jacobian(vehicle, trim):
    """ct.linearize of the nlsys equals -M1^-1 D1 minus the quadratic-damping slope."""
    u0, v0, r0, psi0 = trim
    sys = vehicle_nlsys(vehicle)
    lin = ct.linearize(sys, [0.0, 0.0, psi0, u0, v0, r0], [0.0, 0.0, 0.0])
    a_vel = lin.A[3:5, 3:5]
    slope = np.diag([vehicle.d11_quad * abs(u0) / vehicle.m11, vehicle.d22_quad * abs(v0) / vehicle.m22])
    expected = -coriolis_damping_matrix(vehicle, u0, v0, r0) - slope
    assert_allclose(a_vel, expected, rtol=FD_RTOL, atol=FD_ATOL)
    # Coupling of surge/sway into yaw and the kinematics
    assert_allclose(lin.A[5, 3], -(vehicle.m22 - vehicle.m11) * v0 / vehicle.m33, atol=FD_ATOL)
    assert_allclose(lin.A[0:2, 3:5], rotation(psi0), atol=FD_ATOL)
    assert_allclose(lin.B[3:6, :], np.diag([1 / vehicle.m11, 1 / vehicle.m22, 1 / vehicle.m33]), atol=FD_ATOL)


def test_linearize_equals_block_for_linear_damping():
    """With linear damping only, the Jacobian of gamma' is exactly -M1^-1 D1 = block - S(r)."""
    p = VehicleParams(200, 250, 80, 70, 0, 100, 0, 50, 0)
    r0 = 0.3
    lin = ct.linearize(vehicle_nlsys(p), [0, 0, 0.0, 1.0, 0.2, r0], [0, 0, 0])
    skew = np.array([[0, -r0], [r0, 0]])
    assert_allclose(lin.A[3:5, 3:5], body_block(p, 1.0, 0.2, r0) - skew, atol=FD_ATOL)


def test_zero_control_speeds_decay(vehicle):
    """Damping is dissipative: with no thrust the kinetic energy decreases."""
    state = np.array([0, 0, 0.3, 1.5, 0.4, 0.2])
    tau = np.zeros(3)
    d = rhs(vehicle, state, tau)
    m = np.array([vehicle.m11, vehicle.m22, vehicle.m33])
    energy_rate = np.sum(m * state[3:] * d[3:])
    assert energy_rate < 0


@pytest.mark.parametrize(
    "field, value, pattern",
    [
        ("m11", -200.0, "m11 must be > 0"),
        ("m33", 0.0, "m33 must be > 0"),
        ("d22_quad", -1.0, "d22_quad must be >= 0"),
        ("m22", math.nan, "m22 must be finite"),
        ("d33_lin", math.inf, "d33_lin must be finite"),
        ("d11_lin", "abc", "d11_lin must be a finite real number"),
        ("m11", "20", "m11 must be a finite real number"),  # text is never read as a number
        ("d22_quad", b"1", "d22_quad must be a finite real number"),
        ("m22", True, "m22 must be a finite real number"),
    ],
)
def test_bad_parameters_raise(field, value, pattern):
    kwargs = paper2011().to_dict()
    kwargs[field] = value
    with pytest.raises(ValueError, match=pattern):
        VehicleParams(**kwargs)


def test_unknown_preset():
    with pytest.raises(ValueError, match="unknown vehicle preset 'nope'"):
        preset("nope")


def test_damping_scale():
    p = paper2011().with_damping_scale(1.2)
    assert p.d22_quad == pytest.approx(240.0)
    assert p.m11 == 200.0
    with pytest.raises(ValueError, match="damping scale factor"):
        paper2011().with_damping_scale(-1)


@given(
    m=st.tuples(*[st.floats(1.0, 1e3)] * 3),
    d=st.tuples(*[st.floats(0.0, 1e3)] * 6),
    psi=st.floats(-10, 10),
    uvr=st.tuples(st.floats(-5, 5), st.floats(-5, 5), st.floats(-2, 2)),
)
def test_property_eq20_and_psi_invariance(m, d, psi, uvr):
    p = VehicleParams(*m, *d)
    u, v, r = uvr
    d11, d22, _ = p.damping(u, v, r)
    g = inertial_block(p, psi, u, v, r)
    assert_allclose(g, printed_eq20(p.m11, p.m22, d11, d22, r, psi), rtol=1e-9, atol=1e-9 * (1 + np.abs(g).max()))
    lam = -abs(d11) / p.m11 - 1.0
    n0 = np.linalg.norm(body_block(p, u, v, r) - lam * np.eye(2), 2)
    n1 = np.linalg.norm(g - lam * np.eye(2), 2)
    assert n1 == pytest.approx(n0, rel=1e-9, abs=1e-12)


# --- REMUS 100 provenance -------------------------------------------------------------
# Prestero (2001) tabulates the sway cross-flow drag Y_v|v| = -1310 kg/m, ten times its
# heave twin Z_w|w| = -131 kg/m, although the hull is axisymmetric (the two should be
# equal). The preset keeps the published 1310; this test shows how much the certificate
# depends on that one number.
REMUS_ENVELOPE = dict(u=(0.5, 2.5), v=(-0.3, 0.3), r=(-0.3, 0.3))
PRESTERO = dict(m=30.48, y_vdot=-35.5, x_udot=-0.93, x_uu=-1.62, y_uv=-28.6, z_ww=-131.0, y_vv=-1310.0)


def test_remus100_uses_published_sway_drag():
    p = remus100()
    assert p.d22_quad == -PRESTERO["y_vv"]
    assert p.d22_quad == pytest.approx(-10.0 * PRESTERO["z_ww"])
    assert p.m22 == pytest.approx(PRESTERO["m"] - PRESTERO["y_vdot"])


def test_remus100_sway_drag_sensitivity():
    """d22_quad = 131 kg/m (the heave value) instead of 1310: lambda and sigma both move."""
    env = Envelope(**REMUS_ENVELOPE)
    published = remus100()
    axisym = replace(published, d22_quad=-PRESTERO["z_ww"], name="remus100 (Y_v|v| = Z_w|w|)")

    # lambda from the Prestero table alone: the most negative damping rate at |u| = 2.5, |v| = 0.3
    u0, umax, vmax = 1.5, 2.5, 0.3
    m11, m22 = PRESTERO["m"] - PRESTERO["x_udot"], PRESTERO["m"] - PRESTERO["y_vdot"]
    surge_rate = -PRESTERO["x_uu"] * umax / m11
    for params, y_vv in ((published, PRESTERO["y_vv"]), (axisym, PRESTERO["z_ww"])):
        sway_rate = (-PRESTERO["y_uv"] * u0 - y_vv * vmax) / m22
        assert envelope_lambda(params, env) == pytest.approx(-max(surge_rate, sway_rate), rel=1e-12)

    lam_pub, lam_axi = envelope_lambda(published, env), envelope_lambda(axisym, env)
    sig_pub = vehicle_sigma(published, env, lam_pub).upper
    sig_axi = vehicle_sigma(axisym, env, lam_axi).upper
    print("\nREMUS 100, u in [0.5, 2.5], v in [-0.3, 0.3], r in [-0.3, 0.3] (vehicle coordinates):")
    print(f"  Y_v|v| = -1310 kg/m (published): lambda = {lam_pub:.4f} 1/s, sigma = {sig_pub:.4f} 1/s")
    print(f"  Y_v|v| =  -131 kg/m (= Z_w|w|):  lambda = {lam_axi:.4f} 1/s, sigma = {sig_axi:.4f} 1/s")
    # the sway rate at |v| = 0.3 sets lambda in both cases: 1310 * 0.3 - 131 * 0.3 = 353.7 kg/s less drag
    assert lam_axi - lam_pub == pytest.approx((1310.0 - 131.0) * vmax / m22, rel=1e-12)
    # sigma is dominated by |lambda| minus the smallest damping rate, so it shrinks by about as much
    assert sig_axi < sig_pub - 1.0
    assert abs((sig_pub - sig_axi) - (lam_axi - lam_pub)) < 0.5
