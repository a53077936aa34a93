"""Every number of a text output carries its unit, as ``certify`` prints them (``max_force: 1255.49 N``)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from auv_hinf.certificate.run_plan import REPORT_UNITS
from auv_hinf.cli.commands import _short
from auv_hinf.cli.main import main
from tests.helpers import fully_actuated_file

#: A number in a line of text (not part of a word such as ``d11_lin`` or ``1/sqrt2``).
NUMBER = re.compile(r"(?<![\w./^])[-+]?(?:\d+\.?\d*|\.\d+)(?:e[-+]?\d+)?(?![\w./^])")
#: What may follow a number: a unit (physical, or what is counted), or the closing of a group.
UNIT = re.compile(
    r"\s(m/s\^2|m/s|m|rad/s|rad|N m|N|s|1/s\^3|1/s\^2|1/s|Hz|vehicles|runs/s|runs|vehicle-s/s|steps|violations|vertices"
    r"|of the [\w -]+|in each error's unit)\b"
)
#: Keys whose value is words that may contain numbers with units of their own (a description, a reason).
WORDS = {"scenario", "start", "coverage_reason", "robust_reason", "implementation", "gain_source", "config"}


def unitless_numbers(text: str) -> list[str]:
    """The ``key: value`` lines of ``text`` with a number not followed by a unit."""
    out = []
    for line in text.splitlines():
        key, _, value = line.partition(": ")
        if key.strip() in WORDS:
            continue
        for m in NUMBER.finditer(value):
            if not UNIT.match(value, m.end()):
                out.append(f"{line.strip()!r} at {m.group()!r}")
    return out


def test_the_check_finds_a_number_without_its_unit():
    assert unitless_numbers("   max_force: 1255.49") == ["'max_force: 1255.49' at '1255.49'"]
    assert unitless_numbers("   max_force: 1255.49 N\n   k_psi: [1.5 1/s^2, 1.875 1/s]") == []
    assert unitless_numbers("   counts: {runs: 4 runs, left: 2}") == ["'counts: {runs: 4 runs, left: 2}' at '2'"]


def test_units_reach_numbers_inside_tables_and_lists():
    units = {"final": "m", "max": "m"}
    assert _short({"frame": "path", "final": [1.0, 2.5]}, units) == "{frame: path, final: [1 m, 2.5 m]}"
    assert _short([86.0, 18.5], ("1/s^2", "1/s")) == "[86 1/s^2, 18.5 1/s]"
    assert _short(True, "s") == "True" and _short(3, "vehicles") == "3 vehicles"


@pytest.mark.slow
@pytest.mark.parametrize("rudder", [False, True], ids=["fully-actuated", "rudder"])
def test_simulate_prints_every_number_with_its_unit(tmp_path: Path, capsys: pytest.CaptureFixture[str], rudder: bool):
    if rudder:  # the REMUS's propeller and rudder: uncertified, simulated on request, limits in N and rad
        assert main(["simulate", "--preset", "remus-line", "--horizon", "3", "--uncertified"]) == 1
    else:
        assert main(["simulate", "--config", str(fully_actuated_file("remus-line", tmp_path)), "--horizon", "3"]) == 0
    out = capsys.readouterr().out
    assert "max_force: " in out and re.search(r"max_force: [\d.e+-]+ N\n", out)
    assert unitless_numbers(out) == []
    numeric = {line.split(":")[0].strip() for line in out.splitlines() if NUMBER.search(line.partition(": ")[2])}
    assert numeric - WORDS <= set(REPORT_UNITS)


@pytest.mark.slow
def test_campaign_and_design_print_every_number_with_its_unit(tmp_path: Path, capsys: pytest.CaptureFixture[str]):
    assert (
        main(["campaign", "--preset", "paper-triangle", "--runs", "2", "--horizon", "3", "--out", str(tmp_path)]) == 0
    )
    out = capsys.readouterr().out
    assert "runs_per_second" in out and unitless_numbers(out) == []
    assert main(["design", "--lam", "-1.2", "--gamma", "2.86"]) == 0
    out = capsys.readouterr().out
    checked = [line for line in out.splitlines() if not line.startswith("max relative difference")]  # a ratio
    assert "alpha[stabilizing] = 0.330964979 1/s" in out
    assert unitless_numbers("\n".join(line.replace(" = ", ": ", 1) for line in checked)) == []
    norms = next(line for line in out.splitlines() if line.startswith("||T||_inf"))
    assert unitless_numbers(norms.replace(") ", "): ", 1)) == [] and re.search(r"exact [\d.]+ s", norms)
    # below the stabilising regime the norms do not exist: said in words, not "None s"
    assert main(["design", "--lam", "-1.2", "--gamma", "0.1"]) == 0
    out = capsys.readouterr().out
    assert "None" not in out and "||T||_inf (stabilizing gain) n/a" in out


@pytest.mark.slow
def test_a_guided_fleets_simulate_and_campaign_print_every_number_with_its_unit(tmp_path: Path, capsys):
    """The torpedo path's text: the saturated share, the run counts, the ratios and the implementation's
    figures each with its unit (a review found them bare); the seed is a name, not a quantity."""
    assert main(["simulate", "--preset", "remus-transit-ilos", "--horizon", "5"]) == 0
    out = capsys.readouterr().out
    assert "saturation_fraction: 0 of the samples" in out and unitless_numbers(out) == []
    assert "None" not in out  # a null (no noise, never left the envelope) is the JSON's, not the text's
    assert (
        main(["campaign", "--preset", "remus-transit-ilos", "--runs", "2", "--horizon", "5", "--out", str(tmp_path)])
        == 0
    )
    out = capsys.readouterr().out
    lines = [line for line in out.splitlines() if line.partition(": ")[0].strip() not in ("seed", "notes")]
    assert "vertex_runs: 1 runs" in out and unitless_numbers("\n".join(lines)) == []
