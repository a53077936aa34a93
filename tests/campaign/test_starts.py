"""Campaign start sampling helpers: vertex currents and the box-vertex enumeration."""

from __future__ import annotations

import itertools
from types import SimpleNamespace

import numpy as np
import pytest

from auv_hinf.campaign.starts import RobustStart, vertex_current


def test_vertex_current_has_the_full_speed_in_a_uniform_direction(rng):
    cur = np.array([vertex_current(rng, 0.3) for _ in range(4000)])
    assert np.hypot(cur[:, 0], cur[:, 1]) == pytest.approx(0.3, rel=1e-15)
    # uniform on the circle: mean direction ~ 0 (its standard error is 1/sqrt(2 * 4000) = 0.011)
    assert np.linalg.norm(cur.mean(axis=0)) / 0.3 < 0.05
    quadrants = np.histogram(np.arctan2(cur[:, 1], cur[:, 0]), bins=4, range=(-np.pi, np.pi))[0]
    assert quadrants.min() > 900  # 1000 expected in each
    assert np.array_equal(vertex_current(rng, 0.0), [0.0, 0.0])


@pytest.mark.parametrize("declared", [(), (4,), (0, 3, 8), tuple(range(9))])
def test_vertices_are_the_corners_of_the_declared_parameters(declared, rng):
    """Brute force: runs 0 .. 2^d - 1 are every corner once, bit k of the run setting parameter declared[k]."""
    lo = rng.uniform(0.5, 0.9, 9)
    box = np.column_stack([lo, np.where(np.isin(np.arange(9), declared), lo + 0.2, lo)])
    start = RobustStart(certificate=SimpleNamespace(), declared=declared)  # vertex() reads no certificate
    assert start.vertices == 2 ** len(declared)
    got = [start.vertex(box, i) for i in range(start.vertices)]
    expected = set()
    for ends in itertools.product((0, 1), repeat=len(declared)):
        mult = box[:, 0].copy()
        for k, end in zip(declared, ends):
            mult[k] = box[k, end]
        expected.add(tuple(mult))
    assert {tuple(m) for m in got} == expected and len(got) == len(expected)
    for i, mult in enumerate(got):
        for bit, k in enumerate(declared):
            assert mult[k] == box[k, (i >> bit) & 1]
        undeclared = [k for k in range(9) if k not in declared]
        assert np.array_equal(mult[undeclared], box[undeclared, 0])
