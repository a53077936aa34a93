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

#: How a sampled run's measurement errors are drawn within their bounds
#: (:mod:`auv_hinf.implementation.draws`): at random, or at the bound in a pattern chosen to hurt.
NoisePattern = Literal["uniform", "bang-bang", "bias", "slow", "against-error"]
NOISE_PATTERNS: tuple[NoisePattern, ...] = get_args(NoisePattern)
#: The ``[simulation] noise_pattern`` setting: a pattern, or ``mixed`` (run ``i`` of a campaign gets
#: ``NOISE_PATTERNS[i mod 5]``; a single run the first).
NoisePatternSetting = Literal["uniform", "bang-bang", "bias", "slow", "against-error", "mixed"]

#: Robust gain synthesis: the bandwidth family, LMI synthesis of the least-force gains, or a search
#: over the composed certificate of the deployed (sampled, delayed, noisy) loop.
SynthesisKind = Literal["bandwidth", "lmi", "deployed"]


__all__ = [
    "FORMATION_FRAMES",
    "GAIN_METHODS",
    "JACOBI_KINDS",
    "NOISE_PATTERNS",
    "FloatArray",
    "FormationFrame",
    "GainMethod",
    "JacobiKind",
    "NoisePattern",
    "NoisePatternSetting",
    "OrientationLaw",
    "RiccatiSolver",
    "SynthesisKind",
]
