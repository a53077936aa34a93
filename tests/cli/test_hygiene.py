"""Input that validates but is probably a mistake, a closed pipe, and `design --json` that always answers."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from auv_hinf.cli.main import main
from auv_hinf.config.messages import input_warnings
from auv_hinf.design import crosscheck as crosscheck_module
from auv_hinf.exceptions import SolverError


def test_empty_files_are_flagged_and_degrees_are_errors_not_warnings():
    assert input_warnings({}) and "sets nothing" in input_warnings({})[0]
    assert input_warnings({"reference": {"kind": "line", "heading": 90.0}}) == []  # an error now (tests/config)
    assert input_warnings({"reference": {"kind": "line", "heading": 1.0}}) == []


@pytest.mark.parametrize(("sway", "yaw", "warned"), [(9.64, 6.15, True), (-9.64, -6.15, True), (9.64, -6.15, False)])
def test_a_rudder_whose_side_force_and_moment_share_a_sign_is_flagged_as_a_bow_rudder(sway, yaw, warned):
    """Same signs put the side force ahead of the centre of mass; a sign slip of Fossen's convention is common."""
    rudder = {"kind": "underactuated", "tau_x": 67.0, "rudder_max": 0.2, "rudder_sway": sway, "rudder_yaw": yaw}
    lines = input_warnings({"actuators": rudder})
    assert bool(lines) is warned
    if warned:
        assert "actuators.rudder_yaw" in lines[0] and "0.638 m ahead" in lines[0] and "opposite signs" in lines[0]


@pytest.mark.parametrize(
    ("design", "flagged"),
    [({"robust": True, "synthesis": "lmi"}, {"robust", "synthesis"}), ({"integral": True}, {"integral"}), ({}, set())],
)
def test_design_keys_a_guidance_fleet_does_not_read_are_flagged(design, flagged):
    """A torpedo fleet declaring a robust or LMI design of the formation law was certified without a word."""
    lines = input_warnings({"guidance": {"kind": "ilos"}, "design": {"robust": False, **design}})
    assert {line.split(" ")[0].removeprefix("design.") for line in lines} == flagged
    assert all("[guidance] fleet" in line for line in lines)
    assert input_warnings({"design": {"robust": True, "synthesis": "lmi"}}) == []  # read by the formation law


def test_cli_refuses_degrees_with_one_line_naming_the_key(tmp_path, capsys):
    path = tmp_path / "deg.toml"
    path.write_text('[reference]\nkind = "line"\nspeed = 1.0\nheading = 90.0\n', encoding="utf-8")
    assert main(["certify", "--config", str(path), "--json"]) == 2
    out, err = capsys.readouterr()
    assert len(err.splitlines()) == 1
    assert "error" in err and "reference.heading" in err and "degrees" in err and "1.571 rad" in err
    # with --json the same answer is one JSON object on stdout, for a reader that parses only that
    record = json.loads(out)
    assert record["ok"] is False and record["exit_code"] == 2 and "reference.heading" in record["message"]


@pytest.mark.slow
def test_closed_pipe_exits_quietly():
    cmd = [sys.executable, "-c", "from auv_hinf.cli.main import main; raise SystemExit(main())", "schema"]
    with subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE) as proc:
        assert proc.stdout is not None and proc.stderr is not None
        proc.stdout.read(10)
        proc.stdout.close()  # the reader goes away, like `| head -c 10`
        err = proc.stderr.read().decode()
        code = proc.wait()
    assert code == 0 and "Broken pipe" not in err and "error" not in err


def test_design_json_answers_when_a_crosscheck_route_fails(monkeypatch, capsys):
    def broken(*args: object, **kw: object) -> None:
        raise SolverError("Riccati-inequality LMI: Clarabel returned solver error")

    monkeypatch.setattr(crosscheck_module, "crosscheck", broken)
    code = main(["design", "--lam", "-1.2", "--gamma", "2.86", "--json"])
    out = capsys.readouterr()
    data = json.loads(out.out)
    assert code == 1 and data["ok"] is False and "solver error" in data["crosscheck_error"]
    # the closed form still answers: the stabilising root of eq. (37), c a^2 + 2 lam a + 1 = 0
    # with c = 1/gamma^2 - 2
    a, lam, c = data["alpha"]["stabilizing"], -1.2, 1.0 / 2.86**2 - 2.0
    assert c * a * a + 2.0 * lam * a + 1.0 == pytest.approx(0.0, abs=1e-12) and lam + c * a < 0


@pytest.mark.slow
@pytest.mark.parametrize(
    ("argv", "code"),
    [
        (["--help"], 0),
        (["init"], 0),
        (["schema"], 0),
        (["certify", "--config", "BAD"], 2),
        (["simulate", "--config", "BAD"], 2),
    ],
)
def test_help_init_and_bad_input_do_not_load_the_numerical_stack(tmp_path, argv, code):
    """``--help``, ``init``, ``schema``, a bad configuration and ``import auv_hinf`` answer without python-control,
    Matplotlib or CVXPY (about 2.5 s of imports; the commands that certify or simulate load them when they run)."""
    bad = tmp_path / "bad.toml"
    bad.write_text("[formation]\nn = 0\n", encoding="utf-8")
    args = [str(bad) if a == "BAD" else a for a in argv]
    probe = (
        "import sys, contextlib, io; from auv_hinf.cli.main import main; import auv_hinf\n"
        "quiet = contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO())\n"
        f"with quiet[0], quiet[1]: code = main({args!r})\n"
        "heavy = [m for m in ('control', 'matplotlib', 'cvxpy', 'dask') if m in sys.modules]\n"
        "print(code, heavy, auv_hinf.PRESETS[0])"
    )
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=120, check=True)
    assert out.stdout.strip().splitlines()[-1] == f"{code} [] paper-triangle", out.stdout


def test_a_guided_fleet_is_told_which_simulation_keys_it_does_not_read():
    """A review set [simulation] start = "paper" and blend_time on a torpedo fleet and got no word."""
    guided = {"guidance": {"kind": "ilos"}, "simulation": {"start": "paper", "blend_time": 10.0}}
    lines = input_warnings(guided)
    assert len(lines) == 2 and all("not used by a [guidance] fleet" in x for x in lines)
    assert input_warnings({"guidance": {"kind": "ilos"}, "simulation": {"start": "shaped"}}) == []  # init writes it
    assert input_warnings({"simulation": {"start": "paper", "blend_time": 10.0}}) == []  # the formation law reads them
