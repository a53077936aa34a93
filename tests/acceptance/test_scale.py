"""Scale: certification of 10,000 vehicles in O(N) time and memory, and the fleet-size limits."""

from __future__ import annotations

import json
import time
import tracemalloc

import numpy as np
import pytest

from auv_hinf.certificate.assembly import certify
from auv_hinf.cli.main import main
from auv_hinf.config.schema import MAX_VEHICLES
from auv_hinf.config.settings import config_from_dict
from auv_hinf.exceptions import ConfigError

N = 10_000
#: Circumradius (m): neighbouring vehicles 2 pi R / N = 3.1 m apart.
RADIUS = 5000.0
#: Peak traced memory allowed (bytes): far below one dense N x N array (800 MB at N = 10,000),
#: let alone the 2N x 2N matrices (3.2 GB each) of the dense formulation.
PEAK_LIMIT = 200e6


@pytest.fixture(scope="module")
def big_config():
    return config_from_dict({"formation": {"n": N, "polygon_radius": RADIUS}})


@pytest.fixture(scope="module")
def big_cert(big_config):
    return certify(big_config)


@pytest.mark.slow
def test_certify_ten_thousand_vehicles(big_cert):
    """Every certified quantity of the nominal loop is per vehicle, so 10,000 vehicles get the verdict
    and the numbers of 3 vehicles of the same kind on the same mission and envelope; only the
    Jacobi-coordinate bound grows with N."""
    cert = big_cert
    small = certify(config_from_dict({"formation": {"n": 3, "polygon_radius": 10.0}}))
    assert small.certified and small.reasons == ()
    assert cert.certified is True and cert.reasons == ()
    assert cert.sigma.upper == pytest.approx(small.sigma.upper, rel=1e-12)
    assert cert.small_gain_margin == pytest.approx(small.small_gain_margin, rel=1e-12)
    assert cert.small_gain_margin > 0
    sj = cert.sigma_jacobi
    # the closed-form cond(Phi) = sqrt(2N) of the paper transform scales the exact vehicle sigma
    assert sj.upper == pytest.approx(np.sqrt(2.0 * N) * cert.sigma.upper, rel=1e-9)
    assert 0.0 < cert.sigma.lower <= sj.lower <= sj.upper
    assert len(sj.witness.psi) == N
    loop, small_loop = cert.to_dict()["closed_loop"], small.to_dict()["closed_loop"]
    assert loop["certified"] is True
    for key in ("decay_rate", "max_force", "max_moment"):
        assert loop[key] == pytest.approx(small_loop[key], rel=1e-12), key
    assert loop["region"] == pytest.approx(small_loop["region"], rel=1e-12)
    # the default start (each vehicle on its slot, zero error) is evaluated at every size and
    # covered without a blend, as for 3 vehicles
    assert loop["covers_shaped_start"] is True and loop["shaped_start_note"] is None
    assert loop["shaped_start"]["blend_time"] is None and small_loop["covers_shaped_start"] is True


@pytest.mark.slow
def test_certify_memory_is_linear(big_config):
    tracemalloc.start()
    try:
        cert = certify(big_config)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    print(f"\ncertify N={N}: peak traced memory {peak / 1e6:.1f} MB")
    assert cert.sigma_jacobi.lower <= cert.sigma_jacobi.upper
    assert peak < PEAK_LIMIT


@pytest.mark.slow
def test_cli_certify_json_ten_thousand(big_cert, tmp_path, capsys):
    f = tmp_path / "big.toml"
    f.write_text(f"[formation]\nn = {N}\npolygon_radius = {RADIUS}\n")
    code = main(["certify", "--config", str(f), "--json"])
    data = json.loads(capsys.readouterr().out)
    # the CLI reads the file into the configuration of big_cert and prints its verdict: certified, exit 0
    assert code == 0 and data["certified"] is True and data["reasons"] == []
    expected = big_cert.to_dict()
    assert data["n"] == N
    for key in ("lambda", "gamma", "small_gain_margin"):
        assert data[key] == expected[key], key
    assert data["sigma"]["upper"] == expected["sigma"]["upper"]
    assert data["sigma_jacobi"]["upper"] == expected["sigma_jacobi"]["upper"]
    assert data["sigma_jacobi"]["lower"] <= data["sigma_jacobi"]["upper"]
    assert data["closed_loop"]["region"] == expected["closed_loop"]["region"]


def test_validation_of_a_large_fleet_is_fast_and_finds_coincident_vehicles():
    """Coincident desired positions among 50,000 offsets are found (k-d tree, not N^2 pairs)."""
    n = 50_000
    ang = 2.0 * np.pi * np.arange(n) / n
    off = np.stack([1e4 * np.cos(ang), 1e4 * np.sin(ang)], -1)
    off[31_337] = off[17]
    t0 = time.perf_counter()
    with pytest.raises(ConfigError, match="vehicles 18 and 31338 have the same desired position"):
        config_from_dict({"formation": {"n": n, "offsets": off.tolist()}})
    print(f"\nvalidation of {n} offsets: {time.perf_counter() - t0:.2f} s")


def test_fleet_size_limit_is_a_clear_config_error():
    with pytest.raises(ConfigError, match=f"formation.n must be <= {MAX_VEHICLES}"):
        config_from_dict({"formation": {"n": MAX_VEHICLES + 1}})
    assert MAX_VEHICLES >= 100_000
