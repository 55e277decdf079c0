"""Lateral tyre force of the reference minibus: a Magic-Formula-type model.

Frame and signs: wheel frame after ISO 8855 (x forward along the wheel plane, y left,
z up). The slip angle ``alpha`` [rad] is taken positive when the tyre produces a
positive (leftward) lateral force, i.e. ``alpha = steer - atan(v_y / v_x)`` of the
contact patch (the opposite sign of the ISO 8855 slip angle). SI units: forces in N,
angles in rad.

Model (pure side slip, no camber, no combined slip, no relaxation length)::

    Fy = D sin(C atan(B a - E (B a - atan(B a))))
    D  = mu_y(Fz) Fz,            mu_y = pDy1 (1 + pDy2 dfz),  dfz = (Fz - Fz0) / Fz0
    Ky = pKy1 Fz0 sin(2 atan(Fz / (pKy2 Fz0)))          (cornering stiffness, N/rad)
    B  = Ky / (C D),             E = pEy1 + pEy2 dfz  (E <= 1)

so the slope at zero slip is exactly ``B C D = Ky`` and, for ``C > 1``, the peak is
exactly ``D``. Load sensitivity enters twice: the friction coefficient falls with load
(``pDy2 < 0``) and the cornering stiffness grows less than proportionally with load
(it peaks at ``Fz = pKy2 Fz0``). Both make the lateral capacity of an axle fall when
load is transferred from the inner to the outer wheel, which is how the roll-stiffness
split steers the handling balance.

The structure and coefficient names follow Pacejka's Magic Formula (H. B. Pacejka,
*Tyre and Vehicle Dynamics*, 3rd ed., 2012, ch. 4, the MF 5.2 pure-slip equations,
with shifts, camber and scaling factors dropped). :data:`LIGHT_TRUCK_TYRE` is a
documented choice for a 195/70 R15C light-truck tyre, see its docstring.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.models.minibus.handling_kernel import tyre_cornering, tyre_factors


@dataclass(frozen=True)
class LateralTyre:
    """Coefficients of the pure-side-slip Magic Formula (dimensionless unless stated).

    Attributes:
        fz0: nominal wheel load Fz0 [N].
        pCy1: shape factor C (> 1 gives a peak followed by a falling branch).
        pDy1: friction coefficient at the nominal load.
        pDy2: relative change of the friction coefficient per unit ``dfz`` (< 0).
        pEy1, pEy2: curvature factor E at nominal load and its change with ``dfz``.
        pKy1: cornering stiffness at its maximum, divided by Fz0 [1/rad].
        pKy2: load (in units of Fz0) at which the cornering stiffness peaks.
    """

    fz0: float = 6500.0
    pCy1: float = 1.30  # noqa: N815 - Pacejka's name
    pDy1: float = 0.80  # noqa: N815 - Pacejka's name
    pDy2: float = -0.10  # noqa: N815 - Pacejka's name
    pEy1: float = -0.80  # noqa: N815 - Pacejka's name
    pEy2: float = -0.30  # noqa: N815 - Pacejka's name
    pKy1: float = 16.0  # noqa: N815 - Pacejka's name
    pKy2: float = 2.0  # noqa: N815 - Pacejka's name

    def __post_init__(self) -> None:
        rules = [
            ("fz0 > 0", self.fz0 > 0),
            ("1 < pCy1 < 2", 1.0 < self.pCy1 < 2.0),
            ("pDy1 > 0", self.pDy1 > 0),
            ("-1 < pDy2 <= 0", -1.0 < self.pDy2 <= 0.0),
            ("pEy1 <= 1", self.pEy1 <= 1.0),
            ("pKy1 > 0", self.pKy1 > 0),
            ("pKy2 > 0", self.pKy2 > 0),
        ]
        for rule, holds in rules:
            if not holds:
                raise ValidationError(f"LateralTyre: `{rule}` must hold, but got {self!r}")

    # ------------------------------------------------------------ closed forms
    @functools.cached_property
    def coefficients(self) -> np.ndarray:
        """(fz0, pCy1, pDy1, pDy2, pEy1, pEy2, pKy1, pKy2), as the compiled handling
        loops take them (:mod:`suspenv.models.minibus.handling_kernel`); read-only."""
        k = np.array([self.fz0, self.pCy1, self.pDy1, self.pDy2, self.pEy1, self.pEy2,
                      self.pKy1, self.pKy2])  # fmt: skip
        k.flags.writeable = False
        return k

    def cornering_stiffness(self, fz: np.ndarray | float) -> np.ndarray:
        """Cornering stiffness Ky = dFy/dalpha at alpha = 0 [N/rad]; zero for fz <= 0."""
        return tyre_cornering(np.asarray(fz, dtype=float), self.coefficients)

    # ----------------------------------------------------------------- force
    def lateral_force(self, alpha: np.ndarray | float, fz: np.ndarray | float) -> np.ndarray:
        """Lateral force Fy [N] at slip angle ``alpha`` [rad] and load ``fz`` [N].

        Broadcasts ``alpha`` against ``fz``. A lifted wheel (``fz <= 0``) gives 0.
        Odd in ``alpha``: Fy(-alpha) = -Fy(alpha).
        """
        return self.curve(fz)(alpha)

    def factors(self, fz: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The load-dependent factors (D [N], B [1/rad], E [-]) of the force at loads
        ``fz`` [N] (C is ``pCy1``)."""
        return tyre_factors(np.asarray(fz, dtype=float), self.coefficients)

    def curve(self, fz: np.ndarray | float) -> Callable[[np.ndarray | float], np.ndarray]:
        """The force curve ``alpha -> Fy`` [rad -> N] at fixed loads ``fz`` [N], its
        load-dependent factors (:meth:`factors`) computed once (for solves that evaluate
        many slip angles at the same loads)."""
        d, b, e = self.factors(fz)
        c = self.pCy1

        def force(alpha: np.ndarray | float) -> np.ndarray:
            ba = b * np.asarray(alpha, dtype=float)
            return d * np.sin(c * np.arctan(ba - e * (ba - np.arctan(ba))))

        return force


#: Reference tyre of the minibus: 195/70 R15C (load index 104/102, about 900 kg max).
#:
#: Reasoning for each coefficient (no measured set of this size is public):
#: - ``fz0 = 6500 N``: about 70 % of the 900 kg load-index capacity, close to the
#:   full-load rear wheel load of the reference vehicle.
#: - ``pKy1 = 16``, ``pKy2 = 2``: cornering stiffness 83 kN/rad (1.45 kN/deg) per tyre at
#:   Fz0, i.e. about 0.22 /deg of load, the usual range of light-truck radials
#:   (0.15-0.25 /deg); it peaks at twice the nominal load as in published MF sets of
#:   radial car tyres (pKy2 of about 1.5-2.5).
#: - ``pCy1 = 1.3``: the value Pacejka gives as typical for the side-force shape.
#: - ``pDy1 = 0.80``, ``pDy2 = -0.10``: dry asphalt with a light-truck (C-type) tread
#:   compound, a little below car tyres (0.9-1.0); friction falls 10 % per Fz0 of extra
#:   load (published sets: -0.05 to -0.15). With 0.9 the reference vehicle would reach
#:   two-wheel lift (rollover) before the tyres saturate, for every design of the box.
#: - ``pEy1 = -0.8``, ``pEy2 = -0.3``: a rounded peak, a gentle falling branch.
LIGHT_TRUCK_TYRE = LateralTyre()
