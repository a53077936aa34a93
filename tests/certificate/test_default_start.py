"""The default start is the fleet on its slots: covered at every size, judged alike by certify and simulate."""

from __future__ import annotations

import json

import numpy as np
import pytest

from auv_hinf.certificate.assembly import certify
from auv_hinf.certificate.design_point import design_point, initial_states
from auv_hinf.cli.main import main
from auv_hinf.config.settings import config_from_dict
from auv_hinf.numerics.integrators import NUMERICAL_FLOOR


@pytest.mark.slow
@pytest.mark.parametrize("n", [3, 40, 400])
def test_default_start_has_zero_error_and_is_covered(n):
    cfg = config_from_dict({"formation": {"n": n, "polygon_radius": 0.5 * n}})
    x0 = initial_states(design_point(cfg))
    fleet = design_point(cfg).fleet()
    m = fleet.motion(0.0)
    np.testing.assert_allclose(x0[:, :2], m.p, atol=1e-12)
    ground = np.column_stack(
        [
            x0[:, 3] * np.cos(x0[:, 2]) - x0[:, 4] * np.sin(x0[:, 2]),
            x0[:, 3] * np.sin(x0[:, 2]) + x0[:, 4] * np.cos(x0[:, 2]),
        ]
    )
    np.testing.assert_allclose(ground, m.v, atol=1e-12)
    cert = certify(cfg)
    loop = cert.to_dict()["closed_loop"]
    assert cert.certified and loop["covers_shaped_start"] is True and loop["shaped_start_note"] is None


@pytest.mark.slow
def test_large_default_run_is_covered_and_measured_within_its_bounds(tmp_path, capsys):
    path = tmp_path / "big.toml"
    path.write_text("[formation]\nn = 300\npolygon_radius = 150.0\n[simulation]\nhorizon = 20.0\n", encoding="utf-8")
    code = main(["simulate", "--config", str(path), "--json"])
    run = json.loads(capsys.readouterr().out)
    assert code == 0 and run["certificate_covers_run"] is True and run["stayed_in_envelope"] is True
    # the certified errors carry the integrator's floor, so a covered run is never measured above them
    assert run["numerical_floor"] == NUMERICAL_FLOOR
    for key, value in run["measured_errors"].items():
        assert value <= run["certified_errors"][key], key
    # every null says why
    assert set(run["null_reasons"]) == {k for k, v in run.items() if v is None}
    assert "never left" in run["null_reasons"]["first_exit_time"]


@pytest.mark.parametrize("n", [1, 3, 999, 1000, 1001, 10_000, 100_000])
def test_stored_samples_keep_memory_bounded(n):
    from auv_hinf.certificate.run_plan import MIN_RUN_SAMPLES, RUN_SAMPLES, SAMPLE_BUDGET, run_samples

    k = run_samples(n)
    assert MIN_RUN_SAMPLES <= k <= RUN_SAMPLES
    assert k * n <= max(SAMPLE_BUDGET, MIN_RUN_SAMPLES * n)  # vehicle-samples within the budget
    assert (k == RUN_SAMPLES) == (n * RUN_SAMPLES <= SAMPLE_BUDGET)
