"""Envelope validation: strict pairs, finite, non-empty, heading at most a full turn."""

from __future__ import annotations

import math

import numpy as np
import pytest

from auv_hinf.exceptions import EnvelopeError
from auv_hinf.models.envelope import PAPER_ENVELOPE, Envelope, check_interval


def test_psi_wider_than_a_turn_rejected():
    with pytest.raises(EnvelopeError, match="envelope psi must span at most a full turn"):
        Envelope(u=(0, 1), v=(0, 1), r=(0, 1), psi=(0, 100))


def test_full_circle_and_shifted_turn_accepted():
    assert Envelope(u=(0, 1), v=(0, 1), r=(0, 1)).psi == (-math.pi, math.pi)
    assert Envelope(u=(0, 1), v=(0, 1), r=(0, 1), psi=(0, 2 * math.pi)).psi[1] == pytest.approx(2 * math.pi)


@pytest.mark.parametrize(
    "value, pattern",
    [
        (("0", 1), "must be a pair .* of numbers"),
        ((True, 1), "must be a pair .* of numbers"),
        ((0, 1, 2), "must be a pair"),
        (3, "must be a pair"),
        ((0, math.inf), "must be finite"),
        ((2, 1), "is empty"),
    ],
)
def test_bad_intervals(value, pattern):
    with pytest.raises(EnvelopeError, match=pattern):
        check_interval("u", value)


def test_numpy_and_int_values_become_floats():
    env = Envelope(u=np.array([0, 2]), v=(np.float32(-1), 1), r=[-0.5, np.int64(1)])
    assert env.u == (0.0, 2.0) and all(type(x) is float for x in env.r + env.v)
    assert env.to_dict() == {"u": [0.0, 2.0], "v": [-1.0, 1.0], "r": [-0.5, 1.0], "psi": [-math.pi, math.pi]}


def test_contains_and_paper_envelope():
    assert PAPER_ENVELOPE.contains(3.5, -1.0, 0.5) and not PAPER_ENVELOPE.contains(3.6, 0, 0)
    assert list(PAPER_ENVELOPE.contains([0, 4], [0, 0], [0, 0])) == [True, False]
