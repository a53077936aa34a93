"""Sampled, delayed, noisy runs against the implementation certificate (simulation against the bound)."""

from __future__ import annotations

import numpy as np
import pytest

from auv_hinf.certificate.run_plan import plan_run, run_report
from auv_hinf.config.settings import config_from_dict
from auv_hinf.simulation.engine import simulate
from tests.helpers import BLUEROV_SLOW

CHANNELS = ("position_error", "velocity_error", "heading_error", "yaw_rate_error")


def _config(sample_time: float, delay: float, noise: float, **impl: object) -> dict:
    n = {"position": noise, "velocity": noise, "heading": noise, "yaw_rate": noise}
    return {
        **BLUEROV_SLOW,
        "simulation": {"horizon": 20.0, "seed": 11},
        "implementation": {"sample_time": sample_time, "delay": delay, "noise": n, **impl},
    }


@pytest.mark.parametrize(
    ("sample_time", "delay", "varying"),
    [
        pytest.param(0.01, 0.0, False, marks=pytest.mark.slow),
        pytest.param(0.008, 0.004, True, marks=pytest.mark.slow),
        pytest.param(0.005, 0.005, False, marks=pytest.mark.slow),
    ],
)
def test_covered_runs_stay_inside_the_certified_bounds(sample_time, delay, varying):
    cfg = config_from_dict(_config(sample_time, delay, 1e-3, varying_delay=varying))
    plan = plan_run(cfg)
    # the deployed loop's certificate covers: the composed one (which then supersedes the
    # implementation certificate of the nominal plant), or that one
    covering = {c.part for c in plan.checks if c.covers}
    assert plan.covered and covering & {"composed", "implementation"}, plan.notes
    report = run_report(plan, simulate(plan.scenario))
    certified, measured = report["certified_errors"], report["measured_errors"]
    assert certified is not None and report["certificate_covers_run"]
    for ch in CHANNELS:
        assert measured[ch] <= certified[ch], (ch, measured[ch], certified[ch])
    assert report["implementation"]["sample_time"] == sample_time
    assert report["implementation"]["varying_delay"] is varying


@pytest.mark.slow
def test_an_uncovered_implementation_is_reported_and_has_no_bounds():
    cfg = config_from_dict(_config(0.1, 0.1, 0.05))
    plan = plan_run(cfg)
    assert not plan.covered and any(n.startswith("implementation not covered") for n in plan.notes)
    assert any(n.startswith("composed certificate") for n in plan.notes)
    report = run_report(plan, simulate(plan.scenario))
    assert report["certified_errors"] is None and not report["certificate_covers_run"]
    assert "certified_errors" in report["null_reasons"]


@pytest.mark.slow
def test_a_sample_time_beyond_the_exact_limit_is_never_covered():
    cfg = config_from_dict(_config(1.0, 0.0, 0.0))
    plan = plan_run(cfg, horizon=10.0)
    c = plan.implementation.certificate if plan.implementation is not None else None
    assert c is not None and c.exact_max_sample_time < 1.0
    assert not plan.covered
    assert np.isfinite(c.max_sample_time) and c.max_sample_time < c.exact_max_sample_time
