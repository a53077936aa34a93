"""Path-frame offsets: p_i = q + R(chi) d_i and its derivatives, against independent computations."""

from __future__ import annotations

import numpy as np
import pytest

from auv_hinf.exceptions import ParameterError
from auv_hinf.mission.fleet import FleetReference, PathFrameReference, course_jerk, shaped_start
from auv_hinf.mission.paths import (
    CircleReference,
    LawnmowerReference,
    LineReference,
    SineReference,
    heading_from_velocity,
)
from auv_hinf.mission.tubes import PATH_FRAME_CELLS, path_frame_tube, shaped_tube, slot_bounds

#: Analytic against an independent analytic computation: round-off of a few flops on ~100 m.
EXACT = 1e-9
#: Fourth-order central differences with step H: truncation ~H^4 |p^(5)| plus round-off
#: ~eps |p| / H (|p| ~ 1e3 m): about 1e-9 to 1e-8 in each derivative.
H = 1e-3
FD_ATOL = 1e-7

MISSIONS = [
    SineReference(),
    CircleReference(speed=1.2, radius=40.0, center=(5.0, -3.0)),
    LineReference(speed=1.0, heading=0.7, start=(2.0, 1.0)),
    LawnmowerReference(speed=1.5, leg_length=100.0, spacing=60.0, turn_radius=12.0),
]


def rot(chi: np.ndarray, d: np.ndarray) -> np.ndarray:
    """R(chi) d for times (T,) and offsets (N, 2): (T, N, 2), written out independently."""
    c, s = np.cos(chi)[:, None], np.sin(chi)[:, None]
    return np.stack([c * d[:, 0] - s * d[:, 1], s * d[:, 0] + c * d[:, 1]], axis=-1)


def central(f, t: np.ndarray) -> np.ndarray:
    """Fourth-order central difference of f at t."""
    return (f(t - 2 * H) - 8 * f(t - H) + 8 * f(t + H) - f(t + 2 * H)) / (12 * H)


@pytest.mark.parametrize("mission", MISSIONS, ids=lambda m: m.kind)
def test_positions_match_an_independent_rotation_and_derivatives_match_finite_differences(mission):
    rng = np.random.default_rng(23)
    off = rng.uniform(-30.0, 30.0, size=(6, 2))
    t = rng.uniform(0.0, 600.0, size=9)
    ref = PathFrameReference(mission, off)
    q, qd, qdd, _ = mission(t)
    chi = np.arctan2(qd[:, 1], qd[:, 0])
    chi1 = (qd[:, 0] * qdd[:, 1] - qd[:, 1] * qdd[:, 0]) / (qd**2).sum(-1)
    m = ref.motion(t)
    np.testing.assert_allclose(m.p, q[:, None] + rot(chi, off), rtol=0, atol=EXACT)
    # p' = q' + chi' S R d with S R d = R (S d), S d = (-d_y, d_x)
    np.testing.assert_allclose(m.v, qd[:, None] + chi1[:, None, None] * rot(chi, off[:, ::-1] * [-1, 1]), atol=EXACT)
    np.testing.assert_allclose(m.psi, np.broadcast_to(chi[:, None], m.psi.shape), atol=EXACT)
    terms, _ = ref.kinematics(t)
    for k in range(3):  # p', p'', p''' against differences of the analytic lower derivative
        fd = central(lambda x, k=k: ref.kinematics(x)[0][k], t)
        np.testing.assert_allclose(terms[k + 1], fd, rtol=0, atol=FD_ATOL)
    np.testing.assert_allclose(m.r, central(lambda x: ref.motion(x).psi, t), atol=FD_ATOL)
    np.testing.assert_allclose(m.r_dot, central(lambda x: ref.motion(x).r, t), atol=FD_ATOL)


@pytest.mark.parametrize("mission", MISSIONS, ids=lambda m: m.kind)
def test_snap_and_course_jerk_match_finite_differences(mission):
    t = np.random.default_rng(5).uniform(0.0, 600.0, size=11)
    np.testing.assert_allclose(mission.snap(t), central(lambda x: mission(x)[3], t), atol=FD_ATOL)
    jerk = course_jerk(*mission(t)[1:], mission.snap(t))
    np.testing.assert_allclose(jerk, central(lambda x: heading_from_velocity(*mission(x)[1:])[2], t), atol=FD_ATOL)


def test_per_vehicle_times_and_the_fleet_reference_agree_with_the_reference_class():
    mission = MISSIONS[3]
    off = np.array([[5.0, 0.0], [-5.0, 10.0], [-5.0, -10.0]])
    ref = PathFrameReference(mission, off)
    t = np.array([[10.0, 90.0, 140.0], [3.0, 70.0, 200.0]])
    per = ref.motion_per_vehicle(t)
    for s in range(2):
        for i in range(3):
            one = ref.motion(t[s, i])
            np.testing.assert_allclose(per.p[s, i], one.p[i], atol=EXACT)
            np.testing.assert_allclose(per.a[s, i], one.a[i], atol=EXACT)
    fleet = FleetReference(mission, off, None, "path").motion(t[0])
    np.testing.assert_allclose(fleet.v, ref.motion(t[0]).v, atol=EXACT)


def test_inertial_frame_is_unchanged():
    mission, off = MISSIONS[0], np.array([[3.0, 4.0], [-1.0, 2.0]])
    t = np.linspace(0.0, 100.0, 7)
    m = FleetReference(mission, off).motion(t)
    q, qd, _, _ = mission(t)
    np.testing.assert_array_equal(m.p, off + q[:, None])
    np.testing.assert_array_equal(m.v, np.broadcast_to(qd[:, None], m.v.shape))


def test_shaped_start_in_the_path_frame_starts_on_the_vehicles_and_ends_on_the_slots():
    mission = MISSIONS[3]
    off = np.array([[5.0, 0.0], [-5.0, 10.0], [-5.0, -10.0]])
    init = np.array(
        [[1.0, 2.0, 0.2, 1.2, 0.1, 0.01], [-8.0, 12.0, -0.1, 1.0, 0.0, 0.0], [-6.0, -9.0, 0.1, 1.4, 0.0, 0.0]]
    )
    fleet = shaped_start(mission, off, init, 60.0, turn_time=20.0, frame="path")
    m = fleet.motion(0.0)
    c, s = np.cos(init[:, 2]), np.sin(init[:, 2])
    np.testing.assert_allclose(m.p, init[:, :2], atol=EXACT)
    np.testing.assert_allclose(
        m.v, np.stack([c * init[:, 3] - s * init[:, 4], s * init[:, 3] + c * init[:, 4]], -1), atol=EXACT
    )
    np.testing.assert_allclose(np.cos(m.psi - init[:, 2]), 1.0, atol=EXACT)
    np.testing.assert_allclose(m.r, init[:, 5], atol=EXACT)
    late = np.array([61.0, 150.0])
    np.testing.assert_allclose(fleet.motion(late).p, PathFrameReference(mission, off).motion(late).p, atol=EXACT)


def test_shaped_path_frame_tube_has_one_row_per_cell_and_vehicle_and_bounds_the_blend():
    """Every field of the shaped tube in the path frame has a row per (cell, vehicle), as in the
    inertial frame (the yaw acceleration had one per vehicle: certify and simulate of a path-frame
    fleet with a declared start failed on it), and each blend cell's bounds hold the sampled blend."""
    mission = MISSIONS[2]
    off = np.array([[0.0, 0.0], [-5.0, 10.0], [-5.0, -10.0]])
    init = np.array(
        [[25.0, 5.0, 0.1, 1.0, 1.0, 0.1], [-5.0, 10.0, 0.4, 1.0, 1.0, 0.1], [10.0, 8.0, 0.7, 1.0, 0.0, 0.0]]
    )
    fleet = shaped_start(mission, off, init, 60.0, turn_time=20.0, frame="path")
    k = 16
    tube = shaped_tube(fleet, cells=k)
    rows = tube.speed.shape[0]
    assert tube.offset.shape == tube.yaw_rate.shape == (rows, 2)
    assert tube.accel.shape == tube.yaw_accel.shape == (rows,)
    # the blend's cells come first, cell-major per vehicle: vehicle i's k cells are rows i k ... i k + k - 1
    t = np.linspace(0.0, 60.0, 12_001)[:-1]
    m = fleet.motion(t)
    r_dot = np.gradient(m.r, t, axis=0)
    cell = np.minimum((t / (60.0 / k)).astype(int), k - 1)
    n = off.shape[0]
    for i in range(n):
        box = tube.yaw_rate[i * k + cell]
        assert np.all(m.r[:, i] >= box[:, 0] - FD_ATOL) and np.all(m.r[:, i] <= box[:, 1] + FD_ATOL)
        assert np.all(np.abs(r_dot[2:-2, i]) <= tube.yaw_accel[i * k + cell[2:-2]] * 1.01 + 1e-6)


@pytest.mark.parametrize("mission", [MISSIONS[0], MISSIONS[3]], ids=lambda m: m.kind)
def test_path_frame_tube_contains_every_sampled_desired_motion(mission):
    off = np.array([[6.0, 0.0], [1.0, 10.0], [1.0, -10.0], [-4.0, 20.0], [-4.0, -20.0]]) * 0.2
    tube = path_frame_tube(mission, off)
    m = PathFrameReference(mission, off).motion(np.linspace(0.0, 3000.0, 60_001))
    speed = np.hypot(m.v[..., 0], m.v[..., 1])
    offset = np.angle(np.exp(1j * (m.psi - np.arctan2(m.v[..., 1], m.v[..., 0]))))
    accel = np.hypot(m.a[..., 0], m.a[..., 1])
    k = PATH_FRAME_CELLS
    for i in range(off.shape[0]):
        rows = slice(i * k, (i + 1) * k)

        def inside(x, box, i=i, rows=rows):
            return (x[:, i, None] >= box[rows, 0]) & (x[:, i, None] <= box[rows, 1])

        cell = inside(speed, tube.speed) & inside(offset, tube.offset) & inside(m.r, tube.yaw_rate)
        assert cell.any(axis=1).all()  # every sample lies in one cell (all three at once)
        assert accel[:, i].max() <= tube.accel[rows].max()
        assert np.abs(m.r_dot[:, i]).max() <= tube.yaw_accel[rows].max()


#: Offsets (m) of a five-vehicle V and a line abreast, in the path frame (x along the track).
SLOT_OFFSETS = {
    "v": np.array([[0.0, 0.0], [-5.0, 10.0], [-5.0, -10.0], [-10.0, 20.0], [-10.0, -20.0]]),
    "abreast": np.array([[0.0, -15.0], [0.0, 0.0], [0.0, 15.0]]),
}


@pytest.mark.parametrize("offsets", SLOT_OFFSETS.values(), ids=SLOT_OFFSETS.keys())
@pytest.mark.parametrize(
    "mission",
    [
        LawnmowerReference(speed=1.5, leg_length=300.0, spacing=400.0, turn_radius=100.0),
        CircleReference(speed=1.5, radius=150.0),
        SineReference(speed=1.5, amplitude=20.0, omega=0.02),
        LineReference(speed=1.5),
    ],
    ids=lambda m: m.kind,
)
@pytest.mark.parametrize("frame", ["path", "inertial"])
def test_slot_bounds_hold_on_every_sampled_slot_and_are_near_them_in_the_turns(mission, offsets, frame):
    off = offsets if frame == "path" else np.zeros_like(offsets)  # inertial slots move as the centre
    bounds = slot_bounds(
        mission, off, frame, constant_speed=isinstance(mission, (CircleReference, LawnmowerReference, LineReference))
    )
    t = np.linspace(0.0, 1500.0, 30_001)  # every 0.05 s: the turns last tens of seconds
    ref = PathFrameReference(mission, offsets) if frame == "path" else None

    def slots(tt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if ref is None:
            _, v, a, _ = mission(tt)
            return v[:, None, :], a[:, None, :]
        m = ref.motion(tt)
        return m.v, m.a

    v, a = slots(t)
    speed = np.hypot(v[..., 0], v[..., 1])
    omega = (v[..., 0] * a[..., 1] - v[..., 1] * a[..., 0]) / speed**2
    speed_rate = np.einsum("tni,tni->tn", v, a) / speed  # U' = (p' . p'') / U
    # omega' by central differences of the exact omega (step 1e-3 s: truncation ~1e-6 |omega'''|)
    vp, ap = slots(t + H)
    vm, am = slots(t - H)

    def rate(vv: np.ndarray, aa: np.ndarray) -> np.ndarray:
        return (vv[..., 0] * aa[..., 1] - vv[..., 1] * aa[..., 0]) / np.einsum("tni,tni->tn", vv, vv)

    omega_dot = (rate(vp, ap) - rate(vm, am)) / (2.0 * H)
    assert np.abs(omega).max() <= bounds.turn_rate
    assert np.abs(speed_rate).max() <= bounds.speed_rate + 1e-12
    assert np.abs(omega_dot).max() <= bounds.turn_accel + FD_ATOL
    if frame == "path" and isinstance(mission, LawnmowerReference) and offsets.shape[0] == 5:
        # on a lawn-mower's 100 m turns the closed forms are within 20 % of the sampled course rate and
        # speed rate (the tube's |p_d''| bound of |U'| is 9.5 times the sampled one)
        assert bounds.turn_rate <= 1.2 * np.abs(omega).max()
        assert bounds.speed_rate <= 1.2 * np.abs(speed_rate).max()


def test_slot_bounds_refuse_a_mission_on_which_a_slot_may_stop():
    # a 20 m arm on 10 m turns: the inner slot's speed 1.5 (1 - 20/10) m/s would reverse
    tight = LawnmowerReference(speed=1.5, leg_length=100.0, spacing=60.0, turn_radius=10.0)
    with pytest.raises(ParameterError, match="may stop"):
        slot_bounds(tight, SLOT_OFFSETS["v"], "path", constant_speed=True)
