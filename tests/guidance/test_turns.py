"""The cascade's certificate on turns: the loop's steady-turn equilibrium, and runs on curved missions.

The slot's turn pushes the sway (the Coriolis force) by a known signal; the certificate also bounds
the states about the loop's equilibrium for that push (``x = E omega + z``), where the ILOS state's
crab holds the sideslip. The tests check the equilibrium in closed form and against a simulated
steady turn, and runs of certified fleets on turning missions against the certified box.
"""

from __future__ import annotations

import numpy as np
import pytest

from auv_hinf.cascade.certificate import (
    DERIVED,
    E_R,
    NB,
    STATE_ROWS,
    STATES,
    X_E,
    Y_E,
    E,
    P,
    V,
    _law,
    _loop_analysis,
    _rows,
    _state_rows,
    cascade_loop,
    sway_drag_gap,
    turn_directions,
    turn_equilibrium,
    turn_forcing,
    turn_sway_slope,
    turn_terms,
)
from auv_hinf.certificate.design_point import design_point, raw_fleet
from auv_hinf.certificate.parts.guidance import cascade_problem, guidance_summary
from auv_hinf.guidance.simulation import simulate_guidance
from tests.guidance.test_certificate import _states_along, transit

#: Two REMUS 100 30 m apart (inertial offsets: each slot on its own 200 m circle), at 1.5 m/s
#: (omega = 0.0075 rad/s), in still water (on 100 m circles the start binds: each vehicle starts
#: straight while its slot already turns).
CIRCLE = {"n": 2, "frame": "inertial", "offsets": [[0.0, 0.0], [0.0, 30.0]]}
#: A lawn-mower with 75 m turns for the transit's line abreast (turn rate 0.02 rad/s).
LAWNMOWER = {"kind": "lawnmower", "speed": 1.5, "leg_length": 300.0, "spacing": 310.0, "turn_radius": 75.0}
#: The ``remus-transit-ilos`` gains: a heading loop of 2.4 rad/s and a 16 m lookahead.
GAINS = {"kind": "ilos", "heading_bandwidth": 2.4, "lookahead": 16.0}


def test_the_turn_equilibrium_is_the_rest_point_of_the_nominal_loop_where_the_crab_holds_the_sideslip():
    cfg = transit(reference=LAWNMOWER, guidance=GAINS, uncertainty={}, disturbance={})
    problem = cascade_problem(cfg, design_point(cfg))  # the problem alone, not its certificate
    assert not isinstance(problem, str)
    rows = _rows(problem)
    full = np.vstack([rows[k] for k in STATE_ROWS])
    per_rate = turn_equilibrium(problem)
    state = per_rate[:7]
    a_cl = full[:, :7] + full[:, 7:] @ _law(problem)
    np.testing.assert_allclose(a_cl @ state, -turn_forcing(problem)[0], atol=1e-12)
    # on the track with no heading error, the ILOS crab p equal to the sideslip: the sway damping's
    # answer to the Coriolis force and the side force of the rudder that holds the yaw drag, in closed
    # form (-m11 U0 + d33 / l) omega / (d22 + k_m), k_m = -(m22 - m11) U0 / l the Munk compensation's
    n, act, u0 = problem.nominal_plant, problem.act, problem.nominal_speed
    assert np.allclose(state[[X_E, Y_E, E, E_R]], 0.0, atol=1e-12)
    sideslip = (-n.m11 * u0 + n.d33_lin / act.lever_arm) / (n.d22_lin - (n.m22 - n.m11) * u0 / act.lever_arm)
    np.testing.assert_allclose([state[V], state[P]], [sideslip, sideslip], rtol=1e-10)
    # the two treatments of the turn: about the equilibrium the push leaves the residuals
    about, residual = turn_terms(problem, True), turn_terms(problem, False)
    assert about.equilibrium and not residual.equilibrium
    np.testing.assert_allclose(about.shift, np.abs(per_rate) * problem.turn_rate + about.lagging)
    # the lag term: the held commands and the measured states read the equilibrium h + d earlier
    assert not about.lagging[:7].any() and about.lagging[7:].max() > 0.0
    held_tau = (_law(problem) @ state)[1]  # the rudder's yaw acceleration at the equilibrium, per rad/s
    tau = about.lagging[7 + DERIVED.index("tau")]
    assert tau == pytest.approx(abs(held_tau) * problem.lag * problem.turn_accel, rel=1e-12)
    # each treatment drives the loop by its own two scalar signals: omega' and the lag about the
    # equilibrium, omega and omega' as residuals
    np.testing.assert_array_equal(about.amplitudes, [problem.turn_accel, problem.lag * problem.turn_accel, 0.0, 0.0])
    np.testing.assert_array_equal(residual.amplitudes, [0.0, 0.0, problem.turn_rate, problem.turn_accel])
    assert residual.shift.shape == (NB,) and not residual.shift.any()


def test_each_turn_signal_drives_the_loop_along_its_direction_through_its_own_peak_gain():
    cfg = transit(reference=LAWNMOWER, guidance=GAINS, uncertainty={}, disturbance={})
    problem = cascade_problem(cfg, design_point(cfg))
    assert not isinstance(problem, str)
    force, accel = turn_forcing(problem)
    state = turn_equilibrium(problem)[:7]
    held = _state_rows(_rows(problem))[:, 7:] @ (_law(problem) @ state)
    directions = turn_directions(problem)
    np.testing.assert_allclose(directions, np.column_stack([accel - state, held, force, accel]), atol=1e-15)
    loop = cascade_loop(problem)
    np.testing.assert_array_equal(loop.b_w[:, 7:], directions)
    # one kernel per signal: its gain is at most the sum of the channels' gains it combines (the
    # triangle inequality, with the sum's tolerance), and strictly below it where the channels cancel
    gains, _ = _loop_analysis(problem)
    unmix = np.linalg.inv(loop.b_w[:, :7])  # the residuals' coordinates of each direction
    summed = gains.continuous[:, :7] @ np.abs(unmix @ directions)
    joint = gains.continuous[:, 7:]
    assert np.all(joint <= summed * (1.0 + 1e-3) + 1e-12)
    assert np.any(joint[:7] < 0.9 * summed[:7])


def test_the_sway_drag_slope_is_the_drag_at_the_turns_sideslip_and_its_residual_covers_every_plant():
    cfg = transit(reference=LAWNMOWER, guidance=GAINS, uncertainty={"d22_quad": [0.8, 1.2]}, disturbance={})
    problem = cascade_problem(cfg, design_point(cfg))
    assert not isinstance(problem, str) and problem.turn_rate > 0.0
    sideslip = abs(turn_equilibrium(problem)[V]) * problem.turn_rate
    slope = turn_sway_slope(problem)
    assert slope == pytest.approx(problem.nominal_plant.d22_quad * sideslip, rel=1e-12) and slope > 0.0
    line = transit(guidance=GAINS, uncertainty={}, disturbance={})
    straight = cascade_problem(line, design_point(line))
    assert not isinstance(straight, str) and turn_sway_slope(straight) == 0.0
    # brute force: every plant's quadratic drag less the nominal slope, over |v| <= V
    m22 = problem.plant.interval("m22")
    m22, d22q = problem.plant.interval("m22"), problem.plant.interval("d22_quad")
    quads = np.linspace(*d22q, 7)[:, None, None] / np.linspace(*m22, 5)[None, :, None]
    quad = (d22q[0] / m22[1], d22q[1] / m22[0])
    for sway in (0.5 * sideslip, sideslip, 2.0 * sideslip, 8.0 * sideslip):
        v = np.linspace(-sway, sway, 4001)[None, None, :]
        for s in (0.0, slope, 4.0 * slope):
            gap = np.abs(quads * np.abs(v) * v - s / problem.nominal_plant.m22 * v).max()
            bound = sway_drag_gap(s / problem.nominal_plant.m22, quad, sway)
            assert gap <= bound * (1.0 + 1e-12)
            assert gap >= 0.999 * bound  # the supremum: the sampled plants include the extreme ones


@pytest.mark.slow
def test_a_vehicle_on_a_circle_settles_at_the_turn_equilibrium():
    cfg = transit(
        formation=CIRCLE,
        reference={"kind": "circle", "speed": 1.5, "radius": 200.0},
        guidance=GAINS,
        uncertainty={},
        disturbance={},
    )
    summary = guidance_summary(cfg)
    assert summary.holds, summary.reason
    run = simulate_guidance(cfg.guidance, cfg.vehicle, cfg.vehicle, cfg.actuators, raw_fleet(cfg), 400.0)
    settled = _states_along(cfg, run, (0.0, 0.0))[-1]
    omega = 1.5 / 200.0
    expected = turn_equilibrium(summary.problem)[:7] * omega
    # the nominal loop is the plant linearised on the track: the sideslip and the crab match it to 2 %
    np.testing.assert_allclose(settled[:, [P, V]], np.broadcast_to(expected[[P, V]], (2, 2)), rtol=0.02)
    assert np.abs(settled[:, Y_E]).max() < 0.02  # the ILOS state holds the track: |y_e| < 2 cm


@pytest.mark.slow
@pytest.mark.parametrize("current", [(0.0, 0.0), (0.05, 0.0), (0.0, -0.05)])
def test_runs_on_a_lawnmower_stay_inside_the_certified_box(current):
    speed = float(np.hypot(*current))
    cfg = transit(reference=LAWNMOWER, guidance=GAINS, uncertainty={}, disturbance={"current_speed": max(speed, 0.05)})
    summary = guidance_summary(cfg)
    assert summary.holds, summary.reason
    cert = summary.certificate
    # two legs and both turns: the turns' entries and exits move the equilibrium
    run = simulate_guidance(cfg.guidance, cfg.vehicle, cfg.vehicle, cfg.actuators, raw_fleet(cfg), 520.0, current)
    worst = np.abs(_states_along(cfg, run, current)).max(axis=(0, 1))
    for name, w, b in zip(STATES, worst, cert.errors[:7], strict=True):
        assert w <= b, f"{name}: simulated {w:.4g} above the certified {b:.4g}"
    assert np.abs(run.thrust_cmd).max() <= cert.actuation.thrust
    assert np.abs(run.rudder_cmd).max() <= cert.actuation.rudder
    # not vacuous: the turns move the sway to a tenth of its bound or more
    assert worst[V] >= 0.1 * cert.errors[V]
