"""Campaigns of a sampled implementation are checked against the composed certificate, and only it.

The continuous certificates are about the continuous law: a sampled, delayed, noisy run is
covered by the composed certificate or by none. A covered deployed fleet (a small box, a small
current, noise at a quarter of the deployed bounds) is drawn from the composed certificate's
start set, at box vertices with the current at its full speed, with every noise pattern in turn,
and every run stays inside its bounds and force bound. A fleet it does not cover has no run
counted as covered, and the summary says why.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from auv_hinf.campaign.report import SAMPLED_NOTE, summarize
from auv_hinf.campaign.runner import run_campaign
from auv_hinf.campaign.runs import sample_run
from auv_hinf.campaign.setup import prepare
from auv_hinf.certificate.design_point import design_point
from auv_hinf.certificate.parts.composed import composed_summary
from auv_hinf.composed.certificate import certify_deployed
from auv_hinf.config.settings import config_from_dict
from tests.helpers import DEPLOYED_BOXED as COVERED


@pytest.mark.slow
def test_a_covered_deployed_fleet_is_drawn_from_and_checked_against_the_composed_certificate():
    cfg = config_from_dict(COVERED, "covered")
    setup, _ = prepare(cfg, seed=3)
    comp = setup.composed
    assert comp is not None and setup.checked is comp and setup.robust is None
    # the start set is itself certified: the certificate the runs are checked against covers it
    point = design_point(cfg)
    problem = replace(composed_summary(point, search=False).problem, start=comp.start)
    again = certify_deployed(problem)
    assert again.covers and np.allclose(comp.bounds, again.errors.as_array()[:4])
    # every sampled start lies in the start set (water-relative velocity: the ground one less the current)
    for i in range(8):
        x = sample_run(setup, i)
        e, de, epsi, depsi = x.errors
        assert np.all(np.linalg.norm(e, axis=1) <= comp.start.position * (1 + 1e-12))
        assert np.all(np.linalg.norm(de - x.current, axis=1) <= comp.start.velocity * (1 + 1e-12) + 1e-15)
        assert np.all(np.abs(epsi) <= comp.start.heading) and np.all(np.abs(depsi) <= comp.start.yaw_rate)
    camp = run_campaign(cfg, 6, seed=3, horizon=20.0)
    s = summarize(camp)
    assert s["certificate"] == "composed" and s["box_vertex_runs"] == 3
    assert s["counts"]["certificate_applies"] == 6 and s["counts"]["inside_bounds"] == 6, s
    assert s["forces"]["exceeded_certified_force"] == 0 and s["ok"]
    assert set(camp.table["noise_pattern"]) >= {"uniform", "bang-bang", "bias"}
    # not vacuous: the runs reach a sizeable share of the force bound (the drag at 0.4 m/s)
    assert s["forces"]["worst_ratio"]["force_x"] > 0.5


@pytest.mark.slow
def test_a_sampled_fleet_the_composed_certificate_does_not_cover_has_no_covered_run():
    data = {**COVERED, "implementation": {**COVERED["implementation"], "noise": {"position": 0.5}}}
    cfg = config_from_dict(data, "uncovered")
    camp = run_campaign(cfg, 2, seed=0, horizon=5.0)
    s = summarize(camp)
    assert camp.setup.composed is None and s["counts"]["certificate_applies"] == 0
    assert camp.table["inside_bounds"].isna().all()
    assert any(SAMPLED_NOTE in n for n in s["notes"]) and "composed" in camp.setup.robust_reason


@pytest.mark.slow
def test_the_campaigns_start_set_keeps_the_separation_that_certify_requires():
    """Regression: a larger start set whose bound broke ``min_separation`` was chosen, refusing every run.

    ``certify`` judges the on-slot start; the campaign grows the start set from there. With a
    ``min_separation`` that the on-slot bound keeps and a larger start set's bound breaks, the
    campaign takes a start set whose bound keeps it (down to the on-slot one), not the larger one.
    """
    from auv_hinf.campaign.composed_start import composed_start
    from auv_hinf.campaign.starts import declared_rows
    from auv_hinf.certificate.parts.separation import separation_refusal, separation_with
    from auv_hinf.composed.loops import Errors

    base = {**COVERED, "uncertainty": {}, "disturbance": {}}
    reference = Errors(0.5, 0.2, 0.1, 0.1)
    loose = design_point(config_from_dict(base, "loose"))
    wide, why = composed_start(loose, declared_rows(np.ones((9, 2))), reference)
    on_slot = certify_deployed(composed_summary(loose, search=False).problem)
    assert wide is not None and why is None and wide.scale > 0.0 and on_slot.covers
    b_wide, b_slot = float(wide.bounds[0]), on_slot.errors.position
    assert b_wide > b_slot
    # a separation between the two: kept by the on-slot bound, broken by the larger start set's
    sep = 0.5 * (separation_with(loose, b_slot).certified + separation_with(loose, b_wide).certified)
    tight = design_point(config_from_dict({**base, "formation": {**base["formation"], "min_separation": sep}}, "t"))
    assert separation_refusal(tight, b_slot) is None and separation_refusal(tight, b_wide) is not None
    got, why = composed_start(tight, declared_rows(np.ones((9, 2))), reference)
    assert got is not None and why is None
    assert got.scale < wide.scale and separation_refusal(tight, float(got.bounds[0])) is None
