"""The CLI: one error boundary, exit codes 0/1/2, numeric arguments, --out checks, schema and init."""

from __future__ import annotations

import importlib
import json
import math

import numpy as np
import pytest

import auv_hinf
from auv_hinf.certificate.assembly import Certificate, certify
from auv_hinf.certificate.run_plan import plan_run, run_report
from auv_hinf.cli.main import main
from auv_hinf.config.presets import preset_config
from auv_hinf.config.settings import load_config
from auv_hinf.exceptions import SolverError
from auv_hinf.simulation.engine import simulate


def run(argv, capsys):
    capsys.readouterr()
    code = main(argv)
    out, err = capsys.readouterr()
    assert "Traceback" not in err
    assert all(line.startswith("auv-hinf: ") for line in err.splitlines()), err
    return code, out, err


@pytest.mark.slow
@pytest.mark.parametrize("lam", ["-1e-3", "-1E-3", "-2.5e0", "-.5", "-1"])
def test_negative_and_scientific_numbers_parse(lam, capsys):
    code, out, _ = run(["design", "--lam", lam, "--gamma", "1", "--json"], capsys)
    data = json.loads(out)
    assert code == 0 and data["lambda"] == float(lam)
    g, x = 1.0, float(lam)
    assert data["alpha"]["stabilizing"] == pytest.approx(1 / (-x + math.sqrt(x * x - 1 / g**2 + 2)), rel=1e-12)


def test_scientific_gamma_and_equals_form(capsys):
    code, out, _ = run(["design", "--gamma", "2.86e0", "--lam=-1.2e0", "--n", "2", "--json"], capsys)
    assert code == 0 and json.loads(out)["alpha"]["care"] == pytest.approx(0.330965, abs=1e-6)


def test_unwritable_out_exits_2_before_computing(tmp_path, monkeypatch, capsys):
    certificate_module = importlib.import_module("auv_hinf.certificate.assembly")

    def forbidden(*args, **kwargs):
        raise AssertionError("certify must not run")

    monkeypatch.setattr(certificate_module, "certify", forbidden)
    blocker = tmp_path / "file"
    blocker.write_text("x")
    for cmd in ("certify", "simulate"):
        code, out, err = run([cmd, "--preset", "paper-triangle", "--out", str(blocker / "sub")], capsys)
        assert code == 2 and out == "" and err.count("\n") == 1 and "--out" in err and "not a writable directory" in err


@pytest.mark.slow
def test_out_directory_is_created(tmp_path, capsys):
    out = tmp_path / "a" / "b"
    code, _, _ = run(["certify", "--preset", "paper-triangle", "--out", str(out)], capsys)
    assert code == 0 and json.loads((out / "certificate.json").read_text())["certificate"]["certified"] is True
    # the file certify --out writes is the file Certificate.load reads
    loaded = Certificate.load(out / "certificate.json")
    assert loaded.certified and loaded.gains == certify(preset_config("paper-triangle")).gains


def test_unknown_preset_lists_valid_names(capsys):
    code, _, err = run(["certify", "--preset", "paper-square"], capsys)
    assert code == 2 and err.count("\n") == 1 and "paper-triangle" in err and "paper-hexagon" in err


def test_version_and_help(capsys):
    code, out, _ = run(["--version"], capsys)
    assert code == 0 and out.strip() == f"auv-hinf {auv_hinf.__version__}"
    assert run([], capsys)[0] == 0


def test_schema_command(capsys):
    code, out, _ = run(["schema"], capsys)
    schema = json.loads(out)
    assert code == 0 and schema["additionalProperties"] is False and "design" in schema["properties"]


@pytest.mark.slow
def test_init_writes_loadable_config_and_refuses_overwrite(tmp_path, capsys):
    f = tmp_path / "dir" / "start.toml"
    code, out, _ = run(["init", "--out", str(f), "--preset", "paper-hexagon"], capsys)
    assert code == 0 and str(f) in out
    cfg = load_config(f)
    assert cfg.n == 6 and cfg.simulation.initial == preset_config("paper-hexagon").simulation.initial
    f.write_text("# mine\n")
    code, _, err = run(["init", "--out", str(f)], capsys)
    assert code == 2 and "--force" in err and f.read_text() == "# mine\n"
    assert run(["init", "--out", str(f), "--force"], capsys)[0] == 0 and load_config(f).n == 3
    assert run(["certify", "--config", str(f), "--json"], capsys)[0] == 0


def test_init_under_a_file_names_the_file_that_is_not_a_directory(tmp_path, capsys):
    blocker = tmp_path / "notes"
    blocker.write_text("x")
    code, _, err = run(["init", "--out", str(blocker / "sub" / "start.toml")], capsys)
    assert code == 2 and f"{str(blocker)!r} is a file, not a directory" in err and blocker.read_text() == "x"


def test_init_to_stdout(capsys):
    code, out, _ = run(["init"], capsys)
    assert code == 0 and "[design]" in out and "# Theorem 2 position gain [1/s^2]; > 0" in out


def test_config_problems_one_line_each(tmp_path, capsys):
    f = tmp_path / "bad.toml"
    f.write_text("[design]\ngama = 0.5\nk1 = '1'\n[envelope]\nuu = [0, 1]\n")
    code, out, err = run(["certify", "--config", str(f)], capsys)
    assert code == 2 and out == ""
    lines = err.splitlines()
    assert len(lines) == 3 and all(line.startswith("auv-hinf: error: ") and "bad.toml: " in line for line in lines)
    assert any("did you mean 'gamma'?" in line for line in lines)
    assert any("did you mean 'u'?" in line for line in lines)


def test_negative_verdict_exit_1_with_reason(tmp_path, capsys):
    f = tmp_path / "weak.toml"
    f.write_text("[envelope]\nr = [-2, 2]\n[design]\nmethod = 'paper'\ngamma = 0.2\n")  # gamma below the bound
    code, out, err = run(["certify", "--config", str(f)], capsys)
    assert code == 1 and "CERTIFIED: no" in out
    assert err.count("\n") == 1 and err.startswith("auv-hinf: not certified: ") and "Theorem 1 bound" in err


def test_internal_error_is_one_line_exit_3_and_debug_reraises(monkeypatch, capsys):
    crosscheck_module = importlib.import_module("auv_hinf.design.crosscheck")

    def boom(*args, **kwargs):
        raise KeyError("boom\nsecond line")

    monkeypatch.setattr(crosscheck_module, "crosscheck", boom)
    code, _, err = run(["design", "--lam", "-1", "--gamma", "1"], capsys)
    assert (
        code == 3 and err.count("\n") == 1 and err.startswith("auv-hinf: internal error: KeyError") and "--debug" in err
    )
    with pytest.raises(KeyError):
        main(["--debug", "design", "--lam", "-1", "--gamma", "1"])
    with pytest.raises(KeyError):
        main(["design", "--lam", "-1", "--gamma", "1", "--debug"])


@pytest.mark.parametrize("exc", [SolverError("no optimum"), type("SolverError", (Exception,), {})("cvxpy failed")])
def test_solver_failure_exit_1(exc, monkeypatch, capsys):
    crosscheck_module = importlib.import_module("auv_hinf.design.crosscheck")

    def fail(*args, **kwargs):
        raise exc

    monkeypatch.setattr(crosscheck_module, "crosscheck", fail)
    code, _, err = run(["design", "--lam", "-1", "--gamma", "1"], capsys)
    assert code == 1 and err.startswith("auv-hinf: solver failure: ") and err.count("\n") == 1


@pytest.mark.parametrize(
    "argv",
    [
        ["design", "--lam", "-1", "--gamma", "inf"],
        ["design", "--lam", "-1", "--gamma", "1", "--n", "2.5"],
        ["design", "--lam", "-1", "--gamma", "1", "--n", "1000"],
        ["design", "--lam", "-1"],
        ["certify", "--preset", "paper-triangle", "--method", "fast"],
        ["certify", "--config", "/nonexistent/x.toml"],
        ["frobnicate"],
    ],
)
def test_bad_arguments_exit_2(argv, capsys):
    code, out, err = run(argv, capsys)
    assert code == 2 and out == "" and err.count("\n") == 1 and err.startswith("auv-hinf: error: ")


@pytest.mark.slow
def test_simulate_short_horizon_from_config(tmp_path, capsys):
    f = tmp_path / "short.toml"
    f.write_text("[formation]\nn = 2\npolygon_radius = 5.0\n[simulation]\nhorizon = 2.0\ncurrent = [0.05, 0.0]\n")
    code, out, err = run(["simulate", "--config", str(f), "--json"], capsys)
    data = json.loads(out)
    # the file's settings reach the run: its name, fleet size, horizon and current
    assert (data["scenario"], data["n"], data["horizon"], data["start"]) == ("short", 2, 2.0, "shaped")
    assert data["stayed_in_envelope"] is True and data["first_exit_time"] is None
    # the file's current voids the nominal certificate and no robust one is declared: the run is
    # not covered, so the verdict is negative (exit 1) although it stayed inside
    assert data["certificate_covers_run"] is False and "current" in data["coverage_reason"]
    assert code == 1 and "no certificate covers it" in err and "current" in err
    # the numbers are those of the API run of the same file, with its Theorem 1 gains
    cfg = load_config(f)
    plan = plan_run(cfg)
    report = run_report(plan, simulate(plan.scenario))
    lam, gamma = plan.design.lam, plan.design.gamma
    alpha = 1.0 / (-lam + math.sqrt(lam * lam - 1.0 / gamma**2 + 2.0))  # the stabilising root of eq. (37)
    assert data["alpha"] == pytest.approx(alpha, rel=1e-12) and data["alpha"] == plan.scenario.law.gains.alpha
    assert (data["k1"], data["gain_source"]) == (cfg.k1, "theorem1")
    for key in ("final_shape_error", "final_center_error", "max_force", "max_moment", "max_speed", "max_yaw_rate"):
        assert data[key] == pytest.approx(report[key], rel=1e-12, abs=1e-300), key
    assert data["measured_errors"] == pytest.approx(report["measured_errors"], rel=1e-12)


@pytest.mark.slow
def test_simulate_current_and_actuator_options(capsys):
    """--current and --actuators override the TOML; a current voids the nominal certificate's coverage."""
    code = main(
        [
            "simulate",
            "--preset",
            "paper-triangle",
            "--horizon",
            "5",
            "--current",
            "-0.1,0",
            "--actuators",
            "2000,2000,600",
            "--json",
        ]
    )
    data = json.loads(capsys.readouterr().out)
    # exit 0 only for a covered run: a current voids the nominal certificate, so exit 1
    assert code == 1 and data["certificate_covers_run"] is False and "current" in data["coverage_reason"]
    assert np.abs(np.asarray(data["max_force"])) <= 2000.0 + 1e-9
    assert data["actuator_limits"] == {"force_x": 2000.0, "force_y": 2000.0, "moment": 600.0}


@pytest.mark.parametrize("bad", [["--current", "1,2,3"], ["--actuators", "1,2"], ["--current", "a,b"]])
def test_simulate_vector_options_reject_bad_input(bad, capsys):
    assert main(["simulate", "--preset", "paper-triangle", *bad]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1


SAMPLED_TOML = """
name = "tri-sampled"
[simulation]
horizon = 10.0
seed = 7
[implementation]
sample_time = 0.1
delay = 0.1
[implementation.noise]
position = 0.05
velocity = 0.02
heading = 0.01
yaw_rate = 0.005
"""


@pytest.mark.slow
def test_simulate_json_reports_the_implementation_it_ran(tmp_path, capsys):
    path = tmp_path / "sampled.toml"
    path.write_text(SAMPLED_TOML)
    # the composed certificate does not cover these gains at 10 Hz with this delay and noise: the
    # run is about what was simulated, so it is asked for uncertified
    _, out, _ = run(["simulate", "--config", str(path), "--json", "--uncertified"], capsys)
    data = json.loads(out)
    impl = data["implementation"]
    assert impl["sample_time"] == 0.1 and impl["delay"] == 0.1 and impl["seed"] == 7
    assert impl["noise"] == {"position": 0.05, "velocity": 0.02, "heading": 0.01, "yaw_rate": 0.005}
    assert impl["control_period"] == 0.1 and "10 Hz" in impl["description"]
    # noise keeps the errors away from zero: the tail errors are of the noise's size, not of the integrator's
    assert 1e-3 < data["measured_tail_errors"]["position_error"] <= data["measured_errors"]["position_error"]
    assert data["final_position_error"] > 0 and data["diverged_at"] is None
    _, out_again, _ = run(["simulate", "--config", str(path), "--json", "--uncertified"], capsys)
    assert json.loads(out_again)["measured_errors"] == data["measured_errors"]  # seeded: reproducible
    _, text, _ = run(["simulate", "--config", str(path), "--uncertified"], capsys)
    assert "implementation: 10 Hz (0.1 s ZOH), delay 0.1 s, noise <= 0.05 m" in text and "seed 7" in text


@pytest.mark.slow
def test_simulate_json_of_the_continuous_default_says_so(capsys):
    _, out, _ = run(["simulate", "--preset", "paper-triangle", "--horizon", "5", "--json"], capsys)
    impl = json.loads(out)["implementation"]
    assert impl["sample_time"] == 0.0 and impl["control_period"] is None
    assert "continuous" in impl["description"]


@pytest.mark.parametrize("command", ["certify", "simulate"])
def test_the_force_limits_flag_on_a_guidance_fleet_is_bad_input_naming_the_rudder(command, capsys):
    """``--actuators`` sets three force channels; a propeller-and-rudder fleet is refused it in one line (exit 2)."""
    assert main([command, "--preset", "remus-transit-ilos", "--actuators", "10,10,10"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "[guidance]" in err[0] and "rudder_max" in err[0], err


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["--preset", "remus-transit-ilos", "--method", "paper"], ("--method is for", "[guidance]")),
        (["--preset", "remus-transit-ilos", "--design", "nominal"], ("--design is for", "[guidance]")),
    ],
)
def test_certify_gain_options_on_a_guidance_fleet_are_bad_input(argv, words, capsys):
    """A gain option on a fleet the fully actuated law does not steer is one line on stderr and exit 2, not a
    certificate that silently ignored it."""
    assert main(["certify", *argv]) == 2
    captured = capsys.readouterr()
    err = captured.err.strip().splitlines()
    assert captured.out == "" and len(err) == 1 and all(w in err[0] for w in words), err


@pytest.mark.slow
def test_refine_jacobi_where_no_branch_and_bound_runs_is_said_and_changes_nothing(capsys):
    """``--refine-jacobi`` on six vehicles: a warning that the closed-form bound is used, and the same certificate."""
    code = main(["certify", "--preset", "paper-hexagon", "--refine-jacobi", "--json"])
    captured = capsys.readouterr()
    assert "warning: --refine-jacobi" in captured.err and "N = 6" in captured.err
    assert main(["certify", "--preset", "paper-hexagon", "--json"]) == code
    plain = capsys.readouterr()
    assert "--refine-jacobi" not in plain.err and json.loads(plain.out) == json.loads(captured.out)


@pytest.mark.parametrize("command", ["certify", "simulate"])
def test_design_nominal_on_a_file_of_the_robust_design_runs_nominal_gains_or_names_the_flag(command, tmp_path, capsys):
    """``--design nominal`` on a file whose robust design is synthesised runs the Theorem 1 gains (the synthesis
    only chooses robust gains); on a file with integral action, which only the robust design has, the one line
    names the flag, not the file."""
    lmi = tmp_path / "lmi.toml"
    lmi.write_text('[design]\nrobust = true\nsynthesis = "lmi"\n[simulation]\nhorizon = 2.0\n')
    code = main([command, "--config", str(lmi), "--design", "nominal", "--json"])
    captured = capsys.readouterr()
    assert code in (0, 1) and "Traceback" not in captured.err
    data = json.loads(captured.out)
    source = data["gain_source"] if command == "simulate" else data["design"]["method"]
    assert source.startswith("theorem1"), source
    integral = tmp_path / "integral.toml"
    integral.write_text("[design]\nrobust = true\nintegral = true\n")
    assert main([command, "--config", str(integral), "--design", "nominal"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--design nominal" in err[0] and "integral" in err[0], err


def test_a_run_reports_its_closest_pair_as_certify_counts_vehicles():
    """The text names the closest pair counted from 1 (as ``certify`` does), the JSON keeps 0-based indices."""
    from auv_hinf.cli.commands import _report_line

    line = _report_line("min_separation_pair", [0, 3], {"min_separation_pair": "ignored"})
    assert "the 1st and the 4th vehicle" in line and "of the vehicles" not in line
    pair = _report_line("closest_pair", [10, 21], {})
    assert pair.endswith("the 11th and the 22nd vehicle (the JSON counts them from zero)")
    assert _report_line("min_separation", 1.5, {"min_separation": "m"}).strip() == "min_separation: 1.5 m"
