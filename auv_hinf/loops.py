"""python-control models of the per-block closed loops and their H-infinity norms."""

from __future__ import annotations

import warnings

import control as ct
import numpy as np

#: control.norm(sys, 'inf') without slycot bisects on Hamiltonian eigenvalues (~1e-6).
NORM_RTOL = 1e-5


def velocity_block(lam: float, alpha: float, dim: int = 2) -> ct.StateSpace:
    """Closed velocity loop ``Ze' = (lam - alpha) Ze + w``, output ``Ze`` (one block: dim 2)."""
    eye = np.eye(dim)
    return ct.ss((lam - alpha) * eye, eye, eye, np.zeros((dim, dim)), name="velocity_block")


def position_block(lam: float, alpha: float, k1: float, dim: int = 2) -> ct.StateSpace:
    """Theorem 2 loop ``[Xe; Ze]' = [[0, I], [-k1 I, (lam - alpha) I]] [Xe; Ze] + [0; I] w``.

    Output ``Ze``; one block has ``dim = 2``.
    """
    eye, zero = np.eye(dim), np.zeros((dim, dim))
    a = np.block([[zero, eye], [-k1 * eye, (lam - alpha) * eye]])
    b = np.vstack([zero, eye])
    c = np.hstack([zero, eye])
    return ct.ss(a, b, c, zero, name="position_block")


def hinf_norm(sys: ct.StateSpace) -> float:
    """H-infinity norm from ``control.norm(sys, 'inf')``; any warning it emits is an error."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return float(ct.norm(sys, "inf"))
