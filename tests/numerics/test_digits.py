"""Significant digits rounded in a direction: exact on the decimal form, never on the wrong side."""

from __future__ import annotations

import math

import pytest

from auv_hinf.numerics.digits import significant


@pytest.mark.parametrize(
    "x, digits, up, expected",
    [
        (20.00015, 4, True, 20.01),  # the advised radius that fits, not the declared 20 m
        (20.3999, 4, False, 20.39),
        (0.29, 2, False, 0.29),  # 0.29 / 0.01 is 28.999999999999996 in binary: an exact decimal stays
        (0.140299, 3, True, 0.141),
        (-0.140299, 3, True, -0.14),
        (123456.7, 4, False, 123400.0),
    ],
)
def test_rounded_in_its_direction_and_exact_on_decimals(x, digits, up, expected):
    got = significant(x, digits, up=up)
    assert got == expected
    assert (got >= x) if up else (got <= x)


@pytest.mark.parametrize("x", [0.0, math.inf, -math.inf])
def test_zero_and_non_finite_values_are_returned_as_they_are(x):
    assert significant(x, 3, up=True) == x and significant(x, 3, up=False) == x
