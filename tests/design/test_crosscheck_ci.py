"""CI job: analytic versus LMI gains on a fixed (lam, gamma) grid (part of `make test`)."""

from __future__ import annotations

import pytest

from auv_hinf.design.crosscheck import crosscheck

GRID = [(lam, g) for lam in (-2.1, -1.2, -0.4) for g in (0.45, 0.6, 2**-0.5, 0.9, 2.86)]


@pytest.mark.slow
@pytest.mark.ci_crosscheck
@pytest.mark.parametrize("lam, gamma", GRID)
def test_analytic_vs_lmi_grid(lam, gamma):
    r = crosscheck(lam, gamma, 3)
    failing = [c for c in r.checks if not c.ok]
    assert r.ok, failing
    assert r.max_rel_diff < 1e-5
