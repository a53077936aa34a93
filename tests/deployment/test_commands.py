"""The deployment commands' input checks (one line, exit 2, before any certification) and the link's decoding."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from auv_hinf.cli.main import main
from auv_hinf.deployment.ardusub import ArduSubMapping
from auv_hinf.deployment.link import VehicleLink

TOML = """
[vehicle]
preset = "bluerov2-heavy"

[formation]
n = 2
offsets = [[0.0, -2.0], [0.0, 2.0]]
"""


@pytest.fixture
def config(tmp_path):
    path = tmp_path / "fleet.toml"
    path.write_text(TOML + '\n[deploy]\nconnect = ["udpout:127.0.0.1:1"]\npilot_gain = 0.5\n', encoding="utf-8")
    return path


def _err(capsys) -> str:
    return capsys.readouterr().err.strip()


def test_run_needs_one_connection_per_vehicle(config, tmp_path, capsys):
    code = main(["run", "--config", str(config), "--duration", "1", "--log", str(tmp_path / "r.parquet")])
    err = _err(capsys)
    assert code == 2 and len(err.splitlines()) == 1 and "one --connect URL per vehicle (2" in err and "got 1" in err


@pytest.mark.parametrize(
    ("urls", "words"),
    [
        (["udpout:127.0.0.1:14550", "udpout:127.0.0.1:14550"], "is given twice"),
        (["udpout:127.0.0.1:14550", "foo"], "is not a MAVLink connection string"),
        (["udpout:127.0.0.1:14550", "udpout:127.0.0.1:99999"], "a port in 0-65535"),
    ],
)
def test_run_refuses_connections_that_repeat_or_are_not_mavlink_urls(config, tmp_path, capsys, urls, words):
    """Two vehicles on one connection would each get the other's commands; a string pymavlink would read as
    a serial device or a port out of range fails late: all are bad input, before any certification."""
    log = tmp_path / "r.parquet"
    code = main(
        ["run", "--config", str(config), "--duration", "1", "--log", str(log)]
        + [a for u in urls for a in ("--connect", u)]
    )
    err = _err(capsys)
    assert code == 2 and words in err and len(err.splitlines()) == 1 and not log.exists()
    code = main(
        ["fleet-sim", "--config", str(config), "--duration", "0.1"] + [a for u in urls for a in ("--listen", u)]
    )
    assert code == 2 and words in _err(capsys)


def test_replay_refuses_a_plot_file_whose_extension_is_no_image_format_before_reading_the_log(config, tmp_path, capsys):
    code = main(["replay", str(tmp_path / "none.parquet"), "--config", str(config), "--plot", str(tmp_path / "r.txt")])
    err = _err(capsys)
    assert code == 2 and "--plot" in err and ".png" in err and "none.parquet" not in err


def test_deploy_table_is_validated(tmp_path, capsys):
    path = tmp_path / "bad.toml"
    path.write_text(TOML + "\n[deploy]\npilot_gain = 2.0\nvoltag = 16.0\n", encoding="utf-8")
    code = main(["run", "--config", str(path), "--duration", "1", "--log", str(tmp_path / "r.parquet")])
    err = _err(capsys)
    assert code == 2 and "deploy.pilot_gain" in err and "did you mean 'voltage'" in err and "Traceback" not in err


def test_fleet_sim_needs_one_endpoint_per_vehicle(config, capsys):
    code = main(["fleet-sim", "--config", str(config), "--listen", "udpin:127.0.0.1:0", "--duration", "0.1"])
    assert code == 2 and "one --listen URL per vehicle" in _err(capsys)
    code = main(["fleet-sim", "--config", str(config), "--listen", "udpin:127.0.0.1:0"] * 1 + ["--latency", "-1"])
    assert code == 2 and "--latency" in _err(capsys)


def test_replay_refuses_missing_and_incomplete_logs(config, tmp_path, capsys):
    code = main(["replay", str(tmp_path / "none.parquet"), "--config", str(config)])
    assert code == 2 and "no log file" in _err(capsys)
    (tmp_path / "log.csv").write_text("time,vehicle,x,y,psi,u,v\n0,0,0,0,0,0,0\n", encoding="utf-8")
    code = main(["replay", str(tmp_path / "log.csv"), "--config", str(config)])
    assert code == 2 and "lacks the column(s) r" in _err(capsys)


HEADER = "time,vehicle,x,y,psi,u,v,r\n"


@pytest.mark.parametrize(
    ("rows", "words"),
    [
        ("", "has no rows"),
        ("0,0,abc,0,0,0,0,0\n0,1,0,0,0,0,0,0\n", "column 'x' must hold numbers, got 'abc'"),
        ("0,0,0,0,0,0,0,0\n0,1,nan,0,0,0,0,0\n", "column 'x' must hold numbers, got 'nan'"),
        ("0,0,0,0,0,0,0,0\n0,0.5,0,0,0,0,0,0\n", "whole numbers"),
        ("0,0,0,0,0,0,0,0\n0.1,0,0,0,0,0,0,0\n", "for a fleet of 2 vehicles"),
    ],
    ids=["header only", "text", "nan", "fractional vehicle", "one vehicle of two"],
)
@pytest.mark.slow
def test_replay_names_what_is_wrong_with_a_log(config, tmp_path, capsys, rows, words):
    (tmp_path / "log.csv").write_text(HEADER + rows, encoding="utf-8")
    code = main(["replay", str(tmp_path / "log.csv"), "--config", str(config)])
    err = _err(capsys)
    assert code == 2 and words in err and "internal error" not in err, err


def test_the_link_decodes_navigation_and_ages_from_timesync():
    link = VehicleLink("udpin:127.0.0.1:0", 0, ArduSubMapping())
    try:
        vehicle = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)

        def arrive(msg, t_ns):
            link.handle(mavlink2.MAVLink(None).decode(bytearray(msg.pack(vehicle))), t_ns)

        boot = 5_000_000_000  # the vehicle booted 5 s before our clock's zero: offset +5 s
        arrive(
            vehicle.heartbeat_encode(mavlink2.MAV_TYPE_SUBMARINE, mavlink2.MAV_AUTOPILOT_ARDUPILOTMEGA, 0, 19, 4), 10
        )
        link._pending[1_000] = 1_000  # a TIMESYNC sent at 1 us, answered at the vehicle's 5.000002 s
        arrive(vehicle.timesync_encode(boot + 2_000, 1_000), 3_000)
        assert link.clock.ready and link.clock.best == (2_000, boot)
        stamp_ms = 5_100  # measured at the vehicle's 5.1 s, our 0.1 s
        arrive(vehicle.local_position_ned_encode(stamp_ms, 1.0, 2.0, 0.0, 0.3, 0.4, 0.0), 120_000_000)
        arrive(vehicle.attitude_encode(stamp_ms, 0.0, 0.0, math.pi / 2, 0.0, 0.0, 0.05), 120_000_000)
        state, age, source = link.state(150_000_000)
        # heading east: the NED velocity (0.3, 0.4) is (0.4, -0.3) in the body frame
        assert np.allclose(state, [1.0, 2.0, math.pi / 2, 0.4, -0.3, 0.05], atol=1e-6)
        assert source == "timesync" and age == pytest.approx(0.05, abs=1e-9)
        assert link.custom_mode == 19 and link.target == 1
    finally:
        link.close()
