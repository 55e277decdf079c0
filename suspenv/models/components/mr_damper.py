"""Magnetorheological damper on a shaking table: force from imposed motion.

Frame and signs as in :mod:`suspenv.models.components.damper`: ``displacement``
[m], ``velocity`` [m/s], ``force`` [N] positive when resisting positive velocity.

Base: viscous plus stiffness plus static force, ``F = c v + k x + f_0`` (the force
sensor of the shaking table carries a static offset). The characteristic missing
physics is hysteresis (Bouc-Wen or Dahl), added as an effect.
"""

from __future__ import annotations

import numpy as np

from suspenv.core.space import Parameter
from suspenv.measurements import Recording
from suspenv.models.components.base import (
    FRICTION_WIDTHS,
    ComponentModel,
    bp,
    linear_lstsq,
    robust_amplitude,
)
from suspenv.models.components.damper import sine_blocks


class MRDamperModel(ComponentModel):
    """MR damper; base ``F = c v + k x + f_0``."""

    family = "mr_damper"
    description = "MR damper on a shaking table (base: F = c v + k x + f_0)"
    base_parameters = (
        Parameter("c", 0.0, 1e6, unit="N s/m", default=2000.0, description="viscous damping"),
        Parameter("k", -1e7, 1e7, unit="N/m", default=0.0, description="parallel stiffness"),
        Parameter("f_0", -1e5, 1e5, unit="N", default=0.0, description="static force"),
    )
    input_channels = ("displacement", "velocity")
    output_channels = ("force",)
    channel_units = {"displacement": "m", "velocity": "m/s", "force": "N"}
    freed_parameters = FRICTION_WIDTHS
    device_words = {
        "coulomb_friction": "yield force of the MR fluid (Bingham plastic: a force step at "
        "each reversal)",
        "digressive_damping": "post-yield saturation of the MR fluid (the force levels off "
        "with speed)",
        "bouc_wen_hysteresis": "pre-yield hysteresis of the MR fluid (Bouc-Wen)",
        "dahl_hysteresis": "pre-yield hysteresis of the MR fluid (Dahl)",
        "maxwell_viscoelastic": "compliance lag of the MR damper (Maxwell element: fluid "
        "compressibility, accumulator)",
        "damper_asymmetry": "bump/rebound asymmetry of the MR damper",
    }
    candidate_effects = (
        "bouc_wen_hysteresis",
        "dahl_hysteresis",
        "coulomb_friction",
        "maxwell_viscoelastic",
        "digressive_damping",
        "damper_asymmetry",
        "sensor_lag",
    )
    location = "MR damper"
    viscous_parameter = "c"

    def _predict(self, base, effects, rec):
        x, v = rec.inputs["displacement"], rec.inputs["velocity"]
        f = (
            bp(base["c"]) * v
            + bp(base["k"]) * x
            + bp(base["f_0"])
            + self.effect_force(effects, x, v, rec.time)
        )
        return {"force": np.broadcast_to(f, np.broadcast_shapes(np.shape(f), v.shape)).copy()}

    def _base_guess(self, rec):
        x, v = rec.inputs["displacement"], rec.inputs["velocity"]
        if "force" in rec.outputs:
            c, k, f0 = linear_lstsq([v, x, np.ones_like(v)], rec.outputs["force"])
            return {"c": float(max(c, 1.0)), "k": float(k), "f_0": float(f0)}
        return {p.name: p.reference for p in self.base_parameters}

    def _scales(self, rec):
        x = robust_amplitude(rec.inputs["displacement"])
        v = robust_amplitude(rec.inputs["velocity"])
        f = robust_amplitude(rec.outputs["force"]) if "force" in rec.outputs else 2000.0 * v
        return {"force": f, "deflection": x, "velocity": v}

    def example_recording(self, seed: int = 0) -> Recording:
        """Shaking-table-like sines: 5-20 mm at 0.8-1.7 Hz, 10 ms sampling."""
        rng = np.random.default_rng(seed)
        blocks = [
            (0.005 + 0.015 * rng.uniform(), float(f), 4) for f in rng.uniform(0.8, 1.7, size=3)
        ]
        return sine_blocks(blocks, 0.01, f"mr_damper_example_{seed}", "mr_sine")
