"""The velocities a vehicle reaches within error bounds: cell ranges, margins and the operating envelope."""

from __future__ import annotations

import numpy as np
import pytest

from auv_hinf.mission.margins import ErrorBounds, cell_margins, cell_velocities, operating_envelope
from auv_hinf.mission.paths import CircleReference, LineReference
from auv_hinf.mission.tubes import mission_tube
from auv_hinf.models.envelope import Envelope

ENV = Envelope(u=(-0.5, 1.0), v=(-0.5, 0.5), r=(-0.5, 0.5))


@pytest.mark.parametrize(
    "ref", [LineReference(speed=0.4), LineReference(speed=0.3, heading=1.0), CircleReference(radius=20.0, speed=0.3)]
)
@pytest.mark.parametrize("bounds", [ErrorBounds(0.1, 0.05, 0.02, 0.03), ErrorBounds(0.0, 0.2, 0.3, 0.1)])
def test_operating_envelope_holds_every_cell_widened_and_clipped(ref, bounds) -> None:
    tube = mission_tube(ref)
    u_lo, u_hi, v_lo, v_hi, r_lo, r_hi = cell_velocities(tube, bounds)
    op = operating_envelope(tube, bounds, ENV, 0.05)
    for (lo, hi), (c_lo, c_hi), (e_lo, e_hi) in zip(
        (op.u, op.v, op.r), ((u_lo, u_hi), (v_lo, v_hi), (r_lo, r_hi)), (ENV.u, ENV.v, ENV.r), strict=True
    ):
        a, b = float(c_lo.min()), float(c_hi.max())
        pad = 0.05 * max(abs(a), abs(b))
        assert lo == pytest.approx(max(e_lo, a - pad), abs=1e-15) and hi == pytest.approx(min(e_hi, b + pad), abs=1e-15)
        assert e_lo <= lo and hi <= e_hi
    # every cell's velocities are inside it, strictly where the declared envelope does not clip
    m = cell_margins(tube, bounds, op)
    assert np.all(m >= 0.0)
    unclipped = np.array([op.u[1] < ENV.u[1], op.u[0] > ENV.u[0], op.v[1] < ENV.v[1], op.v[0] > ENV.v[0]])
    assert np.all(m.min(axis=0)[:4][unclipped] > 0.0)


def test_operating_envelope_grows_with_the_bounds_and_is_the_margins_complement() -> None:
    tube = mission_tube(LineReference(speed=0.4))
    small, large = ErrorBounds(0.0, 0.05, 0.01, 0.02), ErrorBounds(0.0, 0.1, 0.05, 0.04)
    a, b = operating_envelope(tube, small, ENV, 0.0), operating_envelope(tube, large, ENV, 0.0)
    assert b.u[0] < a.u[0] < a.u[1] < b.u[1] and b.v[1] > a.v[1] and b.r[1] > a.r[1]
    # unwidened, the hull touches the cells: the margins against it are zero at its edges
    m = cell_margins(tube, small, a).min(axis=0)
    np.testing.assert_allclose(m, 0.0, atol=1e-15)
