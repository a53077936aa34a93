"""``robstab``-style margins: how far the declared box can grow, certified and exhibited.

The box and the current bound are scaled together about the nominal
(:meth:`~auv_hinf.robust.box.ParameterBox.scaled`, ``current * s``).

* ``lower``: the largest scale at which :func:`~auv_hinf.robust.invariant_set.robust_certificate` still
  covers (bisection; every scale reported was itself certified, and a certificate for a box
  covers every smaller box).
* ``upper``: the smallest scale at which a destabilising plant is exhibited. The per-vehicle
  closed loop on a straight line at the tube's top speed is time invariant in error
  coordinates; its trim is found with ``scipy.optimize.root`` and its Jacobian by central
  differences of the simulator's own right-hand side. An eigenvalue in the right half plane
  makes the trim unstable for the nonlinear loop too (Lyapunov's indirect method). Candidates
  are the mass corners, with all damping low or all high, and head, tail and cross currents.
* ``linearised``: the largest scale at which the linearised heading stiffness
  ``m33_hat k1psi + dM (W_par^2 - W_perp^2)`` and damping ``m33_hat k2psi + d33_lin`` stay
  positive for every plant and current (both are affine in the box corners, so the vertex test
  is exact), next to the exhibited ``upper``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.optimize import root

from auv_hinf._typing import FloatArray, SynthesisKind
from auv_hinf.actuation.limits import Actuators
from auv_hinf.law.formation_law import VehicleLaw
from auv_hinf.law.gains import Gains
from auv_hinf.mission.fleet import Motion, ReferenceTube
from auv_hinf.models.envelope import Envelope
from auv_hinf.models.vehicle import VehicleParams, ground_velocity, rhs
from auv_hinf.numerics.bisection import bisect, largest_holding
from auv_hinf.robust.bandwidth import design_robust
from auv_hinf.robust.box import PARAMETERS, ParameterBox
from auv_hinf.robust.invariant_set import robust_certificate
from auv_hinf.robust.synthesis import synthesise_robust

#: Bisection steps of the certified scale (resolution ``cap / 2**7``, under 1 % of a cap of 5).
LOWER_STEPS = 7
#: Bisection steps of the exhibited scale along one corner direction.
UPPER_STEPS = 16
#: Largest scale searched when the box allows more (a 10x box is far beyond any declared one).
SCALE_CAP = 10.0
#: A trim is accepted when its residual is below this times the speed scale (m/s, m/s^2).
TRIM_RTOL = 1e-9
#: An eigenvalue counts as unstable above this times ``max(1, |eig|_max)`` (1/s): far above the
#: central-difference error (step 1e-6 relative, error ~1e-10 of the Jacobian's scale).
UNSTABLE_RTOL = 1e-6


@dataclass(frozen=True)
class Witness:
    """A destabilising plant and current.

    Attributes
    ----------
    scale : float
        Box scale of the plant (the corner direction times ``scale``).
    multipliers : dict
        Plant multipliers of the nine parameters.
    current : tuple of float
        Current (m/s, inertial, the line runs along +x).
    max_real : float
        Largest real part of the trim's closed-loop eigenvalues (1/s).
    """

    scale: float
    multipliers: dict[str, float]
    current: tuple[float, float]
    max_real: float

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dictionary."""
        return {
            "scale": self.scale,
            "multipliers": self.multipliers,
            "current": list(self.current),
            "max_real": self.max_real,
        }


@dataclass(frozen=True)
class RobustMargin:
    """Certified and exhibited box scales.

    Attributes
    ----------
    lower : float
        Largest certified scale (``cap`` when the whole searched range certifies).
    upper : float or None
        Smallest scale with an exhibited destabilising plant (``None``: none up to ``cap``).
    witness : Witness or None
    linearised_lower : float
        Largest scale at which the linearised heading loop is stable for every corner.
    cap : float
        Largest scale searched.
    """

    lower: float
    upper: float | None
    witness: Witness | None
    linearised_lower: float
    cap: float

    def to_dict(self) -> dict[str, Any]:
        """The ``margin`` object of ``certify --json``'s ``robust`` part."""
        up = self.upper
        return {
            "lower": self.lower,
            "upper": up,
            "ratio": None if up is None else self.lower / up,
            "witness": None if self.witness is None else self.witness.to_dict(),
            "linearised": {
                "lower": self.linearised_lower,
                "upper": up,
                "ratio": None if up is None else self.linearised_lower / up,
            },
            "scale_cap": self.cap,
        }


def certified_scale(check: Callable[[float], bool], cap: float, steps: int = LOWER_STEPS) -> float:
    """Largest scale in ``[0, cap]`` found by bisection at which ``check`` holds (0 if none).

    Parameters
    ----------
    check : callable
        ``check(scale)``: whether the certificate holds at that box scale.
    cap : float
        Largest scale searched; with ``cap > 1`` scale 1 is checked first.
    steps : int
        Bisection steps.
    """
    if check(cap):
        return cap
    lo, hi = 0.0, cap
    if cap > 1.0:  # the declared box (scale 1) first: it splits the search where it matters
        lo, hi = (1.0, cap) if check(1.0) else (0.0, 1.0)
    return bisect(check, lo, hi, steps=steps)[0]


def _error_rhs(
    law: VehicleLaw, plant: VehicleParams, speed: float, current: FloatArray
) -> Callable[[FloatArray], FloatArray]:
    motion = Motion(
        p=np.zeros((1, 2)),
        v=np.array([[speed, 0.0]]),
        a=np.zeros((1, 2)),
        psi=np.zeros(1),
        r=np.zeros(1),
        r_dot=np.zeros(1),
    )

    def f(z: FloatArray) -> FloatArray:
        s = np.asarray(z, dtype=float).reshape(1, law.width)  # with integral action: the integrator last
        p_dot = ground_velocity(s, current)
        d = rhs(plant, s[:, :6], law.forces(s, p_dot, motion))[0]
        return np.array([p_dot[0, 0] - speed, p_dot[0, 1], d[2], d[3], d[4], d[5], *s[0, 0 : law.width - 6]])

    return f


def trim_max_real(law: VehicleLaw, plant: VehicleParams, speed: float, current: FloatArray) -> float | None:
    """Largest real part (1/s) of the linearised loop at the straight-line trim, or ``None``.

    ``None`` when no trim is found (then nothing is exhibited).

    Parameters
    ----------
    law : VehicleLaw
        The law on the controller's model.
    plant : VehicleParams
        The (perturbed) plant.
    speed : float
        Speed of the straight-line reference along +x (m/s).
    current : ndarray, shape (2,)
        The current (m/s, inertial frame).
    """
    f = _error_rhs(law, plant, speed, current)
    w = law.width
    z0 = np.zeros(w)
    z0[3:5] = speed - current[0], -current[1]
    sol = root(f, z0, method="hybr")
    if not sol.success or not np.all(np.abs(f(sol.x)) <= TRIM_RTOL * max(1.0, speed)):
        return None
    z = sol.x
    jac = np.empty((w, w))
    for k in range(w):
        h = 1e-6 * max(1.0, abs(z[k]))
        dz = np.zeros(w)
        dz[k] = h
        jac[:, k] = (f(z + dz) - f(z - dz)) / (2.0 * h)
    eig = np.linalg.eigvals(jac)
    return float(eig.real.max())


def _law(box: ParameterBox, gains: Gains) -> VehicleLaw:
    """The law of ``gains`` on the controller's (nominal) model."""
    return VehicleLaw(params=box.nominal, gains=gains)


def _current_directions(current: float) -> list[FloatArray]:
    """Unit directions of the candidate currents (head, tail, both crosses); none without a current."""
    if current <= 0:
        return [np.zeros(2)]
    return [np.array(d) for d in ((-1.0, 0.0), (1.0, 0.0), (0.0, 1.0), (0.0, -1.0))]


def _corners(box: ParameterBox) -> list[FloatArray]:
    """Directions ``m_corner - 1`` of the mass corners with all damping low or all high."""
    masses = box.vertices(("m11", "m22", "m33"))
    out: list[FloatArray] = []
    for m in masses:
        for end in (box.lo, box.hi):
            mult = np.array(end, dtype=float)
            mult[:3] = m[:3]
            out.append(mult - 1.0)
    return out


def exhibited_scale(
    box: ParameterBox, gains: Gains, speed: float, current: float, cap: float, guess: float | None = None
) -> Witness | None:
    """Smallest scale with a destabilising corner plant and current (see the module docstring).

    Parameters
    ----------
    box : ParameterBox
        The declared box, scaled about the nominal.
    gains : Gains
        The law's gains.
    speed : float
        Speed of the straight-line reference (m/s), the tube's top speed.
    current : float
        Declared current speed (m/s), scaled with the box.
    cap : float
        Largest scale searched.
    guess : float, optional
        A scale (e.g. :func:`linearised_scale`) that only narrows the search: the candidates
        bisected are those unstable at ``min(cap, 1.25 guess)`` (all those unstable at ``cap``
        if none is).
    """
    law = _law(box, gains)
    dirs = _current_directions(current)

    def unstable(u: FloatArray, d: FloatArray, s: float) -> float | None:
        plant = box.plant(1.0 + s * u)
        mr = trim_max_real(law, plant, speed, s * current * d)
        return mr if mr is not None and mr > UNSTABLE_RTOL * max(1.0, abs(mr)) else None

    combos = [(u, d) for u in _corners(box) for d in dirs]
    top = cap
    found = [] if guess is None else [(u, d) for u, d in combos if unstable(u, d, min(cap, 1.25 * guess)) is not None]
    if found:
        top = min(cap, 1.25 * guess) if guess is not None else cap
    else:
        found = [(u, d) for u, d in combos if unstable(u, d, cap) is not None]
    best: Witness | None = None
    for u, d in found:

        def stable(m: float, u: FloatArray = u, d: FloatArray = d) -> bool:
            return unstable(u, d, m) is None

        hi = bisect(stable, 0.0, top, steps=UPPER_STEPS)[1]
        if best is None or hi < best.scale:
            mr = unstable(u, d, hi)
            best = Witness(
                hi,
                {n: float(x) for n, x in zip(PARAMETERS, 1.0 + hi * u)},
                (float(hi * current * d[0]), float(hi * current * d[1])),
                float(mr if mr is not None else math.nan),
            )
    return best


def linearised_scale(box: ParameterBox, gains: Gains, speed: float, current: float, cap: float) -> float:
    """Largest scale at which the linearised heading loop is stable for every plant and current.

    Parameters
    ----------
    box : ParameterBox
        The declared box, scaled about the nominal.
    gains : Gains
        The law's gains (the heading gains enter).
    speed : float
        Speed of the straight-line reference (m/s).
    current : float
        Declared current speed (m/s), scaled with the box.
    cap : float
        Largest scale searched.
    """
    m33 = box.nominal.m33

    def stable(s: float) -> bool:
        b = box.scaled(s)
        rho = s * current
        x_max = (speed + rho) ** 2
        x_min = speed**2 / 2.0 - rho**2 if speed <= 2.0 * rho else (speed - rho) ** 2
        k = m33 * gains.k_psi[0] + min(a * x for a in b.dm_range() for x in (x_min, x_max))
        c = m33 * gains.k_psi[1] + b.interval("d33_lin")[0]
        return k > 0.0 and c > 0.0

    return certified_scale(stable, cap, steps=UPPER_STEPS)


def robust_margin(
    box: ParameterBox,
    gains: Gains,
    speed: float,
    current: float,
    covers: Callable[[float], bool],
) -> RobustMargin:
    """Margins of ``gains``: ``covers(s)`` says whether the certificate covers the ``s``-scaled box.

    Parameters
    ----------
    box : ParameterBox
        The declared box.
    gains : Gains
        The law's gains.
    speed : float
        Speed of the straight-line reference for the exhibited scale (m/s).
    current : float
        Declared current speed (m/s).
    covers : callable
        ``covers(scale)``: whether the robust certificate covers the box (and current) scaled so.
    """
    cap = min(SCALE_CAP, box.max_scale) if box.declared else SCALE_CAP
    lower = certified_scale(covers, cap)
    lin = linearised_scale(box, gains, speed, current, cap)
    witness = exhibited_scale(box, gains, speed, current, cap, lin) if (box.declared or current > 0) else None
    return RobustMargin(lower, None if witness is None else witness.scale, witness, lin, cap)


def weakest_corner(box: ParameterBox, gains: Gains, speed: float, current: float) -> Witness | None:
    """The corner plant and current (scale 1) whose linearised trim has the largest real part.

    Parameters
    ----------
    box : ParameterBox
        The declared box.
    gains : Gains
        The law's gains.
    speed : float
        Speed of the straight-line reference (m/s).
    current : float
        Declared current speed (m/s).
    """
    law = _law(box, gains)
    dirs = _current_directions(current)
    best: Witness | None = None
    for u in _corners(box):
        for d in dirs:
            mr = trim_max_real(law, box.plant(1.0 + u), speed, current * d)
            if mr is not None and (best is None or mr > best.max_real):
                mult = {n: float(x) for n, x in zip(PARAMETERS, 1.0 + u)}
                best = Witness(1.0, mult, (float(current * d[0]), float(current * d[1])), mr)
    return best


#: Bisection steps of :func:`largest_certifiable` with fixed gains: the answer is within 2^-12
#: (0.02 %) of the declared value below the true largest certifiable value, never above it.
BISECTION_STEPS = 12


#: With ``[design] robust = true`` a re-run of ``certify`` re-designs the gains for the smaller
#: box or current, so each answer found with the design's gains is confirmed by re-running the
#: robust design there; an answer that does not confirm is halved, at most this many times.
REDESIGN_TRIES = 3


def largest_certifiable(
    box: ParameterBox,
    envelope: Envelope,
    tube: ReferenceTube,
    gains: Gains,
    current: float,
    act: Actuators | None,
    *,
    redesign: SynthesisKind | None = None,
    integral: bool = False,
) -> dict[str, Any]:
    """A box scale and a current speed that certify together within ``act``, largest first.

    ``box``, ``current`` (m/s) and the ``gains`` are the declared design along ``tube`` in
    ``envelope``. With ``redesign`` (the ``[design] synthesis`` of a robust design) every answer
    found with ``gains`` is confirmed by re-running that design there, as a re-run of ``certify``
    would; ``integral`` is the design's ``[design] integral``.

    ``box_scale`` and ``current_speed`` are a pair to re-run with (``uncertainty`` gives the
    scaled ``[uncertainty]`` table); ``box_scale_alone`` (declared current) and
    ``current_speed_alone`` (declared box) are the largest of each with the other unchanged.
    Each is ``None`` when it does not apply (nothing of that kind declared) or when not even
    zero certifies.

    Parameters
    ----------
    box : ParameterBox
        The declared box.
    envelope : Envelope
        Operating envelope.
    tube : ReferenceTube
        Bounds of the desired motion.
    gains : Gains
        The design's gains.
    current : float
        Declared current speed (m/s).
    act : Actuators or None
        The force limits (N, N, N m); ``None``: none declared (the answer then certifies the box and
        current alone).
    redesign : {"bandwidth", "lmi"}, optional
        The ``[design] synthesis`` of a robust design whose answers are confirmed by re-running it.
    integral : bool
        The design's ``[design] integral``.
    """
    out: dict[str, Any] = {"box_scale": None, "current_speed": None}

    def fits(scale: float, speed: float) -> bool:
        return robust_certificate(box.scaled(scale), envelope, tube, gains, speed, act, until_covered=True).covers

    def redesign_fits(scale: float, speed: float) -> bool:
        b = box.scaled(scale)
        if redesign == "lmi":
            design = synthesise_robust(b, envelope, tube, speed, act, integral=integral)
        else:
            design = design_robust(b, envelope, tube, speed, act, fallback=False, integral=integral)
        return (
            design.target > 0.0
            and robust_certificate(b, envelope, tube, design.gains, speed, act, until_covered=True).covers
        )

    def answer(scale_of: Any, top: float) -> float | None:
        """Bisection with the design's gains; with a robust design, confirmed by re-running it."""
        x = largest_holding(lambda v: fits(*scale_of(v)), top, steps=BISECTION_STEPS)
        if x is None or redesign is None:
            return x
        for _ in range(REDESIGN_TRIES):
            if redesign_fits(*scale_of(x)):
                return x
            x *= 0.5
        return None

    top = min(1.0, box.max_scale)
    alone_box = answer(lambda s: (s, current), top) if box.declared else None
    alone_current = answer(lambda c: (1.0, c), current) if current > 0.0 else None

    def pair_fits(scale: float, speed: float) -> bool:
        return fits(scale, speed) and (redesign is None or redesign_fits(scale, speed))

    # the pair to re-run with: each answer alone holds the other at its declared value, so one
    # of them alone is a certified pair; when both shrink, the pair is confirmed together, and
    # when neither alone helps, box and current are scaled together
    if alone_box is not None and alone_current is None:
        pair: tuple[float | None, float] | None = (alone_box, current)
    elif alone_current is not None and alone_box is None:
        pair = (1.0 if box.declared else None, alone_current)
    elif alone_box is not None and alone_current is not None and pair_fits(alone_box, alone_current):
        pair = (alone_box, alone_current)
    elif box.declared and current > 0.0:
        joint = answer(lambda s: (s, s * current), top)
        pair = None if joint is None else (joint, joint * current)
    else:
        pair = None
    out["box_scale_alone"], out["current_speed_alone"] = alone_box, alone_current
    if pair is not None:
        out["box_scale"], out["current_speed"] = pair
        if pair[0] is not None:
            scaled = box.scaled(pair[0])
            moving = scaled.moving()
            out["uncertainty"] = {
                name: [lo, hi] for name, lo, hi in zip(PARAMETERS, scaled.lo, scaled.hi) if name in moving
            }
    return out


__all__ = [
    "BISECTION_STEPS",
    "LOWER_STEPS",
    "REDESIGN_TRIES",
    "SCALE_CAP",
    "TRIM_RTOL",
    "UNSTABLE_RTOL",
    "UPPER_STEPS",
    "RobustMargin",
    "Witness",
    "certified_scale",
    "exhibited_scale",
    "largest_certifiable",
    "linearised_scale",
    "robust_margin",
    "trim_max_real",
    "weakest_corner",
]
