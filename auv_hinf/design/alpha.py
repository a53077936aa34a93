"""Theorem 1 gain design: the paper's alpha, the stabilising Riccati root, the minimal gain.

With ``L = alpha I`` the Riccati equation (37) of the paper is, per channel, the scalar
quadratic (see docs/errata.md)::

    c alpha^2 + 2 lam alpha + 1 = 0,      c = 1/gamma^2 - 2.

Its roots are ``(-lam +- s)/c`` with ``s = sqrt(lam^2 - c)``; they are real iff
``gamma >= 1/sqrt(lam^2 + 2)``. The closed loop of each channel is ``1/(s + alpha - lam)``,
so ``||T||_inf = 1/(alpha - lam)`` exactly (docs/errata.md).

Three designs are offered:

* :func:`alpha_paper` -- eq. (32) exactly as printed. It returns ``alpha = 0`` at
  ``gamma = 1/sqrt(2)``, which leaves a residual of 1 in (37), and below
  ``1/sqrt(2)`` it takes the ``+`` root, which is not the stabilising solution and is a far
  larger gain. Both are flagged on the result.
* :func:`alpha_stabilizing` -- the stabilising root ``lam + c alpha = -s < 0``, the one that
  ``care`` returns, written as ``1/(|lam| + s)``: no cancellation and continuous through
  ``gamma = 1/sqrt(2)`` where it equals ``-1/(2 lam)``.
* :func:`alpha_minimal` -- the smallest alpha with ``||T||_inf <= gamma``:
  ``max(0, 1/gamma + lam)``. It drops the paper's ``K = -L`` restriction.

The hypotheses of Theorem 1 and the numerical regimes of (37) are in :mod:`auv_hinf.design.theorem1`.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from typing import Any

from auv_hinf._typing import GAIN_METHODS, GainMethod

# Re-exported: the Theorem 1 hypotheses live in :mod:`auv_hinf.design.theorem1`.
from auv_hinf.design.theorem1 import (
    NORM_BOUND_RTOL,
    ROOT_RESIDUAL_TOL,
    Theorem1Conditions,
    _check_lam_gamma,
    riccati_c,
    theorem1_conditions,
)
from auv_hinf.exceptions import DesignError, require_finite


@dataclass(frozen=True)
class GainDesign:
    """A Theorem 1 velocity gain ``mu = -alpha Ze`` and its checks.

    Attributes
    ----------
    method : {"paper", "stabilizing", "minimal"}
    lam, gamma : float
        Inputs (1/s and s).
    alpha : float
        The gain, 1/s.
    are_residual : float
        ``c alpha^2 + 2 lam alpha + 1`` of eq. (37); 0 for a root.
    are_stabilizing : bool
        ``lam + c alpha < 0``: alpha is the stabilising solution of (37).
    brl_stabilizing : bool
        ``lam + (1/gamma^2 - 1) alpha < 0``: ``X = alpha I`` is the stabilising solution
        of the bounded-real Riccati equation (35) of the closed loop.
    closed_loop_hinf : float
        ``||T_{Ze w}||_inf = 1/(alpha - lam)`` (s); ``inf`` if the loop is not stable.
    meets_bound : bool
        ``closed_loop_hinf <= gamma``.
    flags : tuple of str
        Human-readable warnings (e.g. where eq. (32) is wrong).
    """

    method: str
    lam: float
    gamma: float
    alpha: float
    are_residual: float
    are_stabilizing: bool
    brl_stabilizing: bool
    closed_loop_hinf: float
    meets_bound: bool
    flags: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dictionary (``inf`` becomes ``None``)."""
        out = asdict(self)
        out["flags"] = list(self.flags)
        if not math.isfinite(self.closed_loop_hinf):
            out["closed_loop_hinf"] = None
        return out


def _evaluate(method: str, lam: float, g: float, alpha: float, flags: list[str]) -> GainDesign:
    c = riccati_c(g)
    residual = c * alpha * alpha + 2.0 * lam * alpha + 1.0
    hinf = 1.0 / (alpha - lam) if alpha > lam else math.inf
    return GainDesign(
        method=method,
        lam=lam,
        gamma=g,
        alpha=alpha,
        are_residual=residual,
        are_stabilizing=lam + c * alpha < 0,
        brl_stabilizing=lam + (1.0 / (g * g) - 1.0) * alpha < 0,
        closed_loop_hinf=hinf,
        meets_bound=hinf <= g * (1.0 + NORM_BOUND_RTOL),
        flags=tuple(flags),
    )


def _require_real_roots(cond: Theorem1Conditions, what: str) -> None:
    if not cond.gamma_ok:
        raise DesignError(
            f"{what}: gamma={cond.gamma:.6g} is below the Theorem 1 bound "
            f"1/sqrt(lambda^2+2)={cond.gamma_min:.6g} (lambda={cond.lam:.6g}); eq. (37) has no "
            "real root. Use method 'minimal', which has no such bound."
        )


def _discriminant_sqrt(lam: float, c: float) -> float:
    # Clamp round-off at the boundary gamma = gamma_min, where s = 0 exactly.
    return math.sqrt(max(lam * lam - c, 0.0))


def alpha_paper(lam: float, gamma: float) -> GainDesign:
    """Eq. (32) exactly as printed, with flags where it is wrong.

    Parameters
    ----------
    lam : float
        Nominal value lambda < 0 (1/s).
    gamma : float
        Bound ``>= 1/sqrt(lam^2 + 2)``.

    Raises
    ------
    DesignError
        If ``lam >= 0`` or gamma is below the bound (no real root).

    Examples
    --------
    >>> round(alpha_paper(-1.2, 2.86).alpha, 6)
    0.330965
    >>> alpha_paper(-1.2, 2**-0.5).are_residual
    1.0
    """
    lam_f, g = _check_lam_gamma(lam, gamma, need_negative_lam=True)
    cond = theorem1_conditions(lam_f, g)
    _require_real_roots(cond, "alpha_paper")
    c = riccati_c(g)
    s = _discriminant_sqrt(lam_f, c)
    flags: list[str] = []
    if cond.regime == "at":
        alpha = 0.0
        flags.append(
            "eq32-at-1/sqrt2: the printed alpha = 0 does not solve eq. (37) (residual 1); "
            f"the root is -1/(2 lambda) = {-0.5 / lam_f:.6g}"
        )
    elif cond.regime == "below":
        alpha = (-lam_f + s) / c
        flags.append(
            "eq32-wrong-branch: below gamma = 1/sqrt2 the printed '+' root is not the "
            "stabilising solution of eq. (37); the norm bound still holds but the gain is "
            f"{alpha / (1.0 / (abs(lam_f) + s)):.3g}x the stabilising one"
        )
    else:
        alpha = (-lam_f - s) / c
    if cond.singular_case:
        flags.append("theorem1-singular-case: |lambda| = 1/gamma - gamma is excluded by Theorem 1")
    return _evaluate("paper", lam_f, g, alpha, flags)


def alpha_stabilizing(lam: float, gamma: float) -> GainDesign:
    """The stabilising root of eq. (37): ``alpha = 1/(|lam| + sqrt(lam^2 - 1/gamma^2 + 2))``.

    This is the root with ``lam + (1/gamma^2 - 2) alpha < 0``, the one ``care`` returns, in
    every regime; it equals ``-1/(2 lam)`` at ``gamma = 1/sqrt(2)``.

    Raises
    ------
    DesignError
        If ``lam >= 0`` or gamma is below ``1/sqrt(lam^2 + 2)``.

    Examples
    --------
    >>> round(alpha_stabilizing(-1.2, 0.70).alpha, 4)
    0.4197
    >>> round(alpha_stabilizing(-1.2, 2**-0.5).alpha, 6)
    0.416667
    """
    lam_f, g = _check_lam_gamma(lam, gamma, need_negative_lam=True)
    cond = theorem1_conditions(lam_f, g)
    _require_real_roots(cond, "alpha_stabilizing")
    c = riccati_c(g)
    alpha = 1.0 / (-lam_f + _discriminant_sqrt(lam_f, c))
    flags: list[str] = []
    if lam_f + (1.0 / (g * g) - 1.0) * alpha >= 0:
        flags.append(
            "near-gamma-min: X = alpha I is not the stabilising solution of the closed-loop "
            "bounded-real equation (35) (lambda + (1/gamma^2 - 1) alpha >= 0); "
            "||T||_inf <= gamma still holds"
        )
    if cond.singular_case:
        flags.append("theorem1-singular-case: |lambda| = 1/gamma - gamma; ||T||_inf equals gamma exactly")
    return _evaluate("stabilizing", lam_f, g, alpha, flags)


def alpha_minimal(lam: float, gamma: float) -> GainDesign:
    """Smallest gain with ``||T_{Ze w}||_inf <= gamma``: ``max(0, 1/gamma + lam)``.

    No ``K = -L`` restriction and no lower bound on gamma; ``lam`` may be any finite value.

    Examples
    --------
    >>> round(alpha_minimal(-1.2, 0.5).alpha, 6)
    0.8
    >>> alpha_minimal(-1.2, 2.86).alpha
    0.0
    """
    lam_f, g = _check_lam_gamma(lam, gamma, need_negative_lam=False)
    result = _evaluate("minimal", lam_f, g, max(0.0, 1.0 / g + lam_f), [])
    if abs(result.are_residual) < ROOT_RESIDUAL_TOL:
        return result
    return replace(
        result, flags=("not-a-root-of-37: the minimal gain drops the paper's K = -L choice, so eq. (37) is not solved",)
    )


def design_alpha(lam: float, gamma: float, method: GainMethod) -> GainDesign:
    """Dispatch to :func:`alpha_paper`, :func:`alpha_stabilizing` or :func:`alpha_minimal`."""
    if method == "paper":
        return alpha_paper(lam, gamma)
    if method == "stabilizing":
        return alpha_stabilizing(lam, gamma)
    if method == "minimal":
        return alpha_minimal(lam, gamma)
    raise DesignError(f"gain method must be one of {GAIN_METHODS}, got {method!r}")


@dataclass(frozen=True)
class PositionLoop:
    """Theorem 2 position loop, per channel ``w -> Ze``: ``s / (s^2 + (alpha - lam) s + k1)``.

    Attributes
    ----------
    k1 : float
        Position gain (1/s^2).
    hinf : float
        Peak gain ``1/(alpha - lam)`` (s).
    peak_frequency : float
        ``sqrt(k1)`` (rad/s), where the peak is reached.
    poles : tuple of complex
        Closed-loop poles of one channel (1/s).
    """

    k1: float
    hinf: float
    peak_frequency: float
    poles: tuple[complex, complex]


def position_loop(lam: float, alpha: float, k1: float) -> PositionLoop:
    """Exact H-infinity norm and poles of the Theorem 2 loop (see docs/errata.md).

    Raises
    ------
    DesignError
        If ``k1 <= 0`` or ``alpha <= lam`` (the loop would not be stable).
    """
    lam_f = require_finite("lambda", lam)
    a = require_finite("alpha", alpha)
    k = require_finite("k1", k1)
    if k <= 0:
        raise DesignError(f"k1 must be > 0 (K1 positive definite), got {k!r}")
    beta = a - lam_f
    if beta <= 0:
        raise DesignError(f"alpha - lambda must be > 0 for a stable loop, got {beta!r}")
    disc = complex(beta * beta - 4.0 * k) ** 0.5
    poles = ((-beta + disc) / 2.0, (-beta - disc) / 2.0)
    return PositionLoop(k1=k, hinf=1.0 / beta, peak_frequency=math.sqrt(k), poles=poles)
