"""The bounds of the composed certificate's loops against brute-force sampling and closed forms."""

from __future__ import annotations

import numpy as np
import pytest

from auv_hinf.composed.loops import (
    Errors,
    MissionBounds,
    OperatingBox,
    Plant,
    compensation_bounds,
    drag_residual,
    misrotation_gains,
    position_axes,
    residual_nominal,
    turn_bounds,
)
from auv_hinf.implementation.model import Implementation, MeasurementNoise
from auv_hinf.models.vehicle import bluerov2_heavy, body_block, remus100
from auv_hinf.robust.box import PARAMETERS, ParameterBox

BOX = (("m22", (0.9, 1.1)), ("d22_lin", (0.8, 1.2)), ("d22_quad", (0.8, 1.2)))


def _sampled(plant: Plant, desired, width, a0, rng, n=200_000) -> float:
    """The residual's largest value over random plants of the box, desired speeds and errors (with the corners)."""
    box = plant.box
    lo = np.array([box.lo[PARAMETERS.index(k)] for k in ("m22", "d22_lin", "d22_quad")])
    hi = np.array([box.hi[PARAMETERS.index(k)] for k in ("m22", "d22_lin", "d22_quad")])
    mult = lo + (hi - lo) * rng.integers(0, 2, (n, 3))  # the corners, where the extremes are
    mult[: n // 2] = lo + (hi - lo) * rng.random((n // 2, 3))
    mdl = plant.model
    m, dl, dq = mdl.m22 * mult[:, 0], mdl.d22_lin * mult[:, 1], mdl.d22_quad * mult[:, 2]
    y = rng.uniform(desired[0], desired[1], n)
    eta = rng.uniform(-width, width, n)
    eta[: n // 10] = rng.choice([-width, width], n // 10)

    def f(x):
        return -(dl * x + dq * np.abs(x) * x) / m

    return float(np.abs(f(y + eta) - f(y) - a0 * eta).max())


@pytest.mark.parametrize("vehicle", [bluerov2_heavy, remus100])
@pytest.mark.parametrize(("desired", "width"), [((-0.1, 0.1), 0.08), ((0.0, 0.0), 0.2), ((-0.02, 0.3), 0.05)])
def test_the_drag_residual_bounds_every_sampled_plant_and_is_nearly_reached(vehicle, desired, width):
    mdl = vehicle()
    plant = Plant(mdl, ParameterBox.from_ranges(mdl, BOX))
    rng = np.random.default_rng(7)
    a0, bound = residual_nominal(plant, "22", desired, width, (-40.0, 0.0))
    seen = _sampled(plant, desired, width, a0, rng)
    assert seen <= bound
    assert seen >= 0.97 * bound  # the grid's Lipschitz margin and the sampling are all that separate them
    # any other slope leaves at least as much (the search found the least)
    for other in (a0 - 0.3, a0 + 0.3):
        assert drag_residual(plant, "22", desired, width, other) >= bound * (1 - 1e-9)


def test_about_zero_speed_the_best_slope_leaves_a_sixth_of_the_symmetric_perturbation():
    """Exactly: for ``f = -k |x| x`` about ``y = 0`` the best linear fit on ``[-V, V]`` leaves ``(3 - 2 sqrt 2) k V^2``.

    The symmetric slope perturbation (slope range ``[-k V, 0]``, half-width ``k V / 2``) bounds it by
    ``k V^2 / 2``: the residual is 2.9 times smaller.
    """
    mdl = bluerov2_heavy()
    plant = Plant(mdl, ParameterBox.from_ranges(mdl, ()))
    k, v = mdl.d22_quad / mdl.m22, 0.1
    a0, bound = residual_nominal(plant, "22", (0.0, 0.0), v, (-k * v, 0.0))
    exact = (3.0 - 2.0 * np.sqrt(2.0)) * k * v * v
    assert exact <= bound <= exact * 1.01
    assert a0 == pytest.approx(-2.0 * (np.sqrt(2.0) - 1.0) * k * v, rel=1e-3)


@pytest.mark.parametrize("vehicle", [bluerov2_heavy(), remus100()], ids=["bluerov2", "remus100"])
@pytest.mark.parametrize(("speed", "heading_error", "yaw_rate"), [(0.4, 0.0, 0.0), (1.5, 0.05, 0.02), (0.3, 0.3, 0.2)])
def test_the_turned_compensation_is_bounded_per_axis_by_brute_force(vehicle, speed, heading_error, yaw_rate):
    """Sample the law's drift compensation and feed-forward turned by a heading change: each body
    component of the error stays within its misrotation gain times the change, and the surge gain is
    second order on a straight line (far below the norm bound it replaced)."""
    mission = MissionBounds(
        speed=(speed, speed), accel=0.0, yaw_rate=0.0, yaw_accel=0.0, offset=0.0, jerk=0.0, yaw_jerk=0.0
    )
    errors = Errors(0.1, 0.05, heading_error, yaw_rate)
    op = OperatingBox.of(mission, 0.0, errors)
    impl = Implementation(0.1, 0.1, noise=MeasurementNoise(0.05, 0.004, 0.004, 0.002))
    u_y, v_y, r_y = max(abs(op.u[0]), abs(op.u[1])) + 0.004, op.v + 0.004, op.r + 0.002
    gains = misrotation_gains(
        Plant(vehicle, ParameterBox.from_ranges(vehicle, ())), op, mission, impl, 1.0, (u_y, v_y, r_y)
    )
    delta_max = op.r * impl.max_lag + impl.noise.heading
    rng = np.random.default_rng(7)
    worst = np.zeros(2)
    bounds = np.array(compensation_bounds(vehicle, (u_y, v_y, r_y)))
    entries = np.zeros(3)
    for _ in range(4000):
        u, v, r = rng.uniform(-u_y, u_y), rng.uniform(-v_y, v_y), rng.uniform(-r_y, r_y)
        b = -body_block(vehicle, u, v, 0.0) + np.array(
            [[0.0, (vehicle.m22 - vehicle.m11) * r / vehicle.m11], [(vehicle.m22 - vehicle.m11) * r / vehicle.m22, 0.0]]
        )
        entries = np.maximum(entries, [abs(b[0, 0]), abs(b[1, 1]), max(abs(b[0, 1]), abs(b[1, 0]))])
        angle = rng.uniform(-op.slip, op.slip)
        p = speed * rng.uniform(0.0, 1.0) * np.array([np.cos(angle), np.sin(angle)])
        delta = rng.choice([-1.0, 1.0]) * delta_max * rng.uniform(0.0, 1.0) ** 0.25
        rot = np.array([[np.cos(delta), -np.sin(delta)], [np.sin(delta), np.cos(delta)]])
        err = np.abs(b @ (rot - np.eye(2)) @ p)
        worst = np.maximum(worst, err / abs(delta))
    assert np.all(entries <= bounds * (1 + 1e-12)), (entries, bounds)  # the law's matrix within its bounds
    assert np.all(worst <= np.array(gains) * (1 + 1e-12)), (worst, gains)
    assert worst[1] >= 0.3 * gains[1]  # the cross-track gain is nearly reached
    if heading_error == 0.0 and yaw_rate == 0.0:
        whole = (max(vehicle.d11_lin + vehicle.d11_quad * u_y, 0.0) / vehicle.m11) * speed
        assert gains[0] < 0.1 * whole  # on a straight line the surge part is second order


@pytest.mark.parametrize(("current", "heading"), [(0.1, 0.05), (0.3, 0.4), (0.0, 0.2)])
def test_one_plant_in_one_current_on_a_line_keeps_its_surge_slope_in_one_cell(current, heading):
    """Brute force: a plant of the box, in a constant current, on a straight line, with the heading
    error anywhere in ``[-E, E]`` and the surge velocity error anywhere in the box's width: every
    steady slope it can have lies in one cell of the surge range (the cells are analysed as
    constant plants, so a plant that could leave its cell would not be covered), and the rest of
    its mean-value slope, times the velocity error, keeps one sign and stays within the curvature."""
    mdl = bluerov2_heavy()
    box = ParameterBox.from_ranges(mdl, (("m11", (0.9, 1.1)), ("d11_lin", (0.8, 1.2)), ("d11_quad", (0.8, 1.2))))
    plant = Plant(mdl, box, current)
    speed, width = 0.4, 0.05
    mission = MissionBounds((speed, speed), 0.0, 0.0, 0.0, 0.0, 0.0)
    op = OperatingBox.of(mission, current, Errors(0.0, width, heading, 0.0, surge=width))
    surge, _ = position_axes(plant, op, 0.0, straight=True)
    assert len(surge.parts) > 1
    rng = np.random.default_rng(3)
    lo = np.array([box.lo[PARAMETERS.index(k)] for k in ("m11", "d11_lin", "d11_quad")])
    hi = np.array([box.hi[PARAMETERS.index(k)] for k in ("m11", "d11_lin", "d11_quad")])
    cells = np.array(surge.parts)
    for _ in range(300):
        mult = lo + (hi - lo) * rng.random(3)
        if rng.random() < 0.5:
            mult = lo + (hi - lo) * rng.integers(0, 2, 3)
        m, dl, dq = mdl.m11 * mult[0], mdl.d11_lin * mult[1], mdl.d11_quad * mult[2]
        c = current * np.array([np.cos(a := rng.uniform(0, 2 * np.pi)), np.sin(a)])
        # over time: the heading error turns the body frame; the velocity error moves within the width
        e_psi = np.concatenate([[-heading, heading], rng.uniform(-heading, heading, 400)])
        w = np.array([speed, 0.0]) - c  # R(psi_d)^T (p_d' - c), psi_d = 0
        u_d = w[0] * np.cos(e_psi) + w[1] * np.sin(e_psi)
        eta = rng.uniform(-width, width, e_psi.size)
        x = u_d + eta
        theta = (np.abs(x) * x - np.abs(u_d) * u_d) / np.where(eta == 0.0, 1.0, eta)
        slopes = -(dl + dq * theta) / m
        steady = -(dl + 2.0 * dq * np.abs(u_d)) / m
        assert any(((steady >= a - 1e-12) & (steady <= b + 1e-12)).all() for a, b in cells), (mult, c)
        assert np.all(np.abs(slopes - steady) <= surge.curvature + 1e-12)
        assert np.all((slopes - steady) * eta * np.sign(u_d) <= 1e-15)  # -d_quad eta^2/m, of one sign


def test_a_varying_current_moves_the_trim_across_the_range_so_it_gets_no_cells():
    mdl = bluerov2_heavy()
    box = ParameterBox.from_ranges(mdl, (("d11_quad", (0.8, 1.2)),))
    mission = MissionBounds((0.4, 0.4), 0.0, 0.0, 0.0, 0.0, 0.0)
    op = OperatingBox.of(mission, 0.2, Errors(0.0, 0.05, 0.05, 0.0))
    held, _ = position_axes(Plant(mdl, box, 0.2), op, 0.0, straight=True)
    varying, _ = position_axes(Plant(mdl, box, 0.2, current_rate=0.01), op, 0.0, straight=True)
    assert len(held.parts) > 1 and len(varying.parts) == 1
    (lo, hi), cells = varying.parts[0], np.array(held.parts)
    assert lo <= cells[:, 0].min() and hi >= cells[:, 1].max()  # every trim the held cells cover


@pytest.mark.parametrize("angle", [0.0, 0.3, 1.2, 2.0, 3.5])
def test_turn_bounds_hold_every_turn_of_random_vectors_and_are_reached(angle):
    """Each component of ``R(t) x - x`` for ``|t| <= angle`` stays under the per-axis bound, which some turn reaches."""
    own, cross = turn_bounds(angle)
    rng = np.random.default_rng(3)
    t = rng.uniform(-angle, angle, 20_000)
    x = rng.normal(size=(20_000, 2))
    moved = np.stack([np.cos(t) * x[:, 0] - np.sin(t) * x[:, 1], np.sin(t) * x[:, 0] + np.cos(t) * x[:, 1]], 1) - x
    for j in range(2):
        assert np.all(np.abs(moved[:, j]) <= own * np.abs(x[:, j]) + cross * np.abs(x[:, 1 - j]) + 1e-12)
    grid = np.linspace(0.0, angle, 10_001)
    assert own == pytest.approx(np.max(1.0 - np.cos(grid)), abs=1e-6)
    assert cross == pytest.approx(np.max(np.abs(np.sin(grid))), abs=1e-6)
