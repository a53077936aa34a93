"""The ArduSub MANUAL_CONTROL mapping and the T200 curve behind it."""

from __future__ import annotations

import numpy as np
import pytest

from auv_hinf.actuation.thrusters import T200_FORWARD_16V, ThrusterAllocation, bluerov2_heavy_thrusters
from auv_hinf.deployment.ardusub import NEUTRAL, ArduSubMapping
from auv_hinf.deployment.thrust_curve import VOLTAGES, T200Curve, force_table
from auv_hinf.exceptions import ParameterError

#: Round-trip residual allowed inside the (30 N, 30 N, 8 N m) box (N, N, N m): the vehicle makes whole
#: microsecond pulses, and one microsecond next to the T200's dead band is about 0.1 N per thruster.
ROUND_TRIP = (1.0, 1.0, 0.2)


def test_t200_table_has_the_published_extremes():
    # forward and reverse maxima of the datasheet sheets (kgf), and the 201 rows of each
    maxima = {12: (3.71, 2.92), 14: (4.53, 3.52), 16: (5.25, 4.07), 18: (6.02, 4.59), 20: (6.72, 5.04)}
    for v in VOLTAGES:
        kgf = force_table(v)
        assert kgf.shape == (201,)
        assert kgf.max() == pytest.approx(maxima[v][0], abs=0.011) and -kgf.min() == pytest.approx(maxima[v][1])
    c16 = T200Curve(16.0)
    assert c16.forward_max == pytest.approx(T200_FORWARD_16V, abs=0.01 * 9.80665)  # the package's 5.25 kgf
    assert c16.dead_band == (1472.0, 1528.0)
    between = T200Curve(15.0)
    assert T200Curve(14.0).forward_max < between.forward_max < c16.forward_max
    with pytest.raises(ParameterError, match="12-20 V"):
        T200Curve(24.0)


def test_t200_inverse_is_the_curve_inverted_outside_the_dead_band():
    c = T200Curve(16.0)
    f = np.linspace(-c.reverse_max, c.forward_max, 301)
    f = f[np.abs(f) > 0.5]  # the table's first step beyond the band is 0.04 kgf = 0.39 N
    assert np.max(np.abs(c.thrust(c.pwm(f)) - f)) < 0.02
    assert c.pwm(0.0) == 1500.0 and c.pwm(1e-3) >= 1528.0 and c.pwm(-1e-3) <= 1472.0


def test_forces_round_trip_through_the_vehicle_side():
    m = ArduSubMapping()
    rng = np.random.default_rng(1)
    for tau in rng.uniform([-30, -30, -8], [30, 30, 8], size=(150, 3)):
        cmd = m.forces_to_manual_control(tau)
        assert not cmd.saturated
        assert max(abs(cmd.x), abs(cmd.y), abs(cmd.r)) <= 1000 and cmd.z == 500
        made = m.manual_control_to_forces(cmd.x, cmd.y, cmd.r)
        assert np.allclose(made, cmd.achieved)  # the prediction is the vehicle's side
        assert np.all(np.abs(made - tau) <= ROUND_TRIP), (tau, made)
    assert m.forces_to_manual_control(np.zeros(3)) == NEUTRAL
    assert NEUTRAL.normalised == (0.0, 0.0, 0.5, 0.0)


def test_each_stick_drives_its_own_axis():
    m = ArduSubMapping()
    fx, fy, mz = (m.manual_control_to_forces(*s) for s in ((400, 0, 0), (0, 400, 0), (0, 0, 400)))
    assert fx[0] > 10 and abs(fx[1]) < 1e-9 and abs(fx[2]) < 1e-9
    assert fy[1] > 10 and abs(fy[0]) < 1e-9 and abs(fy[2]) < 1e-9
    assert mz[2] > 1 and abs(mz[0]) < 1e-9 and abs(mz[1]) < 1e-9
    # the pilot gain scales the RC pulse: at gain 0.5 a stick gives half the pulse of gain 1
    half = ArduSubMapping(gain=0.5)
    assert np.allclose(half.normalised_inputs(400, 0, 0), m.normalised_inputs(200, 0, 0))


def test_the_mixer_delivers_less_than_the_free_allocation():
    m, peak = ArduSubMapping(), (40.0, 40.0, 10.0)
    free = bluerov2_heavy_thrusters().largest_box_scale(peak)
    through = m.largest_box_scale(peak)
    assert free == pytest.approx(1.62, abs=0.01)
    assert 0.85 < through < 0.93 < free  # the pulses of the mix sum to zero: no free null-space share
    assert m.delivers_box(np.multiply(peak, 0.8)) and not m.delivers_box(np.multiply(peak, 1.0))


def test_thrusters_in_another_order_are_refused():
    t = bluerov2_heavy_thrusters()
    swapped = ThrusterAllocation(
        directions=(t.directions[1], t.directions[0], *t.directions[2:]),
        positions=(t.positions[1], t.positions[0], *t.positions[2:]),
        lower=t.lower,
        upper=t.upper,
    )
    with pytest.raises(ParameterError, match="motors 1-4"):
        ArduSubMapping(thrusters=swapped)
    with pytest.raises(ParameterError, match="pilot gain"):
        ArduSubMapping(gain=1.5)
