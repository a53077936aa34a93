"""The exact nominal limits of the deployed loop's timing, against an independent closed form.

:func:`auv_hinf.composed.reach.reach` finds where the composed certificate's nominal loops lose
stability by their period maps. A position axis of the controller's own model with no box is the
double integrator with drag ``e'' = a0 e' + u`` under ``u = -k1 e - (alpha - c0) e'``, held and
delayed: :func:`auv_hinf.implementation.limits.exact_limit` computes its first unstable period
from a separate discretisation, re-checked with python-control. Beyond the exact limit the
composed certificate never covers.
"""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from auv_hinf.composed.certificate import DeployedProblem, certify_deployed
from auv_hinf.composed.loops import Errors, MissionBounds, OperatingBox, Plant, position_axes
from auv_hinf.composed.reach import LIMIT_RTOL, model_loops, reach
from auv_hinf.implementation.limits import exact_limit
from auv_hinf.implementation.model import Implementation
from auv_hinf.implementation.peak import period_radius
from auv_hinf.law.gains import Gains
from auv_hinf.models.envelope import Envelope
from auv_hinf.models.vehicle import bluerov2_heavy
from auv_hinf.robust.box import ParameterBox


def _problem(h: float, d: float, gains: Gains, speed: float = 0.4) -> DeployedProblem:
    mdl = bluerov2_heavy()
    return DeployedProblem(
        Plant(mdl, ParameterBox.from_ranges(mdl, ())),
        MissionBounds((speed, speed), 0.0, 0.0, 0.0, 0.0, 0.0),
        Envelope((-0.5, 1.0), (-0.5, 0.5), (-0.5, 0.5)),
        Implementation(h, d),
        gains,
        Errors(0.0, 0.0, 0.0, 0.0),
    )


@pytest.mark.parametrize(
    ("h", "d", "gains"),
    [
        pytest.param(0.1, 0.1, Gains(2.5, 0.78125, (4.0, 3.0)), marks=pytest.mark.slow),
        pytest.param(0.05, 0.2, Gains(1.5, 0.5625, (1.0, 1.5)), marks=pytest.mark.slow),
        (0.2, 0.0, Gains(4.0, 4.0, (2.25, 2.25))),
    ],
)
def test_the_surge_limit_is_the_closed_form_of_the_held_delayed_double_integrator(h, d, gains):
    p = _problem(h, d, gains)
    op = OperatingBox.of(p.mission, 0.0, Errors(0.0, 0.0, 0.0, 0.0))
    surge, _ = position_axes(p.plant, op, 0.0, True)
    a0, c0, lam0 = surge.nominal()
    assert lam0 == pytest.approx(1.0)
    # the surge axis's limit alone: scan the first loop of model_loops (the surge loop) the same way
    r = reach(p)
    closed = exact_limit(a0, gains.k1, gains.alpha - c0, d)
    surge_limit = _first_unstable_of_surge(p, d)
    assert surge_limit == pytest.approx(closed, rel=5 * LIMIT_RTOL)
    # the reported limit is that of the first loop to fail: never above the surge's own
    assert r.exact_max_sample_time <= surge_limit * (1 + 2 * LIMIT_RTOL)
    assert r.tightness == pytest.approx(h / r.exact_max_sample_time)


def _first_unstable_of_surge(p: DeployedProblem, d: float) -> float:
    h = p.implementation.sample_time
    while period_radius(model_loops(p, h, d)[0]) < 1.0:
        h *= 1.1
    lo, hi = h / 1.1, h
    while hi / lo > 1 + LIMIT_RTOL:
        mid = math.sqrt(lo * hi)
        lo, hi = (mid, hi) if period_radius(model_loops(p, mid, d)[0]) < 1.0 else (lo, mid)
    return hi


def test_beyond_the_exact_limits_the_composed_certificate_never_covers():
    p = _problem(0.1, 0.1, Gains(2.5, 0.78125, (4.0, 3.0)))
    assert certify_deployed(p).covers
    r = reach(p)
    assert 0.1 < r.exact_max_sample_time < math.inf and 0.1 < r.exact_max_delay < math.inf
    late = replace(p.implementation, sample_time=r.exact_max_sample_time * 1.01)
    slow = replace(p.implementation, delay=r.exact_max_delay * 1.01)
    for impl in (late, slow):
        assert not certify_deployed(replace(p, implementation=impl)).covers
        h, d = impl.sample_time, impl.delay
        assert any(period_radius(loop) >= 1.0 for loop in model_loops(p, h, d))
