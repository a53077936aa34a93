"""The 6-DOF REMUS 100: its closed forms, its reduction to the 3-DOF model, and the cascade on it."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from auv_hinf.actuation.limits import vehicle_actuators
from auv_hinf.exceptions import ParameterError
from auv_hinf.guidance.law import GuidanceConfig
from auv_hinf.guidance.simulation import simulate_guidance
from auv_hinf.guidance.six_dof import DepthAutopilot, simulate_guidance_6dof
from auv_hinf.mission.fleet import FleetReference, reference_from_dict
from auv_hinf.models import remus6dof as six
from auv_hinf.models.vehicle import remus100, rhs

PRESTERO = six.Remus6Dof()
U0 = 1.5  # m/s, the design speed of the 3-DOF preset


def planar_twin(u0: float = U0) -> six.Remus6Dof:
    """Coefficients with which the 6-DOF model's horizontal plane is the 3-DOF ``remus100(u0)`` at ``u = u0``.

    No offset centre of gravity, neutral buoyancy, no off-diagonal added mass, and the lift and
    Munk terms set to what the diagonal model keeps: ``-m11 u r`` in sway, ``-(m22 - m11) u v`` in yaw;
    no cross-flow drag across the axes (``Y_r|r|``, ``N_v|v|``).
    """
    p, m = remus100(u0), PRESTERO.mass
    return replace(
        PRESTERO,
        z_g=0.0,
        buoyancy=PRESTERO.weight,
        y_rdot=0.0,
        n_vdot=0.0,
        x_vr=p.m22 - m,
        x_rr=0.0,
        y_rr=0.0,
        n_vv=0.0,
        y_ur=m - p.m11,
        n_uv=-(p.m22 - p.m11),
        k_prop=0.0,
    )


def test_the_mass_matrix_is_symmetric_positive_definite():
    mm = six.mass_matrix(PRESTERO)
    np.testing.assert_array_equal(mm, mm.T)
    assert np.linalg.eigvalsh(mm).min() > 0.0
    with pytest.raises(ParameterError, match="positive definite"):
        six.Remus6Dof(x_udot=40.0)  # a negative added mass larger than the vehicle
    with pytest.raises(ParameterError, match="mass"):
        six.Remus6Dof(mass=-1.0)


def test_the_horizontal_plane_of_the_planar_twin_is_the_3dof_model(rng):
    """At the design speed, level and at constant depth, the two models give the same derivative."""
    twin, p, act = planar_twin(), remus100(U0), vehicle_actuators("remus100")
    n = 50
    planar = np.column_stack(
        [rng.normal(0, 50, n), rng.normal(0, 50, n), rng.uniform(-np.pi, np.pi, n), np.full(n, U0),
         rng.uniform(-0.3, 0.3, n), rng.uniform(-0.3, 0.3, n)]
    )  # fmt: skip
    thrust, rudder = rng.uniform(0, 20, n), rng.uniform(-0.2, 0.2, n)
    full = np.zeros((n, six.STATES))
    full[:, [six.X, six.Y, six.PSI, six.U, six.V, six.R]] = planar
    current = np.array([0.1, -0.2])
    d6 = six.derivative(twin, full, thrust, rudder, np.zeros(n), current)
    q = U0 * U0 * rudder
    d3 = rhs(p, planar, np.column_stack([thrust, act.rudder_sway * q, act.rudder_yaw * q]))
    d3[:, :2] += current
    np.testing.assert_allclose(d6[:, [six.X, six.Y, six.PSI, six.U, six.V, six.R]], d3, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(d6[:, [six.Z, six.PHI, six.THETA, six.W, six.P, six.Q]], 0.0, atol=1e-12)


@pytest.mark.parametrize("angle", [0.05, -0.2, 0.4])
def test_the_hydrostatic_moments_of_the_low_centre_of_gravity(angle):
    """At rest, heeled or pitched by ``angle``: the weight below the buoyancy rights it, ``-z_g W sin(angle)``."""
    state = np.zeros(six.STATES)
    state[six.PHI] = angle
    f = six.forces(PRESTERO, state, np.float64(0.0), np.float64(0.0), np.float64(0.0))
    excess = PRESTERO.weight - PRESTERO.buoyancy
    assert f[3] == pytest.approx(-PRESTERO.z_g * PRESTERO.weight * np.sin(angle), rel=1e-12)
    assert f[1] == pytest.approx(excess * np.sin(angle), rel=1e-12) and f[2] == pytest.approx(excess * np.cos(angle))
    state[six.PHI], state[six.THETA] = 0.0, angle
    f = six.forces(PRESTERO, state, np.float64(0.0), np.float64(0.0), np.float64(0.0))
    assert f[4] == pytest.approx(-PRESTERO.z_g * PRESTERO.weight * np.sin(angle), rel=1e-12)
    assert f[0] == pytest.approx(-excess * np.sin(angle), rel=1e-12)


def test_the_propeller_torque_heels_the_vehicle_to_its_closed_form_angle():
    """In steady straight running the roll moment balances: ``sin(phi) = K_prop T / (X_prop z_g W)``."""
    state = np.zeros(six.STATES)
    state[six.U] = U0
    thrust = -PRESTERO.x_uu * U0 * U0
    phi = np.arcsin(PRESTERO.k_prop * thrust / PRESTERO.x_prop / (PRESTERO.z_g * PRESTERO.weight))
    state[six.PHI] = phi
    f = six.forces(PRESTERO, state, np.float64(thrust), np.float64(0.0), np.float64(0.0))
    assert f[3] == pytest.approx(0.0, abs=1e-12) and -0.15 < phi < -0.05  # Prestero's ~5 degrees


def test_bad_depth_autopilot_gains_are_refused():
    with pytest.raises(ParameterError, match="pitch_bandwidth"):
        DepthAutopilot(pitch_bandwidth=0.0)
    with pytest.raises(ParameterError, match="depth_integral"):
        DepthAutopilot(depth_integral=-1.0)


@pytest.mark.slow
@pytest.mark.parametrize("current", [(0.0, 0.2), (0.1, -0.17)])
def test_the_cascade_designed_on_3dof_runs_the_6dof_remus_in_a_current(current):
    """ILOS still removes the cross-track offset; the worst errors stay near the 3-DOF run's."""
    fleet = FleetReference(reference_from_dict("line", speed=U0, heading=0.0), np.zeros((1, 2)), None, "path")
    g, p, act = GuidanceConfig(kind="ilos"), remus100(U0), vehicle_actuators("remus100")
    r3 = simulate_guidance(g, p, p, act, fleet, 300.0, current).report()
    run = simulate_guidance_6dof(g, p, act, fleet, 300.0, current)
    r6 = run.report()
    assert r6["final_errors"]["cross_track"] < 0.1  # ILOS on the richer model
    assert r6["saturation_fraction"] == 0.0 and r6["commanded_peak"]["rudder"] < act.rudder_max
    # the 3-DOF run starts in its steady crab and stays on the line; the richer model adds its
    # heave, roll and sway-yaw transients, a few centimetres at most
    assert r3["measured_errors"]["cross_track"] < 1e-6
    assert r6["measured_errors"]["cross_track"] < r3["measured_errors"]["cross_track"] + 0.2
    z, phi, theta = run.vertical[-1, 0]
    assert abs(z - DepthAutopilot().depth) < 0.05 and abs(phi) < 0.15 and abs(theta) < 0.1


@pytest.mark.slow
def test_cli_simulate_six_dof(capsys):
    from auv_hinf.cli.main import main

    code = main(
        ["simulate", "--preset", "remus-survey-ilos", "--six-dof", "--horizon", "20", "--json", "--uncertified"]
    )
    out, err = capsys.readouterr()
    rep = json.loads(out)
    assert code == 1 and "6-DOF" in err and rep["saturation_fraction"] == 0.0
    lo, hi = rep["vertical"]["depth"]
    # the propeller's torque starts as a step on the lightly damped roll: it overshoots to about
    # twice the 0.094 rad steady heel
    assert lo <= DepthAutopilot().depth <= hi and 0.094 < rep["vertical"]["peak_roll"] < 2.5 * 0.094
    code = main(["simulate", "--preset", "remus-line", "--six-dof", "--horizon", "5"])
    _, err = capsys.readouterr()
    assert code == 2 and "--six-dof" in err and "Traceback" not in err
