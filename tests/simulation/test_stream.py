"""Streamed trajectories: the Parquet file holds the run itself, sample by sample, vehicle by vehicle."""

from __future__ import annotations

import json
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from auv_hinf.certificate.run_plan import plan_run
from auv_hinf.cli.main import main
from auv_hinf.config.presets import preset_config
from auv_hinf.exceptions import ParameterError
from auv_hinf.law.formation_law import VehicleLaw
from auv_hinf.law.gains import with_integral
from auv_hinf.simulation.engine import simulate
from auv_hinf.simulation.stream import INTEGRATOR_COLUMNS, STATE_COLUMNS, save_trajectories
from tests.cli.test_text_units import unitless_numbers

#: Agreement of the streamed and the stored run: the same integration, so round-off only.
STREAM_ATOL = 1e-9


def _scenario(integral: bool = False) -> object:
    plan = plan_run(preset_config("paper-triangle"), horizon=10.0, samples=101)
    scn = plan.scenario
    if integral:
        scn = replace(scn, law=VehicleLaw(scn.law.params, with_integral(scn.law.gains, -1.0, 1.0)))
    return scn


@pytest.mark.slow
@pytest.mark.parametrize("integral", [False, True])
def test_the_streamed_file_is_the_run(tmp_path: Path, integral: bool) -> None:
    scn = _scenario(integral)
    path = save_trajectories(scn, tmp_path / "run.parquet", interval=scn.horizon / (scn.samples - 1))
    df = pd.read_parquet(path)
    names = STATE_COLUMNS + (INTEGRATOR_COLUMNS if integral else ())
    assert list(df.columns) == ["time", "vehicle", *names]
    assert len(df) == scn.samples * scn.n
    res = simulate(scn)
    states = df.sort_values(["time", "vehicle"])[list(STATE_COLUMNS)].to_numpy().reshape(scn.samples, scn.n, 6)
    np.testing.assert_allclose(states, res.states, rtol=0, atol=STREAM_ATOL)
    np.testing.assert_allclose(np.unique(df["time"]), res.t, rtol=0, atol=1e-12)
    if integral:  # the integrator starts at zero and integrates the position error
        z = df[df["time"] == 0.0][list(INTEGRATOR_COLUMNS)].to_numpy()
        assert np.all(z == 0.0) and np.any(df[list(INTEGRATOR_COLUMNS)].to_numpy() != 0.0)


@pytest.mark.slow
def test_save_refuses_other_formats(tmp_path: Path, capsys) -> None:
    with pytest.raises(ParameterError, match="parquet"):
        save_trajectories(_scenario(), tmp_path / "run.npz")
    assert main(["simulate", "--preset", "paper-triangle", "--save", str(tmp_path / "run.csv")]) == 2
    assert "parquet" in capsys.readouterr().err


@pytest.mark.slow
def test_a_saved_run_is_a_log_that_replay_reads(tmp_path: Path, capsys) -> None:
    """simulate --save writes the log format: replay reads it and judges it against the certificate."""
    from auv_hinf.deployment.log import read_log

    path = save_trajectories(_scenario(), tmp_path / "run.parquet")
    log = read_log(path)
    assert log.frame["vehicle"].nunique() == 3 and log.frame["time"].is_monotonic_increasing
    code = main(["replay", "--preset", "paper-triangle", str(path), "--json"])
    out, err = capsys.readouterr()
    assert code in (0, 1), err
    assert "lacks the column" not in err
    # the continuous law's certificate certifies no loop timing: the sample spacing is not a violation
    summary = json.loads(out.strip().splitlines()[-1])
    timing = {"period", "lag", "delay", "stale"}
    assert timing <= set(summary["unchecked"]) and not timing & {v["assumption"] for v in summary["violations"]}
    # the text: every figure with its unit, a log without verdicts of its own said in words (not "None")
    main(["replay", "--preset", "paper-triangle", str(path)])
    text = capsys.readouterr().out
    assert "None" not in text and "reproduced: not checked" in text
    assert unitless_numbers(text) == [] and re.search(r"max_period: [\d.e+-]+ s\n", text)
