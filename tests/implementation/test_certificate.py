"""The implementation certificate: limits against the exact reference, verdicts, bounds."""

from __future__ import annotations

import math

import pytest

from auv_hinf.certificate.assembly import certify
from auv_hinf.certificate.design_point import design_point
from auv_hinf.certificate.parts.closed_loop import closed_loop_for
from auv_hinf.certificate.parts.implementation import implementation_problem, start_errors
from auv_hinf.config.presets import preset_config
from auv_hinf.config.settings import config_from_dict
from auv_hinf.implementation.model import Implementation, MeasurementNoise
from auv_hinf.implementation.sampled_data import certify_implementation, lag_limits
from auv_hinf.mission.margins import ErrorBounds
from tests.helpers import BLUEROV_SLOW

SMALL_NOISE = MeasurementNoise(0.001, 0.001, 0.001, 0.001)


def _problem(cfg):
    point = design_point(cfg)
    return implementation_problem(point, closed_loop_for(point)), start_errors(point)


@pytest.fixture(scope="module")
def slow():
    return _problem(config_from_dict(BLUEROV_SLOW))


def test_a_fast_small_noise_implementation_is_covered_with_consistent_bounds(slow):
    prob, start = slow
    cert = certify_implementation(prob, Implementation(0.01, 0.0, noise=SMALL_NOISE), start)
    assert cert.covers, cert.reasons
    b, u = cert.bounds, cert.ultimate
    assert b is not None and u is not None
    for name in ("position", "velocity", "heading", "yaw_rate"):
        assert 0.0 < getattr(u, name) <= getattr(b, name)
    assert cert.thrust is not None and prob.actuators is not None and prob.actuators.admits(cert.thrust.as_tuple())
    assert 0 < cert.decay_rate


def test_more_noise_or_slower_sampling_never_tightens_the_bounds(slow):
    prob, start = slow
    base = certify_implementation(prob, Implementation(0.01, 0.0, noise=SMALL_NOISE), start)
    noisier = certify_implementation(
        prob, Implementation(0.01, 0.0, noise=MeasurementNoise(0.002, 0.002, 0.002, 0.002)), start
    )
    assert base.bounds is not None
    if noisier.covers:
        assert noisier.bounds is not None and noisier.ultimate is not None and base.ultimate is not None
        assert noisier.ultimate.position >= base.ultimate.position


def test_a_sample_time_above_the_exact_limit_is_not_covered(slow):
    prob, start = slow
    limits = lag_limits(prob.loops, prob.nominal_dampings, 0.0)
    assert limits.lag <= limits.exact_sample_time
    cert = certify_implementation(prob, Implementation(1.05 * limits.exact_sample_time, 0.0), start)
    assert not cert.covers and "exceeds the certified" in cert.reasons[0]
    assert cert.max_sample_time <= cert.exact_max_sample_time


@pytest.mark.parametrize(
    "preset",
    [
        "paper-triangle",
        pytest.param("bluerov2-line", marks=pytest.mark.slow),
        pytest.param("remus-line", marks=pytest.mark.slow),
    ],
)
def test_presets_at_10_hz_with_delay_say_whether_covered(preset):
    cfg = preset_config(preset)
    impl = Implementation(0.1, 0.1, noise=MeasurementNoise(0.05, 0.02, 0.01, 0.005))
    cert = certify(config_from_dict({**cfg.to_toml_dict(), "implementation": impl.to_dict()}))
    d = cert.to_dict()["implementation"]
    for key in (
        "sample_time",
        "delay",
        "noise",
        "max_sample_time",
        "max_delay",
        "exact_max_sample_time",
        "decay_rate",
        "ultimate_bounds",
        "covers",
    ):
        assert key in d
    assert d["sample_time"] == 0.1 and d["delay"] == 0.1
    assert d["max_sample_time"] <= (d["exact_max_sample_time"] or math.inf)
    if not d["covers"]:
        assert not cert.certified and any("implementation not covered" in r for r in cert.reasons)


def test_the_continuous_default_reports_limits_and_the_continuous_verdict():
    cert = certify(preset_config("paper-triangle"))
    d = cert.to_dict()["implementation"]
    assert d["continuous"] and d["covers"] == cert.certified
    assert 0.3 * d["exact_max_sample_time"] <= d["max_sample_time"] <= d["exact_max_sample_time"]
    assert d["tightness"] == pytest.approx(d["max_sample_time"] / d["exact_max_sample_time"])


@pytest.mark.slow
def test_the_largest_covered_sample_time_is_itself_covered():
    cfg = config_from_dict({**BLUEROV_SLOW, "implementation": {"sample_time": 0.2, "noise": SMALL_NOISE.to_dict()}})
    cert = certify(cfg)
    impl = cert.implementation
    assert impl is not None and not impl.covers
    h = impl.covered_sample_time
    assert h is not None and 0 < h < 0.2
    again = certify(
        config_from_dict({**BLUEROV_SLOW, "implementation": {"sample_time": h, "noise": SMALL_NOISE.to_dict()}})
    )
    assert again.implementation is not None and again.implementation.covers
    assert ErrorBounds(0, 0, 0, 0) == start_errors(design_point(cfg))


@pytest.mark.parametrize("h", [1e-12, pytest.param(1e-6, marks=pytest.mark.slow)])
def test_tiny_sample_times_are_certified_like_fast_ones(slow, h):
    prob, start = slow
    cert = certify_implementation(prob, Implementation(h, 0.0, noise=SMALL_NOISE), start)
    fast = certify_implementation(prob, Implementation(1e-3, 0.0, noise=SMALL_NOISE), start)
    assert cert.covers == fast.covers and math.isfinite(cert.max_sample_time)
