"""Distances between vehicles: the closed-form lower bound of the desired ones, the measured ones.

:func:`slot_separation` bounds ``min_t ||p_d,i(t) - p_d,j(t)||`` from below for every pair of
a :class:`~auv_hinf.mission.fleet.FleetReference`, for all ``t >= 0``, in closed form:

* inertial offsets, ``p_d,i = q + d_i``: the difference is ``d_i - d_j``, constant;
* path-frame offsets, ``p_d,i = q + R(chi) d_i``: the offsets turn together, and
  ``||R(chi) (d_i - d_j)|| = ||d_i - d_j||`` exactly;
* a shaped start adds ``c_i(t) = dp_i h0(t/T_b) + T_h dv_i h1(t/T_h)`` (inertial), so by the
  triangle inequality and the exact sups :data:`~auv_hinf.mission.fleet.H0_SUP`,
  :data:`~auv_hinf.mission.fleet.H1_SUP` of ``|h0|`` and ``|h1|`` on ``[0, 1]`` (both vanish
  for ``t >= T_b``)::

      min_t ||d_ij + c_i - c_j|| >= ||d_ij|| - (H0_SUP ||dp_i - dp_j|| + T_h H1_SUP ||dv_i - dv_j||)

  That bound ignores the direction of the correction and can be far below the truth (the paper's
  triangle start: -27.6 m for desired positions that come 1.10 m apart). The pairs it puts below
  the nearest slot distance are bounded again on a time grid over ``[0, T_b]``, the grid's minimum
  less a Lipschitz gap ``L h / 2`` (``L`` from the sups of ``|h0'|``, ``|h1'|`` and the course's
  turn rate), also sound; the larger of the two bounds is kept.

The closest pair is found with a k-d tree (``scipy.spatial.cKDTree``): the nearest slot distance
``D0`` first, then only the pairs within ``D0 + 2 max_i s_i`` (``s_i`` a vehicle's own shaping
bound), the only ones whose bound can be below ``D0``; ``O(N log N)`` for a start near the slots.

:func:`closest_approach` measures the smallest distance between any two of ``N`` points over
``T`` samples: vectorised pairwise differences on blocks of samples for small fleets, one k-d tree
per sample for large ones, so 1000 vehicles over thousands of samples stay in ``O(N)`` memory.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from auv_hinf._typing import FloatArray
from auv_hinf.exceptions import ParameterError
from auv_hinf.mission.fleet import H0_SUP, H1_SUP, FleetReference, Shaping
from auv_hinf.numerics.integrators import NUMERICAL_FLOOR

#: Fleets up to this size are measured by vectorised pairwise differences; larger ones by k-d trees.
PAIRWISE_MAX_N = 64
#: Pairwise differences held at once by :func:`closest_approach` (about 16 MB of float64 pairs).
PAIR_BLOCK = 1_000_000
#: Relative widening of the candidate radius of :func:`slot_separation` (round-off of the tree's distances).
RADIUS_RTOL = 1e-9
#: Pairs of a shaped start whose desired distance is bounded on a time grid (the others keep the triangle bound).
REFINE_MAX_PAIRS = 4096
#: Target gap (m) between the grid's minimum and the sound bound, and the grid's sizes.
GRID_TOLERANCE = 1e-3
GRID_MIN = 64
GRID_MAX = 20_000


@dataclass(frozen=True)
class SlotSeparation:
    """The closed-form lower bound of the desired distance between any two vehicles, and its pair.

    Attributes
    ----------
    distance : float
        ``min`` over pairs of the lower bound of ``min_t ||p_d,i(t) - p_d,j(t)||`` (m); negative
        when a shaped start may bring two desired positions together.
    pair : tuple of int
        The pair ``(i, j)``, ``i < j`` (0-based), where the bound is smallest.
    slot_distance : float
        ``||d_i - d_j||`` of that pair (m).
    shaping : float
        What the shaped start subtracts for that pair (m; 0 without shaping).
    """

    distance: float
    pair: tuple[int, int]
    slot_distance: float
    shaping: float

    def keeps(self, bound: float, required: float) -> bool:
        """Vehicles each within ``bound`` (m) of their desired positions stay at least ``required`` (m) apart.

        ``distance - 2 bound >= required``, with the bound raised to the integrator's floor
        (:data:`~auv_hinf.numerics.integrators.NUMERICAL_FLOOR`), as a simulated run is judged.

        Parameters
        ----------
        bound : float
            Bound of every vehicle's distance to its desired position (m).
        required : float
            The smallest distance between two vehicles that must be kept (m).
        """
        return self.distance - 2.0 * max(NUMERICAL_FLOOR, bound) >= required

    def to_dict(self) -> dict[str, object]:
        """JSON-safe dictionary (m, 0-based vehicle indices)."""
        return {
            "distance": self.distance,
            "pair": list(self.pair),
            "slot_distance": self.slot_distance,
            "shaping": self.shaping,
        }


def _shaping_terms(fleet: FleetReference) -> tuple[FloatArray, FloatArray, float] | None:
    """``(dp, T_h dv, T_h)`` of the fleet's shaping (``None`` without), scaled by the sups of ``|h0|``, ``|h1|``."""
    sh = fleet.shaping
    if sh is None:
        return None
    n = fleet.offsets.shape[0]
    if sh.dp.shape != (n, 2):
        raise ParameterError(f"slot_separation needs one shaped start (dp of shape ({n}, 2)), got {sh.dp.shape}")
    th = sh.th
    return H0_SUP[0] * sh.dp, th * H1_SUP[0] * sh.dv, th


def slot_separation(fleet: FleetReference) -> SlotSeparation:
    """Lower bound of the desired distance between any two vehicles for all ``t >= 0`` (see the module docstring).

    Parameters
    ----------
    fleet : FleetReference
        The desired motion: offsets in their frame, and at most one shaped start (no batch axes).

    Raises
    ------
    ParameterError
        If the fleet has fewer than two vehicles, or its shaping has batch axes.
    """
    d = fleet.offsets
    n = d.shape[0]
    if n < 2:
        raise ParameterError(f"slot_separation needs at least two vehicles, got {n}")
    tree = cKDTree(d)
    near, idx = tree.query(d, k=2)
    i0 = int(np.argmin(near[:, 1]))
    j0 = int(idx[i0, 1])
    d0 = float(near[i0, 1])
    terms = _shaping_terms(fleet)
    if terms is None:
        i, j = sorted((i0, j0))
        return SlotSeparation(d0, (i, j), d0, 0.0)
    a, b, _ = terms
    own = np.hypot(a[:, 0], a[:, 1]) + np.hypot(b[:, 0], b[:, 1])
    radius = (d0 + 2.0 * float(own.max())) * (1.0 + RADIUS_RTOL)
    pairs = tree.query_pairs(radius, output_type="ndarray")
    if pairs.shape[0] == 0:  # the tree's round-off: the nearest pair is always a candidate
        pairs = np.array([sorted((i0, j0))])
    pi, pj = pairs[:, 0], pairs[:, 1]
    slot = np.linalg.norm(d[pi] - d[pj], axis=-1)
    shift = np.linalg.norm(a[pi] - a[pj], axis=-1) + np.linalg.norm(b[pi] - b[pj], axis=-1)
    low = slot - shift
    # a pair's desired distance ends at its slot distance (t >= T_b): only pairs bounded below d0 can be the closest
    refine = np.argsort(low)[:REFINE_MAX_PAIRS]
    refine = refine[low[refine] < d0]
    if refine.size:
        low[refine] = np.maximum(low[refine], _grid_bound(fleet, pi[refine], pj[refine]))
    k = int(np.argmin(low))
    i, j = sorted((int(pi[k]), int(pj[k])))
    return SlotSeparation(float(low[k]), (i, j), float(slot[k]), float(slot[k] - low[k]))


def _grid_bound(fleet: FleetReference, pi: NDArray[np.intp], pj: NDArray[np.intp]) -> FloatArray:
    """Sound lower bound of ``min_t ||p_d,i - p_d,j||`` (m) of the pairs ``(pi, pj)``: a grid less its Lipschitz gap.

    ``w(t) = p_d,i(t) - p_d,j(t)`` is evaluated by the reference itself on ``M + 1`` points ``h`` apart
    over ``[0, T_b]``; then ``min ||w|| >= min_grid ||w|| - L h / 2`` with ``L`` a bound of ``||w'||``:
    ``H0_SUP[1] ||dp_ij|| / T_b + H1_SUP[1] ||dv_ij||`` for the shaping, plus ``max |chi'| ||d_ij||`` for
    path-frame offsets, which turn with the course. Beyond ``T_b`` the distance is ``||d_ij||``.
    """
    sh = fleet.shaping
    assert sh is not None
    used, inverse = np.unique(np.concatenate([pi, pj]), return_inverse=True)
    ui, uj = inverse[: pi.size], inverse[pi.size :]
    dd, dp, dv = (x[pi] - x[pj] for x in (fleet.offsets, sh.dp, sh.dv))
    lip = H0_SUP[1] * np.linalg.norm(dp, axis=-1) / sh.blend_time + H1_SUP[1] * np.linalg.norm(dv, axis=-1)
    if fleet.frame == "path":
        b = fleet.mission.bounds()
        lip = lip + max(abs(b.turn_rate_min), abs(b.turn_rate_max)) * np.linalg.norm(dd, axis=-1)
    m = int(np.clip(np.ceil(float(lip.max()) * sh.blend_time / (2.0 * GRID_TOLERANCE)), GRID_MIN, GRID_MAX))
    m = max(GRID_MIN, min(m, PAIR_BLOCK // used.size))
    part = Shaping(sh.blend_time, sh.dp[used], sh.dv[used], sh.dpsi[used], sh.dr[used], sh.turn_time)
    sub = FleetReference(fleet.mission, fleet.offsets[used], part, fleet.frame)
    p = sub.kinematics(np.linspace(0.0, sh.blend_time, m + 1))[0][0]  # (M + 1, U, 2)
    gap = np.linalg.norm(p[:, ui] - p[:, uj], axis=-1).min(axis=0)
    out: FloatArray = gap - lip * (sh.blend_time / m) / 2.0
    return out


@dataclass(frozen=True)
class ClosestApproach:
    """The smallest distance between any two vehicles over a run's samples.

    Attributes
    ----------
    distance : float
        ``min`` over samples and pairs of ``||p_i - p_j||`` (m).
    pair : tuple of int
        The pair ``(i, j)``, ``i < j`` (0-based).
    sample : int
        Index of the sample where it occurs.
    """

    distance: float
    pair: tuple[int, int]
    sample: int


def closest_approach(positions: ArrayLike) -> ClosestApproach:
    """The smallest distance between any two of ``N`` points over ``T`` samples (see the module docstring).

    Parameters
    ----------
    positions : array_like, shape (T, N, 2)
        Positions (m) at each sample.

    Raises
    ------
    ParameterError
        If the shape is not ``(T, N, 2)`` with ``T >= 1`` and ``N >= 2``.
    """
    p = np.asarray(positions, dtype=float)
    if p.ndim != 3 or p.shape[0] < 1 or p.shape[1] < 2 or p.shape[2] != 2:
        raise ParameterError(f"closest_approach needs positions of shape (T, N >= 2, 2) (m), got {p.shape}")
    t_count, n, _ = p.shape
    if n <= PAIRWISE_MAX_N:
        iu, ju = np.triu_indices(n, k=1)
        block = max(1, PAIR_BLOCK // iu.size)
        best = (np.inf, (0, 1), 0)
        for lo in range(0, t_count, block):
            chunk = p[lo : lo + block]
            dist = np.hypot(*np.moveaxis(chunk[:, iu] - chunk[:, ju], -1, 0))  # (block, pairs)
            flat = int(np.argmin(dist))
            k, m = divmod(flat, iu.size)
            if dist[k, m] < best[0]:
                best = (float(dist[k, m]), (int(iu[m]), int(ju[m])), lo + k)
        return ClosestApproach(best[0], best[1], best[2])
    best_d, best_pair, best_k = np.inf, (0, 1), 0
    for k in range(t_count):
        near, idx = cKDTree(p[k]).query(p[k], k=2)
        i = int(np.argmin(near[:, 1]))
        if near[i, 1] < best_d:
            other = int(idx[i, 1]) if int(idx[i, 1]) != i else int(idx[i, 0])  # coincident points: either order
            best_d, best_pair, best_k = float(near[i, 1]), (i, other), k
    i, j = sorted(best_pair)
    return ClosestApproach(best_d, (i, j), best_k)


__all__ = [
    "PAIRWISE_MAX_N",
    "PAIR_BLOCK",
    "RADIUS_RTOL",
    "ClosestApproach",
    "SlotSeparation",
    "closest_approach",
    "slot_separation",
]
