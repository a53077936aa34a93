"""Command-line number parsing: negative and scientific values of numeric options, ranges, vectors."""

from __future__ import annotations

import argparse
import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from auv_hinf.cli import args
from auv_hinf.cli.args import Parser, UsageError, join_numbers, number, numeric, vector


def parser() -> Parser:
    """A parser with two numeric options (both are numeric options of auv-hinf too) and a text one."""
    p = Parser(prog="t")
    numeric(p, "--lam", float)
    numeric(p, "--n", int, 2, 10)
    p.add_argument("--name")
    return p


@given(x=st.floats(allow_nan=False, allow_infinity=False))
def test_every_finite_float_round_trips_through_the_joined_argv(x):
    """repr(x) may read as an option (-1e-05, -1.5e+300); after join_numbers argparse reads the value."""
    ns = parser().parse_args(join_numbers(["--lam", repr(x)]))
    assert ns.lam == x and math.copysign(1.0, ns.lam) == math.copysign(1.0, x)


def test_join_numbers_rewrites_only_numeric_options_followed_by_numbers():
    argv = ["--lam", "-1e-3", "--name", "-1e-3", "--lam", "-x", "--n", "-2", "-1e-3"]
    assert join_numbers(argv) == ["--lam=-1e-3", "--name", "-1e-3", "--lam", "-x", "--n=-2", "-1e-3"]
    assert args.NUMERIC_OPTIONS >= {"--lam", "--n"}


def test_number_checks_kind_finiteness_and_range():
    parse = number(int, 2, 10)
    assert parse("2") == 2 and parse("10") == 10 and isinstance(parse("3"), int)
    for bad, why in (("1", "must be in"), ("11", "must be in"), ("2.5", "an integer"), ("x", "an integer")):
        with pytest.raises(argparse.ArgumentTypeError, match=why):
            parse(bad)
    f = number(float)
    assert f("-1E-3") == -1e-3 and f("-.5") == -0.5
    for bad in ("nan", "inf", "-inf"):
        with pytest.raises(argparse.ArgumentTypeError, match="finite"):
            f(bad)
    with pytest.raises(UsageError, match="--n"):
        parser().parse_args(["--n", "1"])


def test_vector_reads_exactly_size_finite_numbers():
    parse = vector(2, "m/s")
    assert parse("-0.1,0") == (-0.1, 0.0) and parse("1e-3,-2E1") == (1e-3, -20.0)
    for bad in ("1", "1,2,3", "a,b", "nan,0", "1,inf", ""):
        with pytest.raises(argparse.ArgumentTypeError, match=r"2 .*comma-separated numbers \(m/s\)"):
            parse(bad)
