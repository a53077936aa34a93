"""Helpers shared by several test modules (not tests themselves)."""

from __future__ import annotations

import numpy as np

from auv_hinf.models.reference import FleetReference


def starts_from_errors(fleet: FleetReference, errors: np.ndarray) -> np.ndarray:
    """Initial states ``(..., n, 6)`` whose errors against ``fleet`` at ``t = 0`` are ``errors``."""
    m = fleet.motion(0.0)
    e, de, ep, dep = errors[..., 0:2], errors[..., 2:4], errors[..., 4], errors[..., 5]
    psi = m.psi + ep
    vel = m.v + de
    c, s = np.cos(psi), np.sin(psi)
    u, v = c * vel[..., 0] + s * vel[..., 1], -s * vel[..., 0] + c * vel[..., 1]
    return np.concatenate([m.p + e, psi[..., None], u[..., None], v[..., None], (m.r + dep)[..., None]], axis=-1)
