"""The certificate's controller and closed loop as python-control systems."""

from __future__ import annotations

from dataclasses import replace

import control as ct
import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

from auv_hinf.certificate import run_plan as plan
from auv_hinf.certificate.assembly import Certificate, certify
from auv_hinf.certificate.design_point import design_point
from auv_hinf.config.presets import preset_config
from auv_hinf.config.settings import ReferenceConfig
from auv_hinf.exceptions import DesignError
from auv_hinf.law.formation_law import FormationController
from auv_hinf.simulation.engine import simulate

#: Straight-line mission of the linearisation test: surge speed (m/s) and course (rad).
LINE_SPEED, LINE_HEADING = 1.5, 0.3


@pytest.fixture(scope="module")
def cert() -> Certificate:
    c = certify(preset_config("paper-triangle"))
    assert c.certified
    return c


@pytest.fixture(scope="module")
def line_cert() -> Certificate:
    cfg = preset_config("paper-triangle")
    cfg = replace(
        cfg,
        reference=ReferenceConfig("line", {"speed": LINE_SPEED, "heading": LINE_HEADING}),
        simulation=replace(cfg.simulation, initial=None),
    )
    c = certify(cfg)
    assert c.certified, c.reasons
    return c


def region_start(c: Certificate, fraction: float = 0.6) -> np.ndarray:
    """States ``(N, 6)`` whose errors against the raw mission at t = 0 are ``fraction`` of every
    radius of the certified simultaneous start region, in varied directions and signs."""
    assert c.closed_loop is not None and c.closed_loop.certificate is not None
    reg = c.closed_loop.certificate.region.region
    m = design_point(c.config).fleet().motion(0.0)
    n = c.config.n
    ang = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False) + 0.3
    sign = np.where(np.arange(n) % 2 == 0, 1.0, -1.0)
    e = fraction * reg.position * np.column_stack([np.cos(ang), np.sin(ang)])
    de = fraction * reg.velocity * np.column_stack([np.cos(ang + 1.0), np.sin(ang + 1.0)])
    psi = m.psi + fraction * reg.heading * sign
    r = m.r - fraction * reg.yaw_rate * sign
    vel = m.v + de
    c_, s_ = np.cos(psi), np.sin(psi)
    u, v = c_ * vel[:, 0] + s_ * vel[:, 1], -s_ * vel[:, 0] + c_ * vel[:, 1]
    return np.column_stack([m.p + e, psi, u, v, r])


@pytest.mark.slow
def test_controller_is_static_with_fleet_signals(cert):
    ctrl = cert.controller()
    n = cert.config.n
    assert isinstance(ctrl, ct.NonlinearIOSystem)
    assert (ctrl.nstates, ctrl.ninputs, ctrl.noutputs) == (0, 6 * n, 3 * n)
    assert ctrl.input_labels[:7] == ["x[0]", "y[0]", "psi[0]", "u[0]", "v[0]", "r[0]", "x[1]"]
    assert ctrl.output_labels[-3:] == [f"tau_x[{n - 1}]", f"tau_y[{n - 1}]", f"tau_psi[{n - 1}]"]


@pytest.mark.slow
def test_controller_matches_the_paper_jacobi_form(cert, rng):
    """The nlsys output equals the independent O(N^2) Jacobi-coordinate law of eqs. (39), (41)."""
    cfg, law = cert.config, cert.law()
    ref = design_point(cfg).fleet()
    jac = FormationController(params=cfg.vehicle, transform=cfg.transform, reference=ref, gains=law.gains)
    ctrl = cert.controller()
    for t in (0.0, 7.3, 41.0):
        m = ref.motion(t)
        states = np.column_stack(
            [
                m.p + rng.normal(0, 2, (cfg.n, 2)),
                m.psi + rng.normal(0, 0.3, cfg.n),
                rng.uniform(0.2, 2.0, cfg.n),
                rng.normal(0, 0.5, cfg.n),
                rng.normal(0, 0.1, cfg.n),
            ]
        )
        c, s = np.cos(states[:, 2]), np.sin(states[:, 2])
        p_dot = np.column_stack([c * states[:, 3] - s * states[:, 4], s * states[:, 3] + c * states[:, 4]])
        expected, _ = jac.forces(t, states, p_dot)
        got = np.asarray(ctrl.output(t, np.zeros(0), states.ravel())).reshape(cfg.n, 3)
        np.testing.assert_allclose(got, expected, rtol=1e-10, atol=1e-9)


@pytest.mark.slow
def test_closed_loop_matches_simulate(cert):
    """ct.input_output_response of the interconnection against simulate (DOPRI) of the same run."""
    x0 = region_start(cert)
    cfg = plan.with_start(cert.config, x0)
    run = plan.plan_run(cfg, start="paper", horizon=40.0, samples=201)
    assert run.covered, run.notes  # the start is inside the certified region: the run is certified
    sys = cert.closed_loop_system()
    n = cfg.n
    assert (sys.nstates, sys.ninputs, sys.noutputs) == (6 * n, 0, 6 * n)
    assert sys.state_labels[:6] == ["auv0_x", "auv0_y", "auv0_psi", "auv0_u", "auv0_v", "auv0_r"]
    resp = ct.input_output_response(
        sys,
        run.scenario.times,
        0.0,
        x0.ravel(),
        solve_ivp_method="RK45",
        solve_ivp_kwargs={"rtol": 1e-10, "atol": 1e-10},
    )
    ours = simulate(run.scenario, rtol=1e-10, atol=1e-10)
    assert ours.exit_time is None  # never leaves the envelope
    states = resp.states.T.reshape(-1, n, 6)
    np.testing.assert_array_equal(resp.outputs, resp.states)
    np.testing.assert_array_equal(states[0], x0)
    pos_err = np.abs(states[..., :2] - ours.states[..., :2]).max()
    assert pos_err < 1e-6, pos_err
    assert np.abs(states[..., 2:] - ours.states[..., 2:]).max() < 1e-6
    # and the fleet converged towards the mission (errors shrink by the certified decay)
    m = design_point(cfg).fleet().motion(run.scenario.times[-1])
    assert (
        np.linalg.norm(states[-1, :, :2] - m.p, axis=1).max()
        < np.linalg.norm(x0[:, :2] - design_point(cfg).fleet().motion(0.0).p, axis=1).max()
    )


@pytest.mark.slow
def test_closed_loop_keeps_the_line_reference_exactly(line_cert):
    """On the reference the closed-loop vector field is the reference's own derivative."""
    sys = line_cert.closed_loop_system()
    ref = design_point(line_cert.config).fleet()
    n = line_cert.config.n
    for t in (0.0, 12.5, 100.0):
        m = ref.motion(t)
        x = np.column_stack([m.p, m.psi, np.full(n, LINE_SPEED), np.zeros(n), np.zeros(n)])
        dx = np.asarray(sys.dynamics(t, x.ravel(), np.zeros(0))).reshape(n, 6)
        np.testing.assert_allclose(dx[:, :2], m.v, rtol=0, atol=1e-12)
        np.testing.assert_allclose(dx[:, 2:], 0.0, rtol=0, atol=1e-12)


@pytest.mark.slow
def test_linearisation_on_a_line_mission(line_cert):
    """ct.linearize about the reference at t = 0 has, per vehicle, the poles of the exact
    linearisation: along-track ``s^2 + (alpha + d11(U)/m11) s + k1``, cross-track
    ``s^2 + (alpha + d22_lin/m22) s + k1`` and the heading poles (placed at r = 0)."""
    cfg, law, par = line_cert.config, line_cert.law(), line_cert.config.vehicle
    n = cfg.n
    m = design_point(cfg).fleet().motion(0.0)
    x0 = np.column_stack([m.p, m.psi, np.full(n, LINE_SPEED), np.zeros(n), np.zeros(n)])
    lin = ct.linearize(line_cert.closed_loop_system(), x0.ravel(), np.zeros(0), t=0.0)
    assert lin.A.shape == (6 * n, 6 * n) and np.all(np.isfinite(lin.A))
    eig = np.linalg.eigvals(lin.A)
    d11 = par.d11_lin + par.d11_quad * LINE_SPEED
    polys = [
        [1.0, law.gains.alpha + d11 / par.m11, law.gains.k1],
        [1.0, law.gains.alpha + par.d22_lin / par.m22, law.gains.k1],
        [1.0, law.gains.k_psi[1] + par.d33_lin / par.m33, law.gains.k_psi[0]],
    ]
    expected = np.concatenate([np.roots(p) for p in polys] * n)
    np.testing.assert_allclose(np.sort(np.roots(polys[2]).real), np.sort(cfg.heading_poles), rtol=1e-9)
    cost = np.abs(eig[:, None] - expected[None, :])
    rows, cols = linear_sum_assignment(cost)
    assert cost[rows, cols].max() < 1e-4  # forward differences (eps 1e-6) in ct.linearize
    assert eig.real.max() < 0


@pytest.mark.slow
def test_controller_needs_a_gain(cert):
    no_gain = replace(cert, gains=None)
    with pytest.raises(DesignError, match="has no gains"):
        no_gain.controller()
