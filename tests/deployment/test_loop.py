"""``auv-hinf run`` against the loopback fleet on 127.0.0.1: four BlueROV2 Heavy at 10 Hz.

The certified configuration is ``tests.helpers.BLUEROV_10HZ`` (the preset ``bluerov2-line`` is not
certified). Every test starts and stops its own processes, talks to 127.0.0.1 only and is bounded
in time (:data:`TEST_BOUND`). The loop and the fleet ask for real-time scheduling (``--realtime``):
on a machine shared with other jobs, a normal-priority loop is late by up to a few hundred
milliseconds now and then, which the monitor rightly reports.
"""

from __future__ import annotations

import json
import os
import select
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from auv_hinf.certificate.assembly import Certificate, certify
from auv_hinf.cli.main import main
from auv_hinf.config.settings import config_from_dict
from auv_hinf.deployment.ardusub import ArduSubMapping
from auv_hinf.deployment.link import VehicleLink
from auv_hinf.deployment.log import CSV_OPTIONAL, CSV_REQUIRED
from auv_hinf.deployment.runner import run
from auv_hinf.deployment.runtime import RuntimeLaw
from tests.helpers import BLUEROV_10HZ

#: Every test of this file ends within this many seconds (SIGALRM).
TEST_BOUND = 150
#: How long a fleet may take to print its endpoints (s): importing the package takes a few seconds
#: on an idle machine, and over 30 s on two cores shared with a parallel test run.
START_BOUND = 60.0
#: The fleet's faults in the fault tests: vehicle 1 loses 80 % of its navigation, vehicle 2 has an
#: 80 ms one-way latency (its measurements arrive about 90 ms old, above the certified 50 ms).
FAULTS = ("--loss", "0,0.8,0,0", "--latency", "0,0,0.08,0")
NEUTRAL_STICKS = [0, 0, 500, 0]
#: Length of the covered real-time run (s): 150 steps at 10 Hz, long enough for the errors to settle
#: and the timing statistics to mean something (the measured figures of docs/deployment.md are of a 60 s run).
RUN_SECONDS = 15.0

#: The monitor's timing assumptions: the only ones a clean loopback run can violate (a late step or message).
TIMING = {"period", "lag", "delay", "stale"}
#: At most this fraction of a clean run's steps may be late (the machine's, flagged by the monitor);
#: a CI run beside the full test suite saw one late stretch (22.5-22.6 s) in 300 steps.
LATE_STEPS = 0.05

pytestmark = pytest.mark.slow


@pytest.fixture(autouse=True)
def _bounded() -> Iterator[None]:
    def _alarm(signum: int, frame: object) -> None:
        raise TimeoutError(f"test exceeded its {TEST_BOUND} s bound")

    old = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(TEST_BOUND)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


@pytest.fixture(scope="module")
def certificate(tmp_path_factory: pytest.TempPathFactory) -> tuple[Certificate, Path]:
    """The certificate of the 10 Hz BlueROV2 fleet, and its file (certified once for the module)."""
    cert = certify(config_from_dict(BLUEROV_10HZ))
    assert cert.certified, cert.reasons
    path = cert.save(tmp_path_factory.mktemp("certificate") / "certificate.json")
    return cert, path


def _cli(*args: str) -> list[str]:
    return [sys.executable, "-m", "auv_hinf.cli.main", *args]


def _stop(proc: subprocess.Popen[str], sig: int = signal.SIGTERM) -> None:
    if proc.poll() is None:
        proc.send_signal(sig)
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(10)


@contextmanager
def fleet(cert_file: Path, report: Path, *extra: str, n: int = 4) -> Iterator[list[str]]:
    """``auv-hinf fleet-sim`` on free ports of 127.0.0.1; yields the controller's connection strings."""
    cmd = _cli("fleet-sim", "--certificate", str(cert_file), "--report", str(report), "--duration", "140", "--realtime")
    cmd += [a for _ in range(n) for a in ("--listen", "udpin:127.0.0.1:0")] + list(extra)
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        assert proc.stdout is not None
        ready, _, _ = select.select([proc.stdout], [], [], START_BOUND)
        line = proc.stdout.readline() if ready else ""
        if not line:
            _stop(proc)
            raise RuntimeError(f"fleet-sim did not start: {proc.stderr.read() if proc.stderr else ''}")
        yield [u.replace("udpin:", "udpout:") for u in json.loads(line)["endpoints"]]
    finally:
        _stop(proc)
        for pipe in (proc.stdout, proc.stderr):
            if pipe is not None:
                pipe.close()


def _names(violations: list[dict], vehicle: int | None = None) -> set[str]:
    return {v["assumption"] for v in violations if vehicle is None or v["vehicle"] == vehicle}


@pytest.fixture(scope="module")
def four_at_10hz(certificate, tmp_path_factory) -> dict:
    """The :data:`RUN_SECONDS` run of four vehicles, through :func:`run` with links that keep every message sent."""
    cert, cert_file = certificate
    tmp = tmp_path_factory.mktemp("run")
    report, log = tmp / "fleet.json", tmp / "run.parquet"
    mapping = ArduSubMapping()
    with fleet(cert_file, report) as urls:
        links = [VehicleLink(u, i, mapping, record=True) for i, u in enumerate(urls)]
        try:
            t0 = time.monotonic()
            summary = run(RuntimeLaw.from_certificate(cert), links, RUN_SECONDS, log, realtime=True)
            elapsed = time.monotonic() - t0
        finally:
            for link in links:
                link.close()
        time.sleep(0.3)  # the fleet has received the last neutral commands
    sent = [list(link.sent) for link in links]
    return {"summary": summary, "elapsed": elapsed, "log": log, "report": report, "sent": sent, "cert": cert}


def test_four_vehicles_at_10hz_stay_inside_the_certified_bounds(four_at_10hz):
    """The loop keeps its certified timing, the monitor flags every step that does not, and the
    measured errors stay inside the certificate's bounds while the assumptions hold.

    The run shares the machine with other tests: a late step now and then is the machine's, and the
    property is then that the monitor reports it (and the run is not called covered), not that it
    never happens. A loop that is late as a rule fails :data:`LATE_STEPS`.
    """
    summary, cert = four_at_10hz["summary"], four_at_10hz["cert"]
    log = pd.read_parquet(four_at_10hz["log"])
    periods = log.loc[log.vehicle == 0, "period"].dropna().to_numpy()
    print(
        f"\n10 Hz loop: {summary['steps']} steps in {four_at_10hz['elapsed']:.1f} s; period mean "
        f"{periods.mean() * 1e3:.3f} ms, std {periods.std() * 1e3:.3f} ms, max |dev| "
        f"{np.abs(periods - 0.1).max() * 1e3:.2f} ms; ages {log.age.min() * 1e3:.1f}-{log.age.max() * 1e3:.1f} ms; "
        f"{summary['violation_count']} violation(s)"
    )
    assert summary["steps"] >= round(RUN_SECONDS / 0.1) - 5 and summary["stopped_by"] == "duration"
    assert log.age_source.eq("timesync").all()
    # covered exactly when nothing was violated; the only violations on a clean loopback are timing ones
    assert summary["covered"] == (summary["violation_count"] == 0)
    assert _names(summary["violations"]) <= TIMING, summary["violations"][:5]
    # every step older than the certified age is flagged, and no step that is not
    bound = RuntimeLaw.from_certificate(cert).assumptions.measurement_age_bound
    flagged = log.violations.str.contains('"delay"')
    assert flagged.equals(log.age > bound), log.loc[flagged != (log.age > bound), ["time", "vehicle", "age"]]
    late = log.loc[log.violations.str.len() > 2, "step"].unique()
    assert len(late) <= LATE_STEPS * summary["steps"], (len(late), summary["violations"][:5])
    # until the first violation, the measured errors stay inside the certificate's invariant set (the
    # composed or the implementation certificate's bounds; no noise on the loopback)
    held = log[log.step < (late.min() if len(late) else np.inf)]
    bounds = RuntimeLaw.from_certificate(cert).assumptions.error_bounds.to_dict()
    c, s = np.cos(held.psi), np.sin(held.psi)
    vx, vy = c * held.u - s * held.v, s * held.u + c * held.v
    errors = {
        "position": np.hypot(held.x - held.ref_x, held.y - held.ref_y),
        "velocity": np.hypot(vx - held.ref_vx, vy - held.ref_vy),
        "heading": np.abs(held.psi - held.ref_psi),
        "yaw_rate": np.abs(held.r - held.ref_r),
    }
    print("largest errors " + ", ".join(f"{k} {e.max():.3g} of {bounds[k]:.3g}" for k, e in errors.items()))
    assert held.step.nunique() >= 50  # the bounds are checked on at least 5 s of the run
    for name, e in errors.items():
        assert e.max() <= bounds[name], (name, e.max(), bounds[name])
    # the fleet moved along its mission at 0.05 m/s
    last = log[log.step == log.step.max()]
    assert np.allclose(last.x, 0.05 * RUN_SECONDS, atol=0.1) and np.all(last.law == "certified")


def test_every_sent_message_decodes_to_its_command(four_at_10hz):
    log = pd.read_parquet(four_at_10hz["log"])
    fleet_report = json.loads(four_at_10hz["report"].read_text())
    for i, sent in enumerate(four_at_10hz["sent"]):
        parser = mavlink2.MAVLink(None)
        decoded = [parser.decode(bytearray(b)) for b in sent]
        assert all(d.get_type() == "MANUAL_CONTROL" and d.target == 1 + i for d in decoded)
        got = np.array([(d.x, d.y, d.z, d.r) for d in decoded]) / 1000.0
        rows = log[log.vehicle == i].sort_values("step")
        want = rows[["cmd_x", "cmd_y", "cmd_z", "cmd_r"]].to_numpy() / 1000.0
        assert len(got) == len(want) + 3 and np.array_equal(got[: len(want)], want)
        assert np.array_equal(got[len(want) :], np.tile([0.0, 0.0, 0.5, 0.0], (3, 1)))  # neutral at the exit
        # the intended command: the sticks the mapping gives for the force the law encoded
        mapping = ArduSubMapping()
        for row in rows.iloc[:: len(rows) // 20].itertuples():
            cmd = mapping.forces_to_manual_control([row.tau_x, row.tau_y, row.tau_psi])
            assert (cmd.x, cmd.y, cmd.z, cmd.r) == (row.cmd_x, row.cmd_y, row.cmd_z, row.cmd_r)
        # and the vehicle received every one (loopback, no loss), the last neutral
        commands = fleet_report["vehicles"][i]["commands"]
        assert len(commands) == len(sent) and commands[-1][1:] == NEUTRAL_STICKS


def test_replay_of_the_run_log_reproduces_its_verdicts(four_at_10hz, certificate, capsys, tmp_path):
    _, cert_file = certificate
    code = main(["replay", str(four_at_10hz["log"]), "--certificate", str(cert_file), "--json"])
    out = json.loads(capsys.readouterr().out)
    summary = four_at_10hz["summary"]
    # the same verdicts: covered or not as the run was (a late step of a busy machine included)
    assert out["reproduced"] is True and out["covered"] is summary["covered"] and code == (0 if out["covered"] else 1)
    assert out["steps"] == summary["steps"] and out["assumptions_match"] is True
    assert out["violation_count"] == summary["violation_count"]
    # the same log in the documented CSV format of real vehicles replays to the same verdicts
    frame = pd.read_parquet(four_at_10hz["log"])
    columns = [c for c in (*CSV_REQUIRED, *CSV_OPTIONAL) if c in frame.columns]
    frame[columns].to_csv(tmp_path / "run.csv", index=False)
    code = main(["replay", str(tmp_path / "run.csv"), "--certificate", str(cert_file), "--json"])
    csv = json.loads(capsys.readouterr().out)
    assert csv["reproduced"] is None and csv["unchecked"] == [] and csv["covered"] is out["covered"]
    assert code == (0 if csv["covered"] else 1) and csv["violation_count"] == out["violation_count"]
    assert csv["steps"] == out["steps"] and csv["max_age"] == pytest.approx(out["max_age"], rel=1e-12)


def _run_cli(capsys, cert_file: Path, urls: list[str], log: Path, *extra: str) -> tuple[int, dict, str]:
    args = [
        "run",
        "--certificate",
        str(cert_file),
        "--duration",
        "3",
        "--log",
        str(log),
        "--json",
        "--realtime",
        *extra,
    ]
    code = main(args + [a for u in urls for a in ("--connect", u)])
    captured = capsys.readouterr()
    return code, json.loads(captured.out.strip().splitlines()[-1]), captured.err


@pytest.fixture
def faulty_fleet(certificate, tmp_path_factory) -> Iterator[tuple[list[str], Path]]:
    """A loopback fleet with :data:`FAULTS`, started on its slots for each fault test (a run leaves the vehicles
    where it ends, and the next run from there would start outside the certified bounds)."""
    report = tmp_path_factory.mktemp("faults") / "fleet.json"
    with fleet(certificate[1], report, *FAULTS) as urls:
        yield urls, report


def test_latency_above_the_delay_trips_the_right_vehicle_and_holds(certificate, faulty_fleet, capsys, tmp_path):
    urls, _ = faulty_fleet
    code, summary, err = _run_cli(capsys, certificate[1], urls, tmp_path / "lat.parquet", "--action", "delay=hold")
    assert code == 1 and "did not cover the run" in err and "Traceback" not in err
    delay = [v for v in summary["violations"] if v["assumption"] == "delay"]
    # the late vehicle at every step, about its 80 ms latency old; the clean ones never (vehicle 1 loses
    # most of its navigation, so its newest message is now and then older than 50 ms too)
    late = [v for v in delay if v["vehicle"] == 2]
    assert len(late) == summary["steps"] and all(0.08 < v["value"] < 0.12 for v in late), late[:3]
    # (a late step of a busy machine may flag a clean vehicle now and then: far fewer than the late one)
    clean = [v for v in summary["violations"] if v["vehicle"] in (0, 3) and v["assumption"] in ("delay", "lag")]
    assert len(clean) <= LATE_STEPS * 2 * summary["steps"], clean[:3]
    assert summary["action"] == "hold" and not summary["covered"]
    log = pd.read_parquet(tmp_path / "lat.parquet")
    first = log.loc[log.violations.str.contains('"delay"'), "step"].min()
    assert (log[log.step >= first].law == "hold").all() and (log[log.step < first].law == "certified").all()
    # its log, with the hold and every violation, replays to the same verdicts
    code = main(["replay", str(tmp_path / "lat.parquet"), "--certificate", str(certificate[1]), "--json"])
    again = json.loads(capsys.readouterr().out)
    assert code == 1 and again["reproduced"] is True and again["violation_count"] == summary["violation_count"]


def test_message_loss_trips_staleness_and_stops_with_neutral(certificate, faulty_fleet, capsys, tmp_path):
    urls, _ = faulty_fleet
    code, summary, err = _run_cli(capsys, certificate[1], urls, tmp_path / "loss.parquet", "--action", "stale=stop")
    assert code == 1 and "stopped by the monitor" in err
    stale = [v for v in summary["violations"] if v["assumption"] == "stale"]
    assert stale and {v["vehicle"] for v in stale} == {1}
    assert summary["stopped_by"] == "monitor" and summary["steps"] < 30
    log = pd.read_parquet(tmp_path / "loss.parquet")
    assert (
        log.law.iloc[-1] == "neutral"
        and (log.loc[log.step == log.step.max(), ["cmd_x", "cmd_y", "cmd_r"]] == 0).all().all()
    )


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM, signal.SIGHUP])
def test_ctrl_c_sends_neutral_and_exits_0(certificate, tmp_path, sig):
    """Ctrl-C, and what ``timeout``, systemd or a closed terminal send (SIGTERM, SIGHUP): neutral to every
    vehicle, one line on stderr, the summary, the log closed and readable, exit 0."""
    _, cert_file = certificate
    report, log = tmp_path / "fleet.json", tmp_path / "int.parquet"
    with fleet(cert_file, report) as urls:
        cmd = _cli(
            "run", "--certificate", str(cert_file), "--duration", "60", "--log", str(log), "--json", "--realtime"
        )
        cmd += [a for u in urls for a in ("--connect", u)]
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        try:
            deadline = time.monotonic() + START_BOUND
            while not log.exists() and time.monotonic() < deadline and proc.poll() is None:
                time.sleep(0.1)
            time.sleep(2.0)  # into the loop: the wait for the vehicles takes well under a second
            proc.send_signal(sig)
            out, err = proc.communicate(timeout=20)
        finally:
            _stop(proc, signal.SIGKILL)
        time.sleep(0.3)
    assert proc.returncode == 0, err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and "interrupted" in lines[0] and "neutral sent to 4 vehicle(s)" in lines[0]
    summary = json.loads(out.strip().splitlines()[-1])
    assert summary["stopped_by"] == signal.Signals(sig).name.lower() and 5 <= summary["steps"] <= 40
    for vehicle in json.loads(report.read_text())["vehicles"]:
        assert vehicle["commands"][-1][1:] == NEUTRAL_STICKS
    assert len(pd.read_parquet(log)) == 4 * summary["steps"]


def test_a_fleet_that_starts_outside_the_certified_bounds_gets_neutral_only(certificate, capsys, tmp_path):
    """A second run on the same loopback fleet starts where the first left the vehicles, metres from the
    mission's slots at t = 0: the first step sees the start outside the certified bounds and sends nothing
    but neutral, whatever the configured actions (the default warns), and the run exits 1 saying so."""
    _, cert_file = certificate
    report = tmp_path / "fleet.json"
    with fleet(cert_file, report) as urls:
        code, first, _ = _run_cli(capsys, cert_file, urls, tmp_path / "first.parquet")
        assert code == 0 and first["covered"], first
        code, again, err = _run_cli(capsys, cert_file, urls, tmp_path / "again.parquet")
    assert code == 1 and again["stopped_by"] == "start" and again["steps"] == 1
    assert "starts outside the certified bounds" in err and "only neutral" in err
    assert _names(again["violations"]) <= {
        "invariant_position",
        "invariant_velocity",
        "invariant_heading",
        "invariant_yaw_rate",
    }
    for vehicle in json.loads(report.read_text())["vehicles"]:
        assert vehicle["commands"][-1][1:] == NEUTRAL_STICKS
