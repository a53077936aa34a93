"""The NPS AUV II preset against the model it reduces (Healey & Lienard 1993, Fossen's ``npsauv.m``).

The horizontal forces of the published model are evaluated here from its nondimensional
derivatives, station by station, independently of :func:`~auv_hinf.models.vehicle.nps_auv2`: on
pure sway and pure yaw at the design speed the preset's diagonal damping must give the same
force and moment, and its rudder and propeller the model's.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from auv_hinf.actuation.limits import VEHICLE_ACTUATORS, RudderActuation
from auv_hinf.certificate.assembly import certify
from auv_hinf.config.settings import config_from_dict
from auv_hinf.models.vehicle import nps_auv2

L, RHO = 5.3, 1000.0


def _scale(k: int) -> float:
    return 0.5 * RHO * L**k


def model_sway_force(u: float, v: float) -> float:
    """``Y`` of ``npsauv.m`` at ``(u, v)``, no rotation, no rudder (N): lift plus the cross-flow sum."""
    dx = L / 10
    cross = sum(dx * 0.5 * (0.6 * v**2) * v / abs(v) for _ in np.arange(-L / 2, L / 2 + dx / 2, dx)) if v else 0.0
    return _scale(2) * (-1.0e-1) * u * v - 0.5 * RHO * cross


def model_yaw_moment(u: float, r: float) -> float:
    """``N`` of ``npsauv.m`` at ``(u, r)``, no sway, no rudder (N m)."""
    dx = L / 10
    cross = 0.0
    for x in np.arange(-L / 2, L / 2 + dx / 2, dx):
        vc = x * r
        if vc:
            cross += dx * 0.5 * (0.6 * vc**2) * vc / abs(vc) * x
    return _scale(4) * (-1.6e-2) * u * r - 0.5 * RHO * cross


@pytest.mark.parametrize("v", [-0.4, -0.05, 0.1, 0.3])
def test_the_sway_damping_is_the_models_at_the_design_speed(v):
    p = nps_auv2(1.5)
    assert -(p.d22_lin + p.d22_quad * abs(v)) * v == pytest.approx(model_sway_force(1.5, v), rel=1e-9)


@pytest.mark.parametrize("r", [-0.2, -0.01, 0.03, 0.15])
def test_the_yaw_damping_is_the_models_at_the_design_speed(r):
    p = nps_auv2(1.5)
    assert -(p.d33_lin + p.d33_quad * abs(r)) * r == pytest.approx(model_yaw_moment(1.5, r), rel=1e-9)


def test_the_masses_are_the_models_inverse_inertia():
    # npsauv.m writes inv(M) expanded; its diagonal is 1/m11, 1/m22, 1/m33 up to the couplings it keeps
    p = nps_auv2()
    assert 1.0 / p.m11 == pytest.approx(1.662e-4, rel=2e-3)
    assert 1.0 / p.m22 == pytest.approx(1.052e-4, rel=1e-2)
    assert 1.0 / p.m33 == pytest.approx(4.838e-5, rel=1e-2)


def test_the_propeller_balances_the_drag_at_the_models_top_speed():
    act = VEHICLE_ACTUATORS["nps-auv2"]
    assert isinstance(act, RudderActuation)
    top = 0.012 * 1500 / 60 * 2 * math.pi  # the model's advance ratio is 1 there: thrust = drag
    assert act.tau_x == pytest.approx(nps_auv2().d11_quad * top**2, rel=1e-3)
    # the rudder is the model's Y_dr, N_dr: a tail rudder about half a length behind the centre
    assert act.rudder_sway == pytest.approx(_scale(2) * 2.7e-2, rel=1e-3)
    assert act.rudder_yaw == pytest.approx(_scale(3) * -1.3e-2, rel=1e-3)
    assert -0.5 * L < act.lever_arm < -0.4 * L


@pytest.mark.slow
def test_the_fully_actuated_law_is_refused_on_the_nps_auv2():
    raw = {
        "vehicle": {"preset": "nps-auv2"},
        "formation": {"n": 3, "shape": [[0.0, -20.0], [0.0, -40.0]]},
        "reference": {"kind": "line", "speed": 1.5, "heading": 0.0},
        "envelope": {"u": [0.5, 2.5], "v": [-0.3, 0.3], "r": [-0.3, 0.3]},
        "actuators": {"preset": "nps-auv2"},
    }
    cert = certify(config_from_dict(raw))
    assert not cert.certified
    text = " ".join(cert.reasons)
    assert "no sway actuator" in text and "rudder" in text
