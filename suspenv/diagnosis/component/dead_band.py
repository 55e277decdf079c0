"""A force missing around zero speed: the probe that tells a dead band from noise.

A friction step adds ``f_c tanh(v / v_eps)`` to the force: at every reversal the force
jumps by ``2 f_c`` within a narrow band of speed. Some components do the opposite: a
valve that opens late, a clearance in the linkage, a damper whose force vanishes below
some speed. Their force *lacks* such a step: beyond the band the viscous law holds, less
a constant, and inside it the force is missing. Friction cannot be negative, so no
library element takes this up; the library's friction fitted to it ends at its bound 0
and is refused, and the residual check may find the deficit too small a share of the
residual in its speed cells.

So after the last named element a ``low_speed_deficit`` element (``-f_d tanh(v /
v_band)``, the step of friction with the sign no friction has) is added to the final
model and refitted, as the delay probe is (:mod:`~suspenv.diagnosis.component.delay`).
It is physics outside the library when it passes the test every refit passes and the
residual check's size rule
(:func:`~suspenv.diagnosis.component.residual_left.beyond_library`), its level ``f_d``
is resolved from zero (``SIZE_Z`` corrected standard errors, the rule of every element's
size) and its band lies inside the speeds run (``v_band`` at most ``BAND_MAX_FRACTION``
of the peak speed: wider, ``tanh`` is a smooth curve over the whole range, a nonlinear
damping law such as a cubic one, not a band about zero speed).

Units: ``f_d`` in the force's unit [N], ``v_band`` in m/s (the model's velocity: a
damper's stroke rate, a guide's speed, a quarter car's deflection rate).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from suspenv.diagnosis.component.refit import SIZE_Z, parameter_and_error, refit_with
from suspenv.diagnosis.component.residual_left import beyond_library
from suspenv.diagnosis.decision import DecisionRule
from suspenv.diagnosis.fitting import FitResult
from suspenv.diagnosis.record import Record
from suspenv.diagnosis.split import Split

#: the probe's element kind (not a candidate of any family)
DEFICIT_KIND = "low_speed_deficit"
#: widest band, as a share of the peak speed, that is a band about zero speed
BAND_MAX_FRACTION = 0.5


@dataclass(frozen=True)
class DeadBandLeft(Record):
    """The low-speed deficit added to the final model (:func:`dead_band_left`).

    Attributes:
        channel: the channel whose residual is judged (the model's main output).
        missing_force: the fitted level ``f_d`` [N]: the force missing beyond
            the band, at every reversal twice that.
        band_speed: the fitted ``v_band`` [m/s].
        peak_speed: the largest speed of the fitted recordings [m/s].
        level_z: ``f_d`` over its corrected standard error.
        p_value_corrected / heldout_reduction / structured_ratio: the final model with
            the element against without, as every probe is judged
            (:func:`~suspenv.diagnosis.component.residual_left.beyond_library`).
        remains: the deficit is physics left that the library does not hold.
        unit: the unit of ``missing_force`` (N: the element is a force whichever
            channel shows it).
    """

    channel: str
    missing_force: float
    band_speed: float
    peak_speed: float
    level_z: float
    p_value_corrected: float
    heldout_reduction: float
    structured_ratio: float
    remains: bool
    unit: str = "N"
    #: the force the deficit is missing from, in words (e.g. "force in the suspension")
    where: str = "force"

    def short(self) -> str:
        """A few words for the headline."""
        return f"a force of {self.missing_force:.3g} {self.unit} missing around zero speed"

    def sentence(self) -> str:
        """One sentence for the verdict."""
        evidence = (
            f"it removes {self.structured_ratio:.2g} x the residual it leaves, level "
            f"{self.level_z:.3g} standard errors from zero, corrected p = "
            f"{self.p_value_corrected:.2g}, held-out error "
            f"{-100 * self.heldout_reduction:+.1f} %; peak speed {self.peak_speed:.3g} m/s"
        )
        if self.remains:
            return (
                f"unexplained, not in the library: the {self.where} lacks "
                f"{self.missing_force:.3g} {self.unit} beyond a band of "
                f"{self.band_speed:.3g} m/s about zero speed, the step of friction with "
                "the sign no friction has (a velocity "
                "dead band: a valve that opens late, a clearance in the linkage; the library's "
                f"friction cannot be negative; {evidence})"
            )
        return (
            f"a force missing around zero speed ({self.missing_force:.3g} {self.unit} beyond "
            f"{self.band_speed:.3g} m/s) is not a finding added to the final model ({evidence})"
        )


def dead_band_left(
    final: FitResult, sp: Split, location: str, peak: float, budget: int, rule: DecisionRule
) -> DeadBandLeft:
    """Whether a force missing around zero speed is physics left after the final model
    (module docstring): the element refitted on top of ``final`` at ``location`` (the
    model's force element place), ``peak`` [m/s] the fitted motion's peak speed."""
    ext = refit_with(
        final, DEFICIT_KIND, sp.fit_recordings, sp.fit_masks, location=location, max_nfev=budget
    )
    channel = final.main_channel()
    c, ratio, passes = beyond_library(final, ext, sp, channel, rule)
    level, sd = parameter_and_error(ext, DEFICIT_KIND, "f_d")
    band = parameter_and_error(ext, DEFICIT_KIND, "v_band")[0]
    z = float(level / sd) if np.isfinite(sd) and sd > 0 else 0.0
    return DeadBandLeft(
        channel=channel,
        missing_force=float(level),
        band_speed=float(band),
        peak_speed=peak,
        level_z=z,
        p_value_corrected=c.lr.p_value_corrected,
        heldout_reduction=c.heldout_reduction,
        structured_ratio=ratio,
        remains=bool(passes and z >= SIZE_Z and float(band) <= BAND_MAX_FRACTION * peak),
        # the element's level f_d is a force [N] whichever channel shows it
        where=f"force in the {location}" if location else "force",
    )
