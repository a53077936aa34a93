"""Campaigns of the guidance cascade: box vertices first, reproducible runs, a summary that is the table's worst."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from auv_hinf.campaign.guidance import run_guidance_campaign, run_inputs
from auv_hinf.campaign.setup import COEFFICIENTS, box_multipliers, scaled_plant
from auv_hinf.campaign.starts import CORNER_PERIOD
from auv_hinf.certificate.design_point import design_point
from auv_hinf.certificate.parts.guidance import guidance_certificate
from auv_hinf.certificate.run_plan import guidance_run
from auv_hinf.cli.main import main
from auv_hinf.config.presets import preset_config
from auv_hinf.config.settings import DisturbanceConfig, FormationConfig, UncertaintyConfig
from auv_hinf.exceptions import ConfigError, Interrupted, ParameterError

#: Runs of 40 s: long enough for the cascade to turn the start into the current, short for CI.
HORIZON = 40.0


def survey(n: int = 3) -> FormationConfig:
    """``remus-survey-ilos`` cut to ``n`` vehicles (the first ``n - 1`` Jacobi vectors of its shape)."""
    cfg = preset_config("remus-survey-ilos")
    return replace(cfg, n=n, shape=cfg.shape[: n - 1])


def test_vertex_runs_come_first_at_the_box_corners_with_the_full_current():
    cfg = preset_config("remus-survey-ilos")
    box = box_multipliers(cfg)
    speed = cfg.disturbance.current_speed
    seen = set()
    for i in range(40):
        vertex, mult, current = run_inputs(cfg, 7, i)
        assert np.all(mult >= box[:, 0]) and np.all(mult <= box[:, 1])
        if i % CORNER_PERIOD == 0:
            assert vertex == i // CORNER_PERIOD
            assert np.all((mult == box[:, 0]) | (mult == box[:, 1]))
            assert np.hypot(*current) == pytest.approx(speed, rel=1e-12)
            seen.add(tuple(mult))
        else:
            assert vertex == -1 and np.hypot(*current) <= speed * (1 + 1e-12)
        again = run_inputs(cfg, 7, i)  # a run depends on (seed, index) alone
        assert again[0] == vertex and np.array_equal(again[1], mult) and np.array_equal(again[2], current)
    assert len(seen) == 20  # distinct corners


def test_without_a_declared_current_every_run_is_in_the_simulation_current():
    cfg = replace(preset_config("remus-survey-ilos"), disturbance=DisturbanceConfig())
    for i in range(4):
        assert np.array_equal(run_inputs(cfg, 0, i)[2], np.asarray(cfg.simulation.current))


@pytest.mark.slow
def test_rows_are_the_runs_and_the_summary_is_their_worst():
    cfg = survey()
    camp = run_guidance_campaign(cfg, 3, seed=3, horizon=HORIZON)
    t = camp.table
    assert list(t["run"]) == [0, 1, 2] and list(t["vertex"] >= 0) == [True, False, True]
    row = t.iloc[1]
    _, mult, current = run_inputs(cfg, 3, 1)
    assert np.array_equal(row[list(COEFFICIENTS)].to_numpy(float), mult)
    rep = guidance_run(cfg, HORIZON, plant=scaled_plant(cfg.vehicle, mult), current=tuple(current)).report()
    assert row["cross_track"] == rep["measured_errors"]["cross_track"]
    assert row["rudder"] == rep["commanded_peak"]["rudder"] and row["min_separation"] == rep["min_separation"]
    s = camp.summary()
    assert s["worst_errors"]["cross_track"] == t["cross_track"].max()
    assert s["worst_commanded_peak"]["force_x"] == t["force_x"].max()
    assert s["min_separation"] == t["min_separation"].min() and s["vertex_runs"] == 2
    assert s["certified"] is False and s["certificate_covers_runs"] is False
    # an uncertified fleet's campaign is not ok, however its runs went: no run is covered
    assert s["counts"]["passed"] == 0 and s["ok"] is False


def test_bad_inputs_are_refused():
    cfg = survey()
    with pytest.raises(ParameterError, match="runs"):
        run_guidance_campaign(cfg, 0)
    with pytest.raises(ParameterError, match="seed"):
        run_guidance_campaign(cfg, 1, seed=-1)
    with pytest.raises(ParameterError, match="horizon"):
        run_guidance_campaign(cfg, 1, horizon=-5.0)
    with pytest.raises(ConfigError, match=r"\[guidance\]"):
        run_guidance_campaign(preset_config("remus-survey"), 1)


def test_ctrl_c_keeps_the_finished_runs(monkeypatch):
    import auv_hinf.campaign.guidance as module

    calls = []

    def row(cfg, seed, index, horizon):
        if index == 2:
            raise KeyboardInterrupt
        calls.append(index)
        return {"run": index, "vertex": -1}

    monkeypatch.setattr(module, "_run_row", row)
    with pytest.raises(Interrupted) as stop:
        run_guidance_campaign(survey(), 5, horizon=HORIZON)
    assert stop.value.done == 2 and list(stop.value.partial.table["run"]) == calls == [0, 1]


@pytest.mark.slow
def test_cli_campaign_of_a_guidance_fleet(tmp_path, capsys):
    out = tmp_path / "camp"
    args = ["campaign", "--preset", "remus-survey-ilos", "--runs", "2", "--horizon", "30", "--json"]
    code = main([*args, "--out", str(out)])
    text, _ = capsys.readouterr()
    assert code == 1 and "refusing to run a campaign of" in text and not (out / "summary.json").exists()
    code = main([*args, "--out", str(out), "--uncertified"])
    text, err = capsys.readouterr()
    summary = json.loads(text)
    assert code == 1 and "not certified" in err and "Traceback" not in err
    assert summary == json.loads((out / "summary.json").read_text())
    assert summary["ok"] is False and summary["certified"] is False
    assert summary["runs"] == 2 and set(summary["worst_errors"]) >= {"along_track", "cross_track", "heading"}
    assert summary["limits"]["rudder"] == pytest.approx(preset_config("remus-survey-ilos").actuators.rudder_max)
    assert len(pd.read_parquet(out / "runs.parquet")) == 2 and (out / "runs.png").stat().st_size > 10_000


@pytest.mark.slow
def test_a_certified_fleet_reports_counts_and_worst_ratios_to_its_bounds():
    """``counts`` and ``worst_ratio`` as the formation law's campaigns have them: the table's, to the bounds."""
    cfg = preset_config("remus-transit-ilos")
    camp = run_guidance_campaign(cfg, 3, seed=1, horizon=HORIZON)
    s, t = camp.summary(), camp.table
    assert s["certified"] and s["counts"]["runs"] == 3 == s["counts"]["certificate_applies"]
    assert s["counts"]["inside_bounds"] == int(t["within_bounds"].sum()) == 3 == s["counts"]["passed"]
    assert s["ok"] is True
    bounds = {**s["certified_errors"], **guidance_certificate(cfg).certificate.to_dict()["certified_peak"]}
    for key, ratio in s["worst_ratio"].items():
        assert ratio == pytest.approx(t[key].max() / bounds[key], rel=1e-12) and 0.0 <= ratio <= 1.0, key


def test_a_coefficient_that_is_zero_adds_no_vertices():
    # the BlueROV2 Heavy has no linear sway damping: a range of it moves no plant
    cfg = preset_config("bluerov2-line")
    assert cfg.vehicle.d22_lin == 0.0
    wider = replace(cfg, uncertainty=UncertaintyConfig((*cfg.uncertainty.box, ("d22_lin", (0.5, 2.0)))))
    box = box_multipliers(wider)
    assert tuple(box[COEFFICIENTS.index("d22_lin")]) == (1.0, 1.0)
    assert np.array_equal(box, box_multipliers(cfg))


def test_a_steered_fleet_designs_no_robust_gains_for_the_law_it_does_not_run():
    # [design] robust asks for the formation law's robust design; with [guidance] that law never runs
    cfg = preset_config("remus-transit-ilos")
    point = design_point(replace(cfg, robust=True))
    assert point.robust_design is None and point.deployed_design is None and point.source == "theorem1"
    assert point.gains == design_point(cfg).gains


@pytest.mark.slow
def test_a_noisy_campaigns_rows_say_which_noise_each_run_had_and_reproduce_it():
    """Each run of a noisy guided fleet records its seed and pattern (``mixed``: its own pattern), and
    guidance_run with them gives the row's figures again; the summary names the implementation."""
    from tests.guidance.test_navigation import _navigation_fleet

    cfg = _navigation_fleet(simulation={"horizon": 20.0, "noise_pattern": "mixed"})
    camp = run_guidance_campaign(cfg, 3, seed=5, horizon=10.0)
    t = camp.table
    assert len(set(t["noise_pattern"])) == 3 and len(set(t["implementation_seed"])) == 3
    for _, row in t.iterrows():
        _, mult, current = run_inputs(cfg, 5, int(row["run"]))
        noise = (int(row["implementation_seed"]), str(row["noise_pattern"]))
        plant = scaled_plant(cfg.vehicle, mult)
        rep = guidance_run(cfg, 10.0, plant=plant, current=tuple(current), noise=noise).report()
        assert row["cross_track"] == rep["measured_errors"]["cross_track"]
        assert row["rudder"] == rep["commanded_peak"]["rudder"]
    impl = camp.summary()["implementation"]
    assert impl["noise_pattern"] == "mixed" and impl["sample_time"] == pytest.approx(0.05) and impl["draws"]
