"""Robust campaigns: starts inside the robust invariant sets, box vertices first, robust bounds."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from auv_hinf.campaign.report import summarize
from auv_hinf.campaign.runner import run_campaign
from auv_hinf.campaign.runs import initial_state, sample_run
from auv_hinf.campaign.setup import COEFFICIENTS, prepare
from auv_hinf.certificate.design_point import design_point
from auv_hinf.certificate.parts.robust import check_robust_run
from auv_hinf.config.settings import SimulationConfig
from tests.helpers import fully_actuated

RUNS, HORIZON, SEED = 12, 12.0, 5


@pytest.fixture(scope="module")
def remus_setup():
    """The robust remus-line preset prepared for a campaign (about 5 s): its tests are marked slow."""
    return prepare(fully_actuated("remus-line"), seed=SEED, horizon=HORIZON)[0]


@pytest.mark.slow
def test_vertex_runs_enumerate_the_box_corners(remus_setup) -> None:
    s = remus_setup
    # a vertex per corner of the coefficients the box moves (the REMUS's d11_lin is 0: its range moves nothing)
    cfg = fully_actuated("remus-line")
    moving = [k for k, _ in cfg.uncertainty.box if float(getattr(cfg.vehicle, k)) != 0.0]
    assert len(moving) == 8 and "d11_lin" not in moving
    assert s.robust is not None and s.robust.vertices == 2 ** len(moving)
    corners = set()
    for i in range(0, 2 * s.robust.vertices, 2):  # every other run is a vertex
        x = sample_run(s, i)
        assert np.all((x.multipliers == s.box[:, 0]) | (x.multipliers == s.box[:, 1]))
        assert np.hypot(*x.current) == pytest.approx(design_point(fully_actuated("remus-line")).current, rel=1e-12)
        corners.add(tuple(x.multipliers))
    assert len(corners) == 2 ** len(moving)
    for i in (1, 3, 2 * s.robust.vertices + 2):  # odd runs, and every run after the vertices are used
        inner = sample_run(s, i)
        ranged = s.box[:, 0] < s.box[:, 1]
        m = inner.multipliers
        assert np.all((m[ranged] > s.box[ranged, 0]) & (m[ranged] < s.box[ranged, 1]))
        assert np.all(m[~ranged] == s.box[~ranged, 0])
    assert s.robust.vertex_runs(200) == 100 and s.robust.vertex_runs(10**6) == 2 ** len(moving)


@pytest.mark.slow
@pytest.mark.parametrize("index", [0, 300, 511, 512, 2000])
def test_sampled_starts_are_covered_by_the_robust_certificate(remus_setup, index) -> None:
    """An independent path: the state is rebuilt into a configuration and checked by check_robust_run."""
    s = remus_setup
    x = sample_run(s, index)
    init = initial_state(s, x)
    base = fully_actuated("remus-line")
    cfg = replace(
        base,
        simulation=SimulationConfig(
            horizon=HORIZON,
            start="paper",
            initial=tuple(map(tuple, init.tolist())),
            current=(float(x.current[0]), float(x.current[1])),
            plant=dict(zip(COEFFICIENTS, x.multipliers.tolist())),
        ),
    )
    verdict = check_robust_run(design_point(cfg), s.reference, init)
    assert verdict.covered, verdict.reason


@pytest.mark.slow
def test_starts_fill_the_certified_sets(remus_setup) -> None:
    """Uniform in volume: some starts lie near the boundary of the 4-D position ellipsoid."""
    s, rob = remus_setup, remus_setup.robust
    rng = np.random.default_rng(0)
    cur = np.array([0.1, -0.1])
    e, de, ep, dep = rob.sample_errors(rng, 4000, cur)
    et = e - rob.certificate.equilibrium_shift(cur)
    p = rob.position
    v = p[0, 0] * (et**2).sum(1) + 2 * p[0, 1] * (et * de).sum(1) + p[1, 1] * (de**2).sum(1)
    assert v.max() <= rob.position_level**2 and v.max() >= 0.95 * rob.position_level**2
    assert rob.inside(e, de, ep, dep, cur) and not rob.inside(2 * e, 2 * de, ep, dep, cur)
    assert s.n == 3


@pytest.mark.slow
def test_robust_campaign_stays_inside_the_robust_bounds() -> None:
    camp = run_campaign(fully_actuated("remus-line"), RUNS, seed=SEED, horizon=HORIZON, chunk=5)
    t = camp.table
    assert t["inside_bounds"].notna().all() and t["inside_bounds"].all()
    summary = summarize(camp)
    # every other run is a box vertex, interleaved with interior plants; the summary says so
    assert summary["certificate"] == "robust" and summary["box_vertex_runs"] == (RUNS + 1) // 2 and summary["ok"]
    assert f"{(RUNS + 1) // 2} at box vertices" in summary["composition"]
    bounds = summary["region_error_bounds"]
    for kind in ("position", "velocity", "heading", "yaw_rate"):
        assert (t[f"max_{kind}_error"] <= bounds[kind] * (1 + 1e-6)).all()
        assert (t[f"bound_{kind}_error"] == bounds[kind]).all()
    # the errors contract: late errors are well inside the bound (decay rate ~0.95 1/s)
    assert (t["tail_position_error"] < t["max_position_error"]).all()
    assert summary["worst_tail_position_ratio"] < 1.0
    assert isinstance(t, pd.DataFrame)
