"""Every error about a command-line option names that option, and no Python class.

The cases are generated from the parser: every option that takes a value gets the values its type
or its choices refuse; every path option (``type=Path``) gets paths that cannot be used, by hand
(an option without a case fails the test); then the values that parse but that the command refuses.
"""

from __future__ import annotations

import argparse
import re
from collections.abc import Iterator
from pathlib import Path

import pytest

from auv_hinf.cli.args import path
from auv_hinf.cli.main import build_parser, main
from tests.helpers import package_class_names

#: Candidate values for an option with a type; those its type refuses are error cases.
CANDIDATES = ("fast", "1e400", "-1e9", "0", "-0", "1e9", "0.5", "1,2", "0,1,1", "1,2,3,4", "")


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    (sub,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    return dict(sub.choices)


def _value_options() -> Iterator[tuple[str, argparse.Action]]:
    """``(command, action)`` of every option that takes a value."""
    for command, parser in _subparsers(build_parser()).items():
        for action in parser._actions:
            if action.option_strings and action.nargs != 0 and action.dest not in ("help", "debug"):
                yield command, action


def _refused(action: argparse.Action) -> list[str]:
    """The candidate values the option's type or choices refuse."""
    if action.choices is not None:
        return ["nope"]
    out = []
    assert action.type is not None
    for text in CANDIDATES:
        try:
            action.type(text)
        except (argparse.ArgumentTypeError, ValueError):
            out.append(text)
    return out


def generated_cases() -> Iterator[tuple[str, list[str], str]]:
    for command, action in _value_options():
        if action.type is path or (action.type is None and action.choices is None):
            continue  # paths by hand, below; any text parses (--scheduler: the command refuses it)
        option = action.option_strings[0]
        for value in _refused(action):
            yield f"{command} {option} {value!r}", [command, f"{option}={value}"], option


def path_cases(tmp: Path) -> dict[tuple[str, str], list[tuple[list[str], str]]]:
    """Unusable paths for every path option: ``(command, option) -> [(argv, the option named)]``."""
    file = tmp / "a-file.txt"
    file.write_text("not a directory\n", encoding="utf-8")
    binary, bad_toml = tmp / "binary.toml", tmp / "bad.toml"
    binary.write_bytes(b"\xff\xfe\x00")
    bad_toml.write_text("[design\n", encoding="utf-8")
    under_file = file / "sub"  # a directory cannot be made inside a file, even by root
    preset = ["--preset", "paper-triangle"]
    out: dict[tuple[str, str], list[tuple[list[str], str]]] = {}
    for command in ("certify", "simulate", "campaign"):
        runs = ["--runs", "2"] if command == "campaign" else []
        out[(command, "--config")] = [
            ([command, *runs, "--out", str(tmp / "o"), "--config", str(p)], "--config")
            for p in (tmp / "missing.toml", tmp, binary, bad_toml)
        ]
        out[(command, "--out")] = [([command, *runs, *preset, "--out", str(p)], "--out") for p in (under_file, file)]
    out[("simulate", "--save")] = [
        (["simulate", *preset, "--save", str(under_file / "x.parquet")], "--save"),
        (["simulate", *preset, "--save", str(tmp / "x.csv")], "--save"),
    ]
    log = tmp / "log.csv"
    log.write_text("not a log\n", encoding="utf-8")
    deploy = {
        "run": ["--connect", "udpin:127.0.0.1:9", "--duration", "1", "--log", str(tmp / "run.parquet")],
        "fleet-sim": ["--listen", "udpout:127.0.0.1:9", "--duration", "1"],
        "replay": [str(log)],
    }
    for command, rest in deploy.items():
        out[(command, "--config")] = [
            ([command, *rest, "--config", str(p)], "--config") for p in (tmp / "missing.toml", bad_toml)
        ]
        out[(command, "--certificate")] = [
            ([command, *rest, "--certificate", str(p)], "--certificate") for p in (tmp / "missing.json", file)
        ]
    out[("run", "--log")] = [(["run", *deploy["run"][:-2], *preset, "--log", str(under_file / "x.parquet")], "--log")]
    out[("fleet-sim", "--report")] = [
        (["fleet-sim", *deploy["fleet-sim"], *preset, "--report", str(under_file / "r.json")], "--report")
    ]
    out[("replay", "--plot")] = [(["replay", str(log), *preset, "--plot", str(under_file / "x.png")], "--plot")]
    out[("init", "--out")] = [
        (["init", "--out", str(file)], "--out"),
        (["init", "--out", str(under_file / "x")], "--out"),
    ]
    for (_, option), cases in out.items():  # an empty name (it would mean the working directory)
        argv = list(cases[0][0])
        argv[argv.index(option) + 1] = ""
        cases.append((argv, option))
    return out


#: Values that parse but that the command refuses, and the option the message names.
REFUSED_BY_THE_COMMAND = [
    (["simulate", "--preset", "paper-triangle", "--current", "100,0"], "--current"),
    pytest.param(  # after the campaign's design (about 1 s)
        ["campaign", "--preset", "paper-triangle", "--runs", "2", "--out", "o", "--scheduler", "no-port"],
        "--scheduler",
        marks=pytest.mark.slow,
    ),
    (["campaign", "--preset", "paper-triangle", "--runs", "2"], "--out"),  # required
    (["certify", "--preset", "paper-triangle", "--config", "x.toml"], "--config"),  # one or the other
    (["campaign", "--preset", "paper-triangle", "--runs", "2", "--workers", "2", "--scheduler", "x"], "--scheduler"),
    (["design", "--gamma", "1"], "--lam"),  # required
]


def _class_names_in(text: str) -> list[str]:
    return [name for name in package_class_names() if re.search(rf"\b{re.escape(name)}\b", text)]


def _check(argv: list[str], option: str, capsys: pytest.CaptureFixture[str]) -> None:
    capsys.readouterr()
    assert main(argv) == 2, argv
    out, err = capsys.readouterr()
    lines = err.splitlines()
    assert out == "" and lines and "Traceback" not in err, (argv, err)
    assert all(line.startswith("auv-hinf: error: ") for line in lines), err
    assert all(option in line for line in lines), (option, err)
    assert _class_names_in(err) == [], err


def test_every_path_option_has_a_case(tmp_path: Path):
    paths = {(c, a.option_strings[0]) for c, a in _value_options() if a.type is path}
    assert paths == set(path_cases(tmp_path))


def test_every_option_with_a_value_is_walked():
    typed = {(c, a.option_strings[0]) for c, a in _value_options() if a.type not in (path, None) or a.choices}
    walked = {(argv[0], argv[1].split("=")[0]) for _, argv, _ in generated_cases()}
    assert typed == walked, typed - walked  # each refuses something


@pytest.mark.slow
@pytest.mark.parametrize(("case", "argv", "option"), list(generated_cases()), ids=lambda x: str(x)[:60])
def test_a_refused_value_names_its_option(case, argv, option, capsys):
    _check(argv, option, capsys)


def test_an_unusable_path_names_its_option(tmp_path: Path, capsys):
    for cases in path_cases(tmp_path).values():
        for argv, option in cases:
            _check(argv, option, capsys)


@pytest.mark.parametrize(("argv", "option"), REFUSED_BY_THE_COMMAND, ids=lambda x: str(x)[:60])
def test_a_value_the_command_refuses_names_its_option(argv, option, capsys, tmp_path: Path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    _check(argv, option, capsys)


def test_the_save_error_of_the_issue_names_save_not_out(capsys):
    argv = ["simulate", "--preset", "paper-triangle", "--save", "/sys/kernel/x.parquet"]
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("auv-hinf: error: --save '/sys/kernel/x.parquet': its folder '/sys/kernel' is not") and (
        "--out" not in err
    )


def test_design_options_take_the_configurations_bounds(capsys):
    """``--lam`` is in ``[-1e6, 0)`` and ``--k1`` in ``(0, 1e6]``, as ``[design] lambda`` and ``k1`` are:
    each end the configuration accepts is accepted, each it refuses is refused with the interval written."""
    assert main(["design", "--lam", "-1e6", "--gamma", "0.5", "--k1", "1e6", "--json"]) == 0
    capsys.readouterr()
    for argv, words in (
        (["--lam", "0", "--gamma", "0.5"], "must be in [-1e+06, 0)"),
        (["--lam", "-1.000001e6", "--gamma", "0.5"], "must be in [-1e+06, 0)"),
        (["--lam", "-1", "--gamma", "0.5", "--k1", "0"], "must be in (0, 1e+06]"),
    ):
        assert main(["design", *argv]) == 2
        assert words in capsys.readouterr().err
