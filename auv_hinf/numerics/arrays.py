"""Memory layout of the batched hot path.

A batch of ``S`` scenarios of ``N`` vehicles holds per-vehicle quantities of shape
``(S, N, k)`` with small ``N`` and ``k`` (3 vehicles, 2-vector components) and per-scenario
ones (plant coefficients, currents, reference motion) that broadcast along ``N``. In numpy's
default C layout every elementwise operation then runs its inner loop over the last, short
axis, paying the loop overhead every 2 or 3 elements. Stacking components with the
*leading* axis fastest in memory (:func:`stack_last`) lets numpy's ``K``-order iteration
run the inner loop over the long scenario axis instead; values are unchanged.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from auv_hinf._typing import FloatArray


def stack_last(parts: Sequence[FloatArray]) -> FloatArray:
    """``np.stack(parts, -1)`` stored with the first axis fastest (Fortran order), same values.

    Parameters
    ----------
    parts : sequence of ndarray
        The components, of one shape or of shapes that broadcast together; ``parts[j]`` becomes
        ``out[..., j]``.
    """
    shapes = {np.shape(p) for p in parts}
    shape = shapes.pop() if len(shapes) == 1 else np.broadcast_shapes(*shapes)
    out: FloatArray = np.empty((*shape, len(parts)), order="F")
    for j, p in enumerate(parts):
        out[..., j] = p
    return out


__all__ = ["stack_last"]
