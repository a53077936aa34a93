"""Shared array alias and the ``Literal`` option types of the public API."""

from __future__ import annotations

from typing import Any, Literal, get_args

import numpy as np
from numpy.typing import NDArray

#: Float arrays of any precision (numpy's ufuncs return ``floating[Any]``).
FloatArray = NDArray[np.floating[Any]]

#: Theorem 1 gain designs.
GainMethod = Literal["paper", "stabilizing", "minimal"]
GAIN_METHODS: tuple[GainMethod, ...] = get_args(GainMethod)

#: Scalings of the Jacobi transform.
JacobiKind = Literal["paper", "orthonormal"]
JACOBI_KINDS: tuple[JacobiKind, ...] = get_args(JacobiKind)

#: Heading law: the corrected eq. (28) or the printed one.
OrientationLaw = Literal["corrected", "printed"]

#: Riccati solver back ends.
RiccatiSolver = Literal["control", "scipy"]

#: Frame of the formation offsets: fixed in the earth frame (the paper) or turning with the path.
FormationFrame = Literal["inertial", "path"]
FORMATION_FRAMES: tuple[FormationFrame, ...] = get_args(FormationFrame)

#: Robust gain synthesis: the bandwidth family, LMI synthesis of the least-force gains, or a search
#: over the composed certificate of the deployed (sampled, delayed, noisy) loop.
SynthesisKind = Literal["bandwidth", "lmi", "deployed"]


__all__ = [
    "FORMATION_FRAMES",
    "GAIN_METHODS",
    "JACOBI_KINDS",
    "FloatArray",
    "FormationFrame",
    "GainMethod",
    "JacobiKind",
    "OrientationLaw",
    "RiccatiSolver",
    "SynthesisKind",
]
