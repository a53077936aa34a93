"""A law with more measurements in flight than the composed certificate analyses is refused, plainly.

Each measurement taken but not yet used is a state of the sampled loops' period map; a fast law
on an old measurement (1 kHz on a 0.5 s delay: 500 of them) would take hours to certify. Such a
problem is not evaluated: the certificate says why and which declared values it analyses, and
the advice's sample-time search never goes past them.
"""

from __future__ import annotations

import re
from dataclasses import replace

import pytest

from auv_hinf.certificate.deployed import deployed_problem
from auv_hinf.certificate.design_point import design_point
from auv_hinf.certificate.parts.composed import composed_start
from auv_hinf.composed.advice import shrunk
from auv_hinf.composed.certificate import MAX_DELAY_SAMPLES, certify_deployed
from auv_hinf.config.settings import config_from_dict
from auv_hinf.implementation.peak import in_flight
from tests.helpers import DEPLOYED


@pytest.fixture(scope="module")
def problem():
    cfg = config_from_dict(DEPLOYED, "deployed")
    point = design_point(cfg)
    return deployed_problem(cfg, point.mission, point.tube, point.offsets, point.gains, composed_start(point))


@pytest.mark.slow
@pytest.mark.parametrize(("h", "d"), [(0.001, 0.5), (0.002, 0.1), (0.004, 0.1)])
def test_too_many_measurements_in_flight_are_not_evaluated_and_the_reason_names_what_is(problem, h, d):
    assert in_flight(h, d) > MAX_DELAY_SAMPLES
    p = replace(problem, implementation=replace(problem.implementation, sample_time=h, delay=d))
    cert = certify_deployed(p)
    assert not cert.covers and cert.errors is None
    (why,) = cert.reasons
    assert "not evaluated" in why and f"{in_flight(h, d)} sample times" in why
    h_ok = float(re.search(r"sample_time >= ([0-9.e-]+) s", why).group(1))  # type: ignore[union-attr]
    d_ok = float(re.search(r"delay <= ([0-9.e-]+) s", why).group(1))  # type: ignore[union-attr]
    assert in_flight(h_ok * (1 + 1e-3), d) <= MAX_DELAY_SAMPLES  # the values it names are analysed
    assert in_flight(h, d_ok * (1 - 1e-3)) <= MAX_DELAY_SAMPLES


def test_the_sample_time_advice_stays_within_the_measurements_it_analyses(problem):
    p = replace(problem, implementation=replace(problem.implementation, sample_time=0.1, delay=0.5))
    for scale in (1.0, 0.5, 0.1, 0.0):
        q = shrunk(p, "sample_time", scale).implementation
        assert in_flight(q.sample_time, q.delay) <= MAX_DELAY_SAMPLES
        assert q.sample_time <= 0.1
