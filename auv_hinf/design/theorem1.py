"""Theorem 1's hypotheses and the numerical regimes of the scalar Riccati equation (37).

With ``L = alpha I`` eq. (37) is, per channel, ``c alpha^2 + 2 lam alpha + 1 = 0`` with
``c = 1/gamma^2 - 2`` (see :mod:`auv_hinf.design.alpha` and ``docs/derivations/theorem1.md``).

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
from dataclasses import asdict, dataclass
from typing import Any

from auv_hinf.exceptions import DesignError, require_finite

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
    """Coefficient ``c = 1/gamma^2 - 2`` of the scalar Riccati equation (37) (s^-2 scaled)."""
    return 1.0 / (gamma * gamma) - 2.0


def gamma_min(lam: float) -> float:
    """Smallest gamma for which (37) has a real root: ``1/sqrt(lam^2 + 2)``."""
    return 1.0 / math.sqrt(lam * lam + 2.0)


def discriminant(lam: float, gamma: float) -> float:
    """Discriminant ``lam^2 - c = lam^2 + 2 - 1/gamma^2`` of (37) (1/s^2); roots are real iff >= 0."""
    return lam * lam + 2.0 - 1.0 / (gamma * gamma)


def discriminant_scale(lam: float, gamma: float) -> float:
    """Size ``lam^2 + 1/gamma^2`` of the terms that cancel in :func:`discriminant` (1/s^2)."""
    return lam * lam + 1.0 / (gamma * gamma)


def riccati_regime(lam: float, gamma: float) -> str:
    """Numerical regime of eq. (37): ``"double-root"``, ``"lyapunov"``, ``"R>0"`` or ``"R<0"``.

    See the module docstring; the tolerances are :data:`DOUBLE_ROOT_RTOL` and
    :data:`LYAPUNOV_RTOL`. Every route (care, scipy, LMI) branches on this one function.

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
