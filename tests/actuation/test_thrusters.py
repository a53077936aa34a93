"""Thruster allocation: the feasible body-force polytope, its box tests, saturation, and the BlueROV2 Heavy."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from auv_hinf.actuation.limits import vehicle_actuators
from auv_hinf.actuation.thrusters import (
    BENZON2022_THRUST,
    FORCE_TOLERANCE,
    T200_FORWARD_16V,
    T200_REVERSE_16V,
    ThrusterAllocation,
    bluerov2_heavy_thrusters,
    box_corners,
)
from auv_hinf.exceptions import AuvHinfError, ParameterError, SolverError
from auv_hinf.models.vehicle import PRESETS, bluerov2_heavy, preset

C = math.sqrt(0.5)
#: A 2-thruster layout whose matrix is easy by hand: a stern thruster pushing forward and a bow
#: thruster pushing to starboard.
TWO = ThrusterAllocation(
    directions=((1.0, 0.0), (0.0, 1.0)), positions=((-0.5, 0.2), (0.8, 0.0)), lower=(-3.0, -1.0), upper=(5.0, 2.0)
)
#: An unsymmetric, fully actuated 4-thruster layout (different limits per thruster).
SKEW = ThrusterAllocation(
    directions=((C, C), (1.0, 0.0), (0.0, 1.0), (-C, C)),
    positions=((0.4, -0.3), (-0.6, 0.1), (0.5, 0.05), (-0.3, -0.4)),
    lower=(-10.0, -6.0, -4.0, -8.0),
    upper=(12.0, 15.0, 7.0, 5.0),
)
#: A 5-thruster layout: two redundant directions, so saturate() is plain pseudo-inverse allocation.
FIVE = ThrusterAllocation(
    directions=((1.0, 0.0), (1.0, 0.0), (0.0, 1.0), (0.0, 1.0), (C, C)),
    positions=((-0.5, 0.3), (-0.5, -0.3), (0.6, 0.0), (-0.6, 0.0), (0.0, 0.4)),
    lower=(-4.0,) * 5,
    upper=(6.0,) * 5,
)
BLUE = bluerov2_heavy_thrusters()
LAYOUTS = {"skew": SKEW, "bluerov2": BLUE, "five": FIVE}


def sample_forces(alloc: ThrusterAllocation, rng: np.random.Generator, n: int) -> np.ndarray:
    """``n`` thruster-force vectors drawn uniformly in the limits, plus the box's vertices."""
    lo, hi = np.asarray(alloc.lower), np.asarray(alloc.upper)
    inside = lo + (hi - lo) * rng.random((n, alloc.count))
    vertices = rng.choice([0, 1], size=(n // 4, alloc.count))
    return np.vstack([inside, lo + (hi - lo) * vertices])


def close(a: np.ndarray, b: np.ndarray) -> bool:
    return bool(np.allclose(a, b, rtol=0.0, atol=1e-9))


def test_matrix_by_hand():
    # tau_psi = x f_y - y f_x: thruster 0 gives -0.2 N m per N, thruster 1 gives +0.8 N m per N.
    assert_allclose(TWO.matrix(), [[1.0, 0.0], [0.0, 1.0], [-0.2, 0.8]], atol=1e-15)
    assert_allclose(TWO.matrix() @ [2.0, -1.0], [2.0, -1.0, -1.2], atol=1e-15)


def test_two_thrusters_contains_exactly_their_plane():
    assert TWO.contains([2.0, -1.0, -1.2])
    assert not TWO.contains([2.0, -1.0, 0.0])  # off the plane T f spans
    assert not TWO.contains([5.5, 0.0, -1.1])  # on the plane, past the 5 N limit


@pytest.mark.parametrize("name", sorted(LAYOUTS))
def test_contains_every_sampled_image_and_rejects_far_points(name, rng):
    alloc = LAYOUTS[name]
    mat = alloc.matrix()
    for f in sample_forces(alloc, rng, 40):
        assert alloc.contains(mat @ f)
    # Beyond sum |T_kj| max(|lo_j|, |hi_j|) in a channel no allocation reaches.
    reach = np.abs(mat) @ np.maximum(np.abs(alloc.lower), np.abs(alloc.upper))
    for _ in range(20):
        direction = rng.normal(size=3)
        k = int(np.argmax(np.abs(direction)))
        far = direction / abs(direction[k]) * 1.01 * reach[k]
        assert not alloc.contains(far)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(LAYOUTS))
def test_contains_box_agrees_with_sampled_points(name, rng):
    alloc = LAYOUTS[name]
    limits = np.asarray(alloc.channel_limits())
    accepted = rejected = 0
    for _ in range(12):
        peak = limits * rng.uniform(0.05, 0.9, size=3)
        if alloc.contains_box(peak):
            accepted += 1
            for tau in peak * rng.uniform(-1.0, 1.0, size=(25, 3)):
                assert alloc.contains(tau)
        else:
            rejected += 1
            assert not all(alloc.contains(c) for c in box_corners(peak))
    assert accepted and rejected, (accepted, rejected)


@pytest.mark.parametrize("name", sorted(LAYOUTS))
def test_largest_box_scale_is_the_supremum(name, rng):
    alloc = LAYOUTS[name]
    for peak in (rng.uniform(1.0, 10.0, size=3), np.array([3.0, 0.0, 1.0])):
        s = alloc.largest_box_scale(peak)
        assert 0.0 < s < math.inf
        assert alloc.contains_box(peak * s * (1 - 1e-6))
        assert not alloc.contains_box(peak * s * (1 + 1e-4))
    assert alloc.largest_box_scale([0.0, 0.0, 0.0]) == math.inf


@pytest.mark.parametrize("name", sorted(LAYOUTS))
def test_channel_limits_are_the_largest_pure_pushes(name):
    alloc = LAYOUTS[name]
    for k, c in enumerate(alloc.channel_limits()):
        e = np.eye(3)[k]
        assert alloc.contains(c * (1 - 1e-6) * e) and alloc.contains(-c * (1 - 1e-6) * e)
        assert not (alloc.contains(c * (1 + 1e-4) * e) and alloc.contains(-c * (1 + 1e-4) * e))


@pytest.mark.parametrize("name", sorted(LAYOUTS))
def test_saturate_returns_deliverable_forces(name, rng):
    alloc = LAYOUTS[name]
    limits = np.asarray(alloc.channel_limits())
    tau = limits * rng.uniform(-3.0, 3.0, size=(4, 10, 3))  # vehicles x time, many beyond reach
    applied, active = alloc.saturate(tau)
    assert applied.shape == tau.shape and active.shape == tau.shape[:-1] and active.dtype == bool
    for t in applied.reshape(-1, 3):
        assert alloc.contains(t)
    big = alloc.saturate(10.0 * limits * np.eye(3))
    assert np.all(big[1])


@pytest.mark.parametrize("name", ["skew", "bluerov2"])
def test_exact_allocation_leaves_every_deliverable_command_unchanged(name, rng):
    alloc = LAYOUTS[name]
    assert alloc.allocation_is_exact()
    tau = sample_forces(alloc, rng, 200) @ alloc.matrix().T  # deliverable, up to the polytope's edges
    applied, active = alloc.saturate(tau)
    assert not np.any(active)
    assert_allclose(applied, tau, atol=1e-9)


def test_bluerov2_surge_beyond_plain_pseudo_inverse_is_delivered():
    # Plain pinv asks 120 / (4 c) = 42.4 N of reverse thrust from the front pair, past 40.2 N.
    tau = np.array([120.0, 0.0, 0.0])
    f_pinv = np.linalg.pinv(BLUE.matrix()) @ tau
    assert f_pinv.min() < -T200_REVERSE_16V
    applied, active = BLUE.saturate(tau)
    assert not active and close(applied, tau)


def test_plain_pseudo_inverse_layout_keeps_small_commands():
    assert not FIVE.allocation_is_exact()
    tau = 0.3 * np.asarray(FIVE.channel_limits()) * np.array([1.0, -1.0, 0.5])
    applied, active = FIVE.saturate(tau)
    assert not active and close(applied, tau)


def test_bluerov2_channel_limits():
    # Pure surge: front pair at -R, rear pair at +F, each 45 degrees off axis: sqrt(2) (F + R).
    surge = math.sqrt(2.0) * (T200_FORWARD_16V + T200_REVERSE_16V)
    # Pure yaw: every thruster on an arm of (0.156 + 0.111) / sqrt(2) m, two at +F and two at -R.
    yaw = 2.0 * (0.156 + 0.111) * C * (T200_FORWARD_16V + T200_REVERSE_16V)
    assert_allclose(BLUE.channel_limits(), (surge, surge, yaw), rtol=1e-7)
    assert_allclose(BLUE.channel_limits(), (129.7, 129.7, 34.6), atol=0.1)
    # With the symmetric thruster curve of von Benzon et al. (2022): about 86 N, 86 N, 23 N m.
    paper = bluerov2_heavy_thrusters(BENZON2022_THRUST, BENZON2022_THRUST).channel_limits()
    assert_allclose(paper, (86.0, 86.0, 23.0), atol=1.0)


def test_bluerov2_limits_do_not_hold_all_at_once():
    limits = np.asarray(BLUE.channel_limits())
    assert not BLUE.contains_box(limits)
    s = BLUE.largest_box_scale(limits)
    assert 0.2 < s < 1.0
    assert BLUE.contains_box(s * (1 - 1e-6) * limits)


def test_validation_messages_name_the_field():
    ok = {"directions": ((1.0, 0.0),), "positions": ((0.0, 0.0),), "lower": (-1.0,), "upper": (1.0,)}
    cases = {
        "positions": {"positions": ((0.0, 0.0), (1.0, 1.0))},
        "directions[0]": {"directions": ((1.0, 1.0),)},
        "lower[0]": {"lower": (2.0,), "upper": (1.0,)},
        "contain 0": {"lower": (0.5,), "upper": (1.0,)},
        "finite": {"upper": (math.inf,)},
        "shape (m, 2)": {"directions": ()},
    }
    for needle, change in cases.items():
        with pytest.raises(ParameterError, match=needle.replace("[", r"\[").replace("(", r"\(").replace(")", r"\)")):
            ThrusterAllocation(**{**ok, **change})
    with pytest.raises(ParameterError, match="peak"):
        BLUE.contains_box([1.0, -1.0, 1.0])
    with pytest.raises(ParameterError, match="tau"):
        BLUE.saturate(np.zeros((4, 2)))
    with pytest.raises(ParameterError, match="reverse"):
        bluerov2_heavy_thrusters(reverse=0.0)


def test_solver_error_is_a_package_error():
    assert issubclass(SolverError, AuvHinfError) and issubclass(SolverError, RuntimeError)
    assert FORCE_TOLERANCE < 1e-3


def test_bluerov2_heavy_parameters():
    p = bluerov2_heavy()
    m, izz = 13.5, 0.37
    assert p.m11 == pytest.approx(m + 6.36) and p.m22 == pytest.approx(m + 7.12)
    assert p.m33 == pytest.approx(izz + 0.22)
    assert (p.d11_lin, p.d11_quad, p.d22_lin, p.d22_quad, p.d33_lin, p.d33_quad) == (13.7, 141.0, 0.0, 217.0, 0.0, 1.5)
    assert PRESETS["bluerov2-heavy"] is bluerov2_heavy and preset("bluerov2-heavy") == p
    assert p.name == "bluerov2-heavy"


def test_a_box_far_beyond_the_thrusters_is_used_infinitely_not_a_division_by_zero():
    """A review's vehicle with 1e12 kg/s of damping asked for forces whose largest deliverable scale the LP
    returns as -0.0: the utilisation is then infinite and the binding names the thrusters (was ZeroDivisionError)."""
    act = vehicle_actuators("bluerov2-heavy")
    big = (1e14, 1e14, 1e14)
    assert act.thrusters is not None and act.thrusters.largest_box_scale(big) <= 0.0
    assert act.utilisation(big) == math.inf and act.binding(big) == ("thrusters", math.inf)
    assert not act.admits(big)
    finite = (1e6, 1e6, 1e6)  # still a number where the scale is positive: its inverse
    assert act.utilisation(finite) == pytest.approx(1.0 / act.thrusters.largest_box_scale(finite))
