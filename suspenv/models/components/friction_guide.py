"""Mass on a friction guide (EMPS-type positioning axis): inverse dynamic model.

Frame and signs: ``position`` [m] along the guide, ``velocity`` [m/s] and
``acceleration`` [m/s^2] its derivatives, all measured (inputs); ``force`` [N] is
the drive force on the carriage along +position (output).

Form: the model predicts the drive force from the measured motion (inverse
dynamics), ``F = m a + c v + sum of effect forces(position, velocity)``. The base
is linear in its parameters ``(m, c)`` (an ordinary least-squares problem);
friction effects (Coulomb, direction-dependent, Stribeck, LuGre), a rate-independent
hysteresis (Dahl, Bouc-Wen), a progressive spring and a constant force offset are the
expected missing physics. Note that a friction force with a
different level in each direction is exactly a symmetric friction plus a constant
offset wherever the carriage moves, so those two hypotheses can only be separated
by data with the carriage at rest under load.

Fitted where the library holds them fixed (:attr:`freed_parameters`): the friction
steps' velocity widths, LuGre's bristle stiffness ``sigma0`` (the contact's pre-sliding
displacement ``f_c / sigma0``, from micrometres to a fraction of a millimetre on rolling
guides) and a cubic spring's neutral position ``x_0`` [m] (the position is measured from
an end of the travel, not from where a spring is relaxed; started at the middle of the
travel).
"""

from __future__ import annotations

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.core.space import Parameter
from suspenv.measurements import Recording
from suspenv.models.components.base import FRICTION_WIDTHS, LUGRE_BRISTLES, LinearForceModel


class FrictionGuideModel(LinearForceModel):
    """Mass on a guide driven by a measured force; base ``F = m a + c v``."""

    family = "friction_guide"
    # the motion's content above a low-pass is largest where a move starts or ends, and
    # the inertia carries it into the force: compare the force low-passed alike
    output_lowpass = True
    # a guide's trajectory holds the carriage still between moves
    dwells_between_moves = True
    description = "mass on a friction guide, inverse model F = m a + c v (linear in m, c)"
    base_parameters = (
        Parameter("m", 0.0, 1e4, unit="kg", default=100.0, description="moving mass"),
        Parameter("c", 0.0, 1e5, unit="N s/m", default=200.0, description="viscous friction"),
    )
    input_channels = ("position", "velocity", "acceleration")
    output_channels = ("force",)
    channel_units = {"position": "m", "velocity": "m/s", "acceleration": "m/s^2", "force": "N"}
    freed_parameters = {
        **FRICTION_WIDTHS,
        "lugre_friction": LUGRE_BRISTLES,
        "cubic_stiffness": ("x_0",),
    }
    candidate_effects = (
        "coulomb_friction",
        "directional_friction",
        "stribeck_friction",
        "lugre_friction",
        "dahl_hysteresis",
        "bouc_wen_hysteresis",
        "force_offset",
        "cubic_stiffness",
        "damper_asymmetry",
        "sensor_lag",
    )
    device_words = {
        "damper_asymmetry": "direction-dependent viscous friction in the guide (a viscous "
        "coefficient that differs between the two directions of travel)",
        "dahl_hysteresis": "rate-independent hysteresis in the guide (Dahl: a force that "
        "builds up over a displacement after each reversal and holds at rest)",
        "bouc_wen_hysteresis": "rate-independent hysteresis in the guide (Bouc-Wen: a "
        "force that builds up over a displacement after each reversal and holds at rest)",
    }
    location = "guide"
    viscous_parameter = "c"
    regressors = (("m", "acceleration", 1e-3), ("c", "velocity", 1e-3))

    def _check_effect(self, effect):
        if effect.kind in ("bump_stop", "rebound_stop", "bump_and_rebound_stops"):
            raise ValidationError(f"{self.family}: end stops are not part of a guide model")

    def linear_part(self, base, rec):
        """The inertia and viscous force ``m a + c v`` [N]."""
        return {"force": self._linear_force(base, rec)}

    def _scales(self, rec):
        pos = np.asarray(rec.inputs["position"], float)
        centre = 0.5 * float(np.max(pos) + np.min(pos))  # the middle of the travel
        return {**super()._scales(rec), "centre": centre}

    def example_recording(self, seed: int = 0) -> Recording:
        """EMPS-like back-and-forth trajectory (0.2 m stroke, rests between moves), 2 ms."""
        rng = np.random.default_rng(seed)
        dt = 0.002
        t = np.arange(0.0, 12.0, dt)
        f1, f2 = 0.25 * (1 + 0.1 * rng.uniform(-1, 1)), 0.9 * (1 + 0.1 * rng.uniform(-1, 1))
        w1, w2 = 2 * np.pi * f1, 2 * np.pi * f2
        x = 0.1 * np.sin(w1 * t) + 0.01 * np.sin(w2 * t)
        v = 0.1 * w1 * np.cos(w1 * t) + 0.01 * w2 * np.cos(w2 * t)
        a = -0.1 * w1**2 * np.sin(w1 * t) - 0.01 * w2**2 * np.sin(w2 * t)
        return Recording(
            f"friction_guide_example_{seed}",
            "emps_trajectory",
            t,
            {"position": x, "velocity": v, "acceleration": a},
            {},
            dict(self.channel_units),
            {"source": "synthetic", "sampling": {"dt_s": dt}},
        )
