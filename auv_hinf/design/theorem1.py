"""Theorem 1: its hypotheses, the regimes of the scalar Riccati equation (37), and the three gain designs.

With ``L = alpha I`` the Riccati equation (37) of the paper is, per channel, the scalar
quadratic (see docs/errata.md)::

    c alpha^2 + 2 lam alpha + 1 = 0,      c = 1/gamma^2 - 2.

Its roots are ``(-lam +- s)/c`` with ``s = sqrt(lam^2 - c)``; they are real iff
``gamma >= 1/sqrt(lam^2 + 2)``. The closed loop of each channel is ``1/(s + alpha - lam)``,
so ``||T||_inf = 1/(alpha - lam)`` exactly (docs/errata.md). Three designs are offered:

* :func:`alpha_paper` -- eq. (32) exactly as printed. It returns ``alpha = 0`` at
  ``gamma = 1/sqrt(2)``, which leaves a residual of 1 in (37), and below
  ``1/sqrt(2)`` it takes the ``+`` root, which is not the stabilising solution and is a far
  larger gain. Both are flagged on the result.
* :func:`alpha_stabilizing` -- the stabilising root ``lam + c alpha = -s < 0``, the one that
  ``care`` returns, written as ``1/(|lam| + s)``: no cancellation and continuous through
  ``gamma = 1/sqrt(2)`` where it equals ``-1/(2 lam)``.
* :func:`alpha_minimal` -- the smallest alpha with ``||T||_inf <= gamma``:
  ``max(0, 1/gamma + lam)``. It drops the paper's ``K = -L`` restriction.

:func:`theorem1_gains` completes a design into the law's :class:`~auv_hinf.law.gains.Gains`.

Numerical regimes of (37) (:func:`riccati_regime`), shared by every solver route:

* ``"double-root"``: the discriminant ``lam^2 - c`` is zero up to
  :data:`DOUBLE_ROOT_RTOL`; the two roots merge, the Hamiltonian of (37) has a double
  eigenvalue at 0 and ``care`` cannot split it, so solvers use the closed form of the double
  root. :func:`theorem1_conditions` accepts exactly the gammas whose discriminant is
  ``>= -DOUBLE_ROOT_RTOL * scale``, so every accepted gamma has a root on every route;
* ``"lyapunov"``: ``|c|`` is negligible next to ``lam^2`` (:data:`LYAPUNOV_RTOL`); (37) is
  the Lyapunov equation ``2 lam L + I = 0`` to better than round-off of the Riccati routes;
* ``"R>0"`` / ``"R<0"``: ``c < 0`` / ``c > 0``, the two signs of care's weight ``R = -1/c``.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from typing import Any

from auv_hinf._typing import GAIN_METHODS, GainMethod
from auv_hinf.exceptions import DesignError, require_finite
from auv_hinf.law.gains import Gains, heading_gains
from auv_hinf.models.vehicle import VehicleParams

#: ``|1/gamma^2 - 2|`` at or below this is treated as ``gamma = 1/sqrt(2)``. It is about
#: ten ulps of 2, so only the exact value up to round-off takes the singular branch.
GAMMA_SINGULAR_TOL = 1e-14


#: Relative tolerance of the condition ``gamma >= 1/sqrt(lam^2+2)`` (round-off in the bound).
#: The check itself is done on the discriminant with :data:`DOUBLE_ROOT_RTOL`, which is the
#: same tolerance: ``gamma = gamma_min (1 - e)`` gives a discriminant of
#: ``-e (lam^2+2)/(lam^2+1) * scale``, i.e. between ``-e`` and ``-2e`` times the scale.
GAMMA_MIN_RTOL = 1e-12


#: The discriminant ``lam^2 - c = lam^2 + 2 - 1/gamma^2`` of (37) counts as zero (merged roots)
#: when ``|disc| <= DOUBLE_ROOT_RTOL * (lam^2 + 1/gamma^2)``. The scale is the size of the terms
#: that cancel in ``disc``, so its round-off is a few ulps (~1e-15) of the scale; 1e-12 is
#: 1000 times that, and equals :data:`GAMMA_MIN_RTOL` on gamma (see its comment). The same
#: number decides ``gamma_ok`` and the solvers' double-root branch, so an accepted gamma never
#: reaches a solver that cannot handle it.
DOUBLE_ROOT_RTOL = GAMMA_MIN_RTOL


#: (37) is solved as the Lyapunov equation ``2 lam L + I = 0`` when ``|c| <= LYAPUNOV_RTOL *
#: lam^2``. The Lyapunov root ``-1/(2 lam)`` differs from the true root by the relative amount
#: ``|c|/(4 lam^2) + O(c^2) <= 2.5e-13``, far below every Riccati tolerance (ARE_RTOL = 1e-9),
#: while care with ``R = -1/c`` of size ``>= 1e12/lam^2`` is no longer well scaled.
LYAPUNOV_RTOL = 1e-12


#: Relative tolerance under which ``|lam| == 1/gamma - gamma`` counts as the singular case
#: of Theorem 1 (the matrix ``A_lam + (1/gamma^2 - 1) L`` is then singular).
SINGULAR_CASE_RTOL = 1e-9


#: Residual of eq. (37) below which a gain counts as a root (round-off of a quadratic in
#: O(1) numbers).
ROOT_RESIDUAL_TOL = 1e-12


#: Relative slack allowed when testing ``||T||_inf <= gamma`` (round-off only).
NORM_BOUND_RTOL = 1e-12


def riccati_c(gamma: float) -> float:
    """Coefficient ``c = 1/gamma^2 - 2`` of the scalar Riccati equation (37) (s^-2 scaled).

    Parameters
    ----------
    gamma : float
        H-infinity bound (s), nonzero.
    """
    return 1.0 / (gamma * gamma) - 2.0


def gamma_min(lam: float) -> float:
    """Smallest gamma for which (37) has a real root: ``1/sqrt(lam^2 + 2)``.

    Parameters
    ----------
    lam : float
        Nominal value lambda (1/s).
    """
    return 1.0 / math.sqrt(lam * lam + 2.0)


def discriminant(lam: float, gamma: float) -> float:
    """Discriminant ``lam^2 - c = lam^2 + 2 - 1/gamma^2`` of (37) (1/s^2); roots are real iff >= 0.

    Parameters
    ----------
    lam : float
        Nominal value lambda (1/s).
    gamma : float
        H-infinity bound (s), nonzero.
    """
    return lam * lam + 2.0 - 1.0 / (gamma * gamma)


def discriminant_scale(lam: float, gamma: float) -> float:
    """Size ``lam^2 + 1/gamma^2`` of the terms that cancel in :func:`discriminant` (1/s^2).

    Parameters
    ----------
    lam : float
        Nominal value lambda (1/s).
    gamma : float
        H-infinity bound (s), nonzero.
    """
    return lam * lam + 1.0 / (gamma * gamma)


def riccati_regime(lam: float, gamma: float) -> str:
    """Numerical regime of eq. (37): ``"double-root"``, ``"lyapunov"``, ``"R>0"`` or ``"R<0"``.

    See the module docstring; the tolerances are :data:`DOUBLE_ROOT_RTOL` and
    :data:`LYAPUNOV_RTOL`. Every route (care, scipy, LMI) branches on this one function.

    Parameters
    ----------
    lam : float
        Nominal value lambda (1/s).
    gamma : float
        H-infinity bound (s), nonzero.

    Examples
    --------
    >>> riccati_regime(-1.2, 2.86), riccati_regime(-1.2, 0.7), riccati_regime(-1.2, 2**-0.5)
    ('R>0', 'R<0', 'lyapunov')
    >>> riccati_regime(-1.2, gamma_min(-1.2))
    'double-root'
    """
    if discriminant(lam, gamma) <= DOUBLE_ROOT_RTOL * discriminant_scale(lam, gamma):
        return "double-root"
    c = riccati_c(gamma)
    if abs(c) <= LYAPUNOV_RTOL * lam * lam:
        return "lyapunov"
    return "R>0" if c < 0 else "R<0"


def _check_lam_gamma(lam: float, gamma: float, *, need_negative_lam: bool) -> tuple[float, float]:
    lam_f = require_finite("lambda", lam)
    g = require_finite("gamma", gamma)
    if g <= 0:
        raise DesignError(f"gamma must be > 0, got {g!r}")
    if need_negative_lam and lam_f >= 0:
        raise DesignError(f"lambda must be < 0 (a dissipative nominal block, Theorem 1), got {lam_f!r}")
    return lam_f, g


@dataclass(frozen=True)
class Theorem1Conditions:
    """The hypotheses of Theorem 1 for a given ``(lam, gamma)``.

    Attributes
    ----------
    lam : float
        Nominal diagonal value lambda, 1/s.
    gamma : float
        Requested H-infinity bound (s, the unit of ``1/(s - lam)``'s peak).
    gamma_min : float
        ``1/sqrt(lam^2 + 2)``.
    gamma_ok : bool
        ``gamma >= gamma_min``, decided on the discriminant with :data:`DOUBLE_ROOT_RTOL`
        (the tolerance of the solvers' double-root branch).
    gamma_margin : float
        ``gamma - gamma_min``.
    lam_negative : bool
        ``lam < 0``.
    singular_case : bool
        ``|lam| == 1/gamma - gamma`` within :data:`SINGULAR_CASE_RTOL`; excluded by the theorem.
    singular_margin : float
        ``|lam| - (1/gamma - gamma)``.
    regime : str
        ``"above"`` (gamma > 1/sqrt2), ``"at"`` or ``"below"``.
    """

    lam: float
    gamma: float
    gamma_min: float
    gamma_ok: bool
    gamma_margin: float
    lam_negative: bool
    singular_case: bool
    singular_margin: float
    regime: str

    @property
    def all_ok(self) -> bool:
        """True when every hypothesis of Theorem 1 holds."""
        return self.gamma_ok and self.lam_negative and not self.singular_case

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dictionary."""
        out = asdict(self)
        out["all_ok"] = self.all_ok
        return out


def theorem1_conditions(lam: float, gamma: float) -> Theorem1Conditions:
    """Evaluate the hypotheses of Theorem 1.

    Parameters
    ----------
    lam : float
        Nominal value lambda (1/s); the theorem needs ``lam < 0``.
    gamma : float
        Requested bound on ``||T_{Ze w}||_inf`` (> 0).

    Examples
    --------
    >>> c = theorem1_conditions(-1.2, 2.86)
    >>> c.gamma_ok, round(c.gamma_min, 6), c.regime
    (True, 0.539164, 'above')
    """
    lam_f, g = _check_lam_gamma(lam, gamma, need_negative_lam=False)
    gmin = gamma_min(lam_f)
    singular_margin = abs(lam_f) - (1.0 / g - g)
    c = riccati_c(g)
    regime = "at" if abs(c) <= GAMMA_SINGULAR_TOL else ("below" if c > 0 else "above")
    return Theorem1Conditions(
        lam=lam_f,
        gamma=g,
        gamma_min=gmin,
        gamma_ok=discriminant(lam_f, g) >= -DOUBLE_ROOT_RTOL * discriminant_scale(lam_f, g),
        gamma_margin=g - gmin,
        lam_negative=lam_f < 0,
        singular_case=abs(singular_margin) <= SINGULAR_CASE_RTOL * max(abs(lam_f), 1.0 / g),
        singular_margin=singular_margin,
        regime=regime,
    )


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

    Parameters
    ----------
    lam : float
        Nominal value lambda < 0 (1/s).
    gamma : float
        H-infinity bound (s), ``>= 1/sqrt(lam^2 + 2)``.

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

    Parameters
    ----------
    lam : float
        Nominal value lambda (1/s), finite.
    gamma : float
        H-infinity bound (s), > 0.

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
    """Dispatch to :func:`alpha_paper`, :func:`alpha_stabilizing` or :func:`alpha_minimal`.

    Parameters
    ----------
    lam : float
        Nominal value lambda (1/s).
    gamma : float
        H-infinity bound (s), > 0.
    method : {"paper", "stabilizing", "minimal"}
        Which design; anything else raises :class:`DesignError`.
    """
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

    Parameters
    ----------
    lam : float
        Nominal value lambda (1/s).
    alpha : float
        Velocity gain (1/s), ``> lam``.
    k1 : float
        Position gain (1/s^2), > 0.

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


def theorem1_gains(
    params: VehicleParams,
    lam: float,
    gamma: float,
    *,
    method: GainMethod,
    k1: float,
    heading_poles: tuple[float, float],
) -> Gains:
    """The Theorem 1 gains: ``alpha`` of ``method`` at ``(lam, gamma)``, ``k1``, placed heading poles.

    Parameters
    ----------
    params : VehicleParams
        The controller's model (for the heading gains).
    lam : float
        Envelope lambda (1/s).
    gamma : float
        H-infinity bound (s).
    method : {"paper", "stabilizing", "minimal"}
        Theorem 1 gain formula.
    k1 : float
        Position gain (1/s^2).
    heading_poles : tuple of float
        Heading poles (1/s).

    Raises
    ------
    DesignError
        If the method gives no finite gain (e.g. gamma below the Theorem 1 bound).
    """
    alpha = float(design_alpha(lam, gamma, method).alpha)
    if not math.isfinite(alpha):
        raise DesignError(f"no finite gain for method {method!r} at lambda={lam:g}, gamma={gamma:g}")
    return Gains(alpha, k1, heading_gains(params, heading_poles))


__all__ = [
    "DOUBLE_ROOT_RTOL",
    "GAMMA_MIN_RTOL",
    "GAMMA_SINGULAR_TOL",
    "LYAPUNOV_RTOL",
    "NORM_BOUND_RTOL",
    "ROOT_RESIDUAL_TOL",
    "SINGULAR_CASE_RTOL",
    "GainDesign",
    "PositionLoop",
    "Theorem1Conditions",
    "alpha_minimal",
    "alpha_paper",
    "alpha_stabilizing",
    "design_alpha",
    "discriminant",
    "discriminant_scale",
    "gamma_min",
    "position_loop",
    "riccati_c",
    "riccati_regime",
    "theorem1_conditions",
    "theorem1_gains",
]
