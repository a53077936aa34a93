"""Campaign commanded forces: streamed peaks, the certified-force check, the summary's counts."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from auv_hinf.actuation.limits import CHANNELS, Actuators
from auv_hinf.campaign.report import force_summary, passed, summarize, write_outputs
from auv_hinf.campaign.runner import Campaign, run_campaign
from auv_hinf.campaign.runs import FORCE_COLUMNS, run_scenario, sample_run
from auv_hinf.campaign.setup import prepare
from auv_hinf.config.presets import preset_config
from auv_hinf.simulation.engine import integrate_batch, simulate_batch
from auv_hinf.simulation.metrics import ErrorSink
from auv_hinf.simulation.scenario import ScenarioBatch
from tests.helpers import fully_actuated

RUNS, HORIZON, SEED = 24, 15.0, 11
#: Columns every campaign table gains for the commanded forces.
NEW_COLUMNS = (*FORCE_COLUMNS, "within_certified_force", "saturated_fraction")
#: Paper-triangle limits below its unlimited certified thrust (about 1476 N, 578 N, 320 N m):
#: the certified start region shrinks until its thrust bound fits them.
TIGHT = Actuators(1400.0, 400.0, 250.0)


@pytest.fixture(scope="module")
def campaign() -> Campaign:
    return run_campaign(preset_config("paper-triangle"), RUNS, seed=SEED, chunk=10, horizon=HORIZON)


@pytest.mark.slow
def test_every_certified_run_stays_within_its_certified_force(campaign: Campaign) -> None:
    t = campaign.table
    for col in NEW_COLUMNS:
        assert col in t.columns, col
    # every run of the paper triangle commands force on every channel (it turns and sways)
    assert (t[list(FORCE_COLUMNS)] > 0).all().all()
    assert np.isfinite(t[list(FORCE_COLUMNS)].to_numpy()).all()
    assert t["within_certified_force"].dtype == "boolean"
    certified = t["inside_bounds"].notna()
    assert certified.all(), "every nominal paper-triangle run is covered by the nominal certificate"
    assert (t["within_certified_force"].notna() == certified).all()
    assert t.loc[certified, "within_certified_force"].all()
    bound = campaign.certificate.thrust.as_tuple()
    for col, b in zip(FORCE_COLUMNS, bound):
        assert (t[col] <= b).all(), (col, t[col].max(), b)
    # no actuators declared: nothing saturates
    assert (t["saturated_fraction"] == 0.0).all()


@pytest.mark.slow
def test_the_summary_counts_the_runs_over_their_certified_force(campaign: Campaign, tmp_path: Path) -> None:
    summary = write_outputs(campaign, tmp_path)
    assert summary["counts"]["exceeded_certified_force"] == 0
    assert summary["counts"]["saturated"] == 0
    forces = summary["forces"]
    assert forces["within_certified_force"] == RUNS and forces["exceeded_certified_force"] == 0
    assert forces["certified_thrust"] == campaign.certificate.thrust.to_dict()
    assert forces["actuator_limits"] is None
    t = campaign.table
    for c, col in zip(CHANNELS, FORCE_COLUMNS):
        assert forces["max_commanded"][c] == pytest.approx(t[col].max(), rel=0, abs=0)
        assert 0.0 < forces["worst_ratio"][c] <= 1.0
    on_disk = json.loads((tmp_path / "summary.json").read_text())
    assert on_disk["counts"]["exceeded_certified_force"] == 0 and on_disk["forces"]["exceeded_certified_force"] == 0
    table = pd.read_parquet(tmp_path / "runs.parquet")
    for col in NEW_COLUMNS:
        assert col in table.columns, col
    assert table["within_certified_force"].all()


@pytest.mark.slow
def test_a_run_over_its_certified_force_fails(campaign: Campaign) -> None:
    t = campaign.table.copy()
    assert passed(t).all()
    t.loc[3, "within_certified_force"] = False
    verdict = passed(t)
    assert not verdict[3] and verdict.drop(index=3).all()
    summary = summarize(replace(campaign, table=t))
    assert summary["counts"]["exceeded_certified_force"] == 1 and not summary["ok"]


@pytest.mark.slow
def test_streamed_peaks_equal_the_stored_post_processing() -> None:
    """Independent path: simulate_batch's commanded_peak and saturated flags from stored samples."""
    setup, cert = prepare(preset_config("paper-triangle"), seed=SEED, horizon=10.0)
    # a sway limit the commands exceed some of the time (a 5000 N or N m limit never binds)
    law = replace(setup.law, actuators=Actuators(5000.0, 100.0, 5000.0))
    batch = ScenarioBatch(tuple(replace(run_scenario(setup, i, sample_run(setup, i)), law=law) for i in range(4)))
    sink = ErrorSink(
        batch.source,
        batch.scenarios[0].times,
        batch.current,
        setup.n,
        cert.position.matrix,
        cert.heading.matrix,
        law=law,
    )
    integrate_batch(batch, sink=sink)
    met = sink.result()
    results = simulate_batch(batch)
    for k, res in enumerate(results):
        np.testing.assert_allclose(met.commanded_peak[k], res.commanded_peak, rtol=1e-12)
        assert met.saturated_fraction[k] == pytest.approx(float(res.saturated.mean()), abs=0)
    assert met.saturated_fraction.min() == 0.0 and 0.0 < met.saturated_fraction.max() < 1.0
    # the same sink without a law keeps no forces
    plain = ErrorSink(
        batch.source, batch.scenarios[0].times, batch.current, setup.n, cert.position.matrix, cert.heading.matrix
    )
    integrate_batch(batch, sink=plain)
    assert np.isnan(plain.result().commanded_peak).all() and np.isnan(plain.result().saturated_fraction).all()


@pytest.mark.slow
def test_declared_actuators_bound_the_certified_force_and_are_reported() -> None:
    cfg = replace(preset_config("paper-triangle"), actuators=TIGHT)
    camp = run_campaign(cfg, 12, seed=SEED, horizon=HORIZON)
    t = camp.table
    bound = camp.certificate.thrust.as_tuple()
    assert TIGHT.admits(bound)
    assert t["within_certified_force"].notna().all() and t["within_certified_force"].all()
    assert (t["saturated_fraction"] == 0.0).all(), "a certified run never reaches its limits"
    forces = force_summary(camp)
    assert forces["actuator_limits"] == TIGHT.to_dict()
    assert forces["exceeded_certified_force"] == 0
    assert all(forces["max_commanded"][c] <= lim for c, lim in zip(CHANNELS, TIGHT.limits()))


@pytest.mark.slow
def test_robust_runs_stay_within_the_robust_thrust_bound() -> None:
    camp = run_campaign(fully_actuated("remus-line"), 12, seed=5, horizon=12.0, chunk=6)
    t = camp.table
    rob = camp.setup.robust
    assert rob is not None and rob.certificate.thrust is not None
    assert t["within_certified_force"].notna().all() and t["within_certified_force"].all()
    for col, b in zip(FORCE_COLUMNS, rob.thrust):
        assert (t[col] > 0).all() and (t[col] <= b).all() and math.isfinite(b)
    forces = summarize(camp)["forces"]
    assert forces["certified_thrust"] == rob.certificate.thrust.to_dict()
    assert forces["exceeded_certified_force"] == 0
