"""Magnetorheological damper on a shaking table: force from imposed motion.

Frame and signs as in :mod:`suspenv.models.components.damper`: ``displacement``
[m], ``velocity`` [m/s], ``force`` [N] positive when resisting positive velocity.

Base: viscous plus stiffness plus static force, ``F = c v + k x + f_0`` (the force
sensor of the shaking table carries a static offset). The characteristic missing
physics is hysteresis (Bouc-Wen or Dahl), added as an effect.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from suspenv.core.options import choice
from suspenv.core.space import Parameter
from suspenv.measurements import Recording
from suspenv.models.components.base import (
    FRICTION_WIDTHS,
    ComponentModel,
    LinearForceModel,
    linear_lstsq,
    robust_amplitude,
)
from suspenv.models.components.damper import sine_blocks
from suspenv.models.effects._util import batch_param as bp
from suspenv.models.effects.hysteresis import bouc_wen_force_path


class MRDamperModel(LinearForceModel):
    """MR damper; base ``F = c v + k x + f_0``."""

    family = "mr_damper"
    description = "MR damper on a shaking table (base: F = c v + k x + f_0)"
    base_parameters: ClassVar[tuple[Parameter, ...]] = (
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
    candidate_effects: ClassVar[tuple[str, ...]] = (
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
    regressors = (("c", "velocity", 1.0), ("k", "displacement", None), ("f_0", "", None))

    def example_recording(self, seed: int = 0) -> Recording:
        """Shaking-table-like sines: 5-20 mm at 0.8-1.7 Hz, 10 ms sampling."""
        rng = np.random.default_rng(seed)
        blocks = [
            (0.005 + 0.015 * rng.uniform(), float(f), 4) for f in rng.uniform(0.8, 1.7, size=3)
        ]
        return sine_blocks(blocks, 0.01, f"mr_damper_example_{seed}", "mr_sine")


#: field input channels the field-dependent law reads -> their SI unit
FIELD_INPUTS: dict[str, str] = {"coil_current": "A", "coil_voltage": "V"}


class MRFieldDamperModel(MRDamperModel):
    """MR damper whose force follows a recorded coil current or voltage ``u``.

    The phenomenological Bouc-Wen model of Spencer, Dyke, Sain and Carlson
    ("Phenomenological model for magnetorheological dampers", J. Eng. Mech. 123(3),
    230-238, 1997, section "Bouc-Wen model"), with its parameters linear in the field
    input as there (``alpha = alpha_a + alpha_b u``, ``c0 = c0a + c0b u``)::

        F = (c + c_field u) v + k x + f_0 + (f_y + f_field u) z
        dz/dt = (v - (shape |v| z + (1 - shape) v |z|)) / x_y        (n = 1)

    ``x`` [m], ``v`` [m/s], ``F`` [N] in the frame of :class:`MRDamperModel`; ``u`` the
    channel named by the option ``field`` (``coil_current`` [A] or ``coil_voltage``
    [V], :data:`FIELD_INPUTS`); ``z`` dimensionless (ultimate value 1, so ``f_y +
    f_field u`` [N] is the yield force at that field), ``x_y`` [m] the yield
    displacement, ``shape`` in [0, 1] the loop shape (Spencer's ``A = 1/x_y``, ``beta +
    gamma = 1/x_y``). ``z`` follows the motion only (its shape does not depend on
    ``u``, as in Spencer's model), so it is the exact path of
    :func:`~suspenv.models.effects.hysteresis.bouc_wen_force_path` from ``z = 0``.
    Spencer's first-order lag of the coil (``eta`` about 190 1/s, 5 ms) is not
    modelled: the recorded channel is taken as the field's cause at each sample.
    ``c_field`` is in N s/m per unit of ``u`` and ``f_field`` in N per unit of ``u``.
    """

    description = (
        "MR damper with a field input u (base: F = (c + c_field u) v + k x + f_0 + "
        "(f_y + f_field u) z, Bouc-Wen z, Spencer et al. 1997)"
    )
    base_parameters = (
        *MRDamperModel.base_parameters,
        *(
            Parameter(name, low, high, unit, log=log, default=default, description=meaning)
            for name, low, high, unit, log, default, meaning in (
                ("c_field", -1e6, 1e6, "N s/m/field", False, 0.0,
                 "viscous damping per unit of the field input"),
                ("f_y", 0.0, 1e5, "N", False, 50.0, "yield force at u = 0"),
                ("f_field", -1e5, 1e5, "N/field", False, 0.0,
                 "yield force per unit of the field input"),
                ("x_y", 1e-6, 0.05, "m", True, 1e-3, "yield displacement of the hysteresis"),
                ("shape", 0.0, 1.0, "", False, 0.5, "loop shape b"),
            )
        ),
    )  # fmt: skip
    candidate_effects = tuple(
        k
        for k in MRDamperModel.candidate_effects
        if k not in ("bouc_wen_hysteresis", "dahl_hysteresis")
    )

    def __init__(self, effects=(), **options):
        super().__init__(effects, **options)
        choice(self.family, "field", self.field, sorted(FIELD_INPUTS))

    @property
    def field(self) -> str:
        """The field input channel (option ``field``)."""
        return str(self.options.get("field", ""))

    @property
    def reads_inputs(self) -> tuple[str, ...]:
        return (*self.input_channels, self.field)

    @property
    def parameter_units(self) -> tuple[str, ...]:
        unit = FIELD_INPUTS[self.field]
        return tuple(u.replace("/field", f"/{unit}") for u in super().parameter_units)

    def _field(self, rec: Recording) -> np.ndarray:
        rec.require((self.field,), units={self.field: FIELD_INPUTS[self.field]})
        return np.asarray(rec.inputs[self.field], float)

    def _predict(self, base, effects, rec):
        u = self._field(rec)
        out = super()._predict(base, effects, rec)
        x, v = rec.inputs["displacement"], rec.inputs["velocity"]
        z = bouc_wen_force_path(x, 1.0, base["x_y"], base["shape"])
        out["force"] = out["force"] + bp(base["c_field"]) * u * v
        out["force"] = out["force"] + (bp(base["f_y"]) + bp(base["f_field"]) * u) * z
        return out

    def _base_guess(self, rec):
        guess = ComponentModel._base_guess(self, rec)  # the references, not a fit
        x, v = rec.inputs["displacement"], rec.inputs["velocity"]
        guess["x_y"] = float(np.clip(0.1 * robust_amplitude(x), 1e-5, 0.01))
        if "force" not in rec.outputs:
            return guess
        # for a fixed loop (x_y, shape) the force is linear in every other parameter
        u = self._field(rec)
        z = bouc_wen_force_path(x, 1.0, guess["x_y"], guess["shape"])
        cols = [v, x, np.ones_like(v), u * v, z, u * z]
        names = ("c", "k", "f_0", "c_field", "f_y", "f_field")
        coef = linear_lstsq(cols, rec.outputs["force"])
        guess.update({n: float(c) for n, c in zip(names, coef, strict=True)})
        guess["c"], guess["f_y"] = max(guess["c"], 1.0), max(guess["f_y"], 0.0)
        return guess
