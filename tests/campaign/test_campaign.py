"""Monte Carlo campaigns: reproducible sampling, executor independence, certified bounds, CLI."""

from __future__ import annotations

import itertools
import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from auv_hinf.campaign.report import passed, summarize
from auv_hinf.campaign.runner import run_campaign
from auv_hinf.campaign.runs import FORCE_COLUMNS, initial_state, run_chunk, sample_run
from auv_hinf.campaign.setup import chunks, prepare
from auv_hinf.cli.main import main
from auv_hinf.closed_loop.coverage import initial_errors
from auv_hinf.config.presets import preset_config
from auv_hinf.config.settings import DisturbanceConfig, UncertaintyConfig
from auv_hinf.exceptions import ParameterError
from auv_hinf.implementation.model import Implementation, MeasurementNoise

RUNS, HORIZON, SEED = 8, 20.0, 7


@pytest.fixture(scope="module")
def serial() -> pd.DataFrame:
    return run_campaign(preset_config("paper-triangle"), RUNS, seed=SEED, chunk=3, horizon=HORIZON).table


def test_sampled_starts_lie_in_the_certified_region() -> None:
    setup, cert = prepare(preset_config("paper-triangle"), seed=SEED, horizon=HORIZON)
    radii = cert.region.region.as_array()
    for i in range(50):
        x = sample_run(setup, i)
        e, de, ep, dep = initial_errors(setup.reference, initial_state(setup, x))
        measured = np.stack([np.linalg.norm(e, axis=1), np.linalg.norm(de, axis=1), np.abs(ep), np.abs(dep)], 1)
        assert np.all(measured <= radii * (1 + 1e-12)), (i, measured, radii)
        assert np.all(x.multipliers == 1.0) and np.all(x.current == 0.0)
    # the same run index gives the same inputs whatever else was sampled
    a, b = sample_run(setup, 5), sample_run(setup, 5)
    assert all(np.array_equal(u, v) for u, v in zip(a.errors, b.errors))
    assert not np.array_equal(sample_run(setup, 4).errors[0], a.errors[0])


@pytest.mark.slow
def test_nominal_runs_stay_inside_their_certified_bounds(serial: pd.DataFrame) -> None:
    assert list(serial["run"]) == list(range(RUNS))
    assert serial["nominal"].all() and serial["stayed_in_envelope"].all()
    assert serial["inside_bounds"].dtype == "boolean" and serial["inside_bounds"].all()
    for kind in ("position", "velocity", "heading", "yaw_rate"):
        # every bound covers the start error and the measured excursion
        assert (serial[f"start_{kind}_error"] <= serial[f"bound_{kind}_error"]).all()
        assert (serial[f"max_{kind}_error"] >= serial[f"start_{kind}_error"]).all()
        assert (serial[f"ratio_{kind}_error"] <= 1.0 + 1e-6).all()
    assert (serial["final_position_error"] < serial["start_position_error"]).all()


@pytest.mark.slow
def test_dask_in_process_gives_an_identical_table(serial: pd.DataFrame) -> None:
    distributed = pytest.importorskip("distributed")
    # no warning filter: an in-process cluster without a dashboard starts and stops silently
    with distributed.Client(processes=False, n_workers=2, threads_per_worker=1, dashboard_address=":0") as client:
        table = run_campaign(
            preset_config("paper-triangle"), RUNS, seed=SEED, chunk=3, horizon=HORIZON, client=client
        ).table
    pd.testing.assert_frame_equal(table, serial, check_exact=True)


@pytest.mark.slow
def test_sampling_does_not_depend_on_the_chunking(serial: pd.DataFrame) -> None:
    other = run_campaign(preset_config("paper-triangle"), RUNS, seed=SEED, chunk=5, horizon=HORIZON).table
    inputs = [c for c in serial.columns if c.endswith("_mult") or c.startswith(("start_", "current_"))]
    pd.testing.assert_frame_equal(other[inputs], serial[inputs], check_exact=True)
    np.testing.assert_allclose(other["max_position_error"], serial["max_position_error"], rtol=1e-9)
    assert chunks(8, 3) == [(0, 3), (3, 6), (6, 8)]


@pytest.mark.slow
def test_uncovered_box_and_current_make_the_verdict_not_applicable() -> None:
    """The nominal paper gains are not robustly certified for this box: no verdict on such runs."""
    cfg = replace(
        preset_config("paper-triangle"),
        uncertainty=UncertaintyConfig({"m11": (0.9, 1.1)}),
        disturbance=DisturbanceConfig(current_speed=0.05),
    )
    camp = run_campaign(cfg, 3, seed=1, horizon=5.0)
    t = camp.table
    assert t["inside_bounds"].isna().all()
    assert ((t["m11_mult"] >= 0.9) & (t["m11_mult"] <= 1.1) & (t["m11_mult"] != 1.0)).all()
    assert (np.hypot(t["current_x"], t["current_y"]) <= 0.05).all() and (t["m22_mult"] == 1.0).all()
    summary = summarize(camp)
    assert summary["counts"]["not_applicable"] == 3 and summary["fraction_inside"] is None
    assert any("robust certificate does not cover" in n for n in summary["notes"])
    assert bool(passed(t).all()) == bool(t["stayed_in_envelope"].all())
    # no run is covered: the campaign is not ok however its runs went (as simulate's exit code), and it
    # names no certificate
    assert summary["ok"] is False and summary["certificate"] is None
    # no certificate covers these runs: their forces are recorded, with no force verdict
    assert t["within_certified_force"].isna().all() and (t[list(FORCE_COLUMNS)] > 0).all().all()
    assert summary["counts"]["exceeded_certified_force"] == 0 and summary["forces"]["within_certified_force"] == 0
    assert all(v is None for v in summary["forces"]["worst_ratio"].values())


def test_bad_inputs_raise() -> None:
    cfg = preset_config("paper-triangle")
    with pytest.raises(ParameterError, match="runs"):
        run_campaign(cfg, 0)
    with pytest.raises(ParameterError, match="seed"):
        prepare(cfg, seed=-1)


@pytest.mark.slow
def test_cli_campaign_writes_its_outputs(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "camp"
    code = main(
        [
            "campaign",
            "--preset",
            "paper-triangle",
            "--runs",
            "4",
            "--seed",
            "3",
            "--horizon",
            "10",
            "--out",
            str(out),
            "--json",
        ]
    )
    assert code == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["ok"] and summary["counts"]["inside_bounds"] == 4 and summary["fraction_inside"] == 1.0
    assert math.isfinite(summary["throughput"]["vehicle_seconds_per_wall_second"])
    for name in ("runs.parquet", "summary.json", "excursions.png", "bound_ratios.png"):
        assert (out / name).stat().st_size > 0
    assert len(pd.read_parquet(out / "runs.parquet")) == 4


def test_cli_campaign_bad_input_exits_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["campaign", "--preset", "paper-triangle", "--runs", "0", "--out", str(tmp_path)])
    assert code == 2
    err = capsys.readouterr().err
    assert "--runs" in err and "Traceback" not in err
    assert (
        main(
            [
                "campaign",
                "--preset",
                "paper-triangle",
                "--runs",
                "2",
                "--workers",
                "1",
                "--scheduler",
                "x",
                "--out",
                str(tmp_path),
            ]
        )
        == 2
    )


@pytest.mark.slow
def test_local_workers_get_the_allocator_settings_and_even_chunks() -> None:
    """Dask's default trims the heap so hard that every temporary is re-mapped (page faults)."""
    pytest.importorskip("distributed")
    import os

    from auv_hinf.campaign.runner import WORKER_MALLOC, _balanced, dask_client

    with dask_client(workers=2) as client:
        env = client.run(lambda: {k: os.environ.get(k) for k in WORKER_MALLOC})
        assert len(env) == 2
        for got in env.values():
            assert got == {k: str(v) for k, v in WORKER_MALLOC.items()}
        # 10,000 runs with chunks of at most 4096 on 2 workers: 4 chunks of 2500, not 4096 + 4096 + 1808
        size = _balanced(4096, 10_000, client)
        assert size == 2500 and len(chunks(10_000, size)) % 2 == 0
        assert _balanced(4096, 3, client) == 2  # both workers get a chunk


@pytest.mark.slow
def test_a_chunk_reports_its_progress_as_it_runs() -> None:
    setup, _ = prepare(preset_config("paper-triangle"), seed=SEED, horizon=HORIZON)
    seen: list[float] = []
    table = run_chunk(setup, 0, 3, progress=seen.append)
    assert len(table) == 3
    assert 50 <= len(seen) <= 101 and all(b >= a + 0.01 for a, b in itertools.pairwise(seen))
    assert 0.0 < seen[0] <= 0.02 and 0.99 <= seen[-1] <= 1.0


@pytest.mark.slow
def _record_bar(mp: pytest.MonkeyPatch) -> list[int]:
    """Patch tqdm's bar to record its position after every update; returns the record."""
    import tqdm

    seen: list[int] = []

    class Recording(tqdm.tqdm):  # type: ignore[misc]
        def update(self, n: float | None = 1) -> bool | None:
            out = super().update(n)
            seen.append(int(self.n))
            return out

    mp.setattr(tqdm, "tqdm", Recording)
    return seen


@pytest.mark.slow
def test_dask_chunks_report_their_progress_as_events_and_the_bar_ends_at_the_runs() -> None:
    """On Dask every chunk logs fractions below one while it runs; the bar is monotone and ends at the runs.

    When the events reach the client depends on the machine's load, so the bar positions
    are checked with a scripted client (next test); here the events themselves are.
    """
    pytest.importorskip("distributed")
    from auv_hinf.campaign.runner import dask_client

    runs = 4
    with pytest.MonkeyPatch.context() as mp, dask_client(workers=2) as client:
        seen = _record_bar(mp)
        topics: set[str] = set()
        read = client.get_events

        def spy(topic: str) -> object:
            topics.add(topic)
            return read(topic)

        mp.setattr(client, "get_events", spy)
        camp = run_campaign(
            preset_config("paper-triangle"), runs, seed=SEED, horizon=60.0, client=client, progress=True
        )
        (topic,) = topics
        logged = read(topic)
    assert len(camp.table) == runs and seen[-1] == runs
    assert all(b >= a for a, b in itertools.pairwise(seen))
    starts = {lo for lo, _ in chunks(runs, camp.chunk)}
    partial = {lo for _, (lo, frac) in logged if 0.0 < frac < 1.0}
    assert partial == starts, (logged, starts)


def test_the_dask_bar_moves_with_the_chunk_events_before_the_chunks_finish(monkeypatch: pytest.MonkeyPatch) -> None:
    """A scripted client: half of each chunk is reported before any chunk finishes; the bar shows it."""
    from auv_hinf.campaign import runner

    seen = _record_bar(monkeypatch)

    class Future:
        def __init__(self, client: Scripted) -> None:
            self.client = client

        def done(self) -> bool:
            return self.client.polls > 2

        def result(self) -> pd.DataFrame:  # fetched as soon as the chunk is done
            return pd.DataFrame()

    class Scripted:
        """Poll 1: no events; poll 2: each chunk half done; poll 3: all finished."""

        def __init__(self) -> None:
            self.polls = 0

        def scatter(self, setup: object, broadcast: bool) -> object:
            return setup

        def submit(self, fn: object, setup: object, lo: int, hi: int, progress: object, pure: bool) -> Future:
            return Future(self)

        def get_events(self, topic: str) -> list[tuple[float, tuple[int, float]]]:
            self.polls += 1
            return [(0.0, (lo, 0.5)) for lo in (0, 4)] if self.polls == 2 else []

    monkeypatch.setattr(runner, "PROGRESS_POLL", 0.0)
    runner._execute(None, [(0, 4), (4, 8)], Scripted(), progress=True)  # type: ignore[arg-type]
    assert 4 in seen and seen[-1] == 8, seen


@pytest.mark.slow
def test_sampled_campaign_draws_per_run_and_does_not_depend_on_the_chunk():
    impl = Implementation(0.1, 0.1, varying_delay=True, noise=MeasurementNoise(0.05, 0.02, 0.01, 0.005))
    cfg = replace(preset_config("paper-triangle"), implementation=impl)
    whole = run_campaign(cfg, 3, seed=4, chunk=3, horizon=5.0)
    single = run_campaign(cfg, 3, seed=4, chunk=1, horizon=5.0)
    cols = ["max_position_error", "max_velocity_error", "final_position_error", "max_force_x"]
    np.testing.assert_allclose(whole.table[cols].to_numpy(), single.table[cols].to_numpy(), rtol=1e-9, atol=1e-12)
    seeds = whole.table["implementation_seed"]
    assert seeds.nunique() == 3 and (seeds == single.table["implementation_seed"]).all()
    assert whole.table["diverged_at"].isna().all()
    assert summarize(whole)["implementation"]["sample_time"] == 0.1


def test_a_horizon_shorter_than_one_output_interval_keeps_its_two_ends() -> None:
    """``simulate`` takes any positive horizon; a campaign of 1 us used to stop on its own sample count
    ("samples must be an integer >= 2, got 1"), naming no setting: it now samples the run's two ends."""
    setup, _ = prepare(preset_config("paper-triangle"), horizon=1e-6)
    assert setup.samples == 2 and setup.horizon == 1e-6
