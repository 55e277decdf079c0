"""Damper on a dyno: force from imposed displacement and velocity.

Frame and signs: ``displacement`` x [m] and ``velocity`` v [m/s] are the imposed
stroke and its rate (the recording's stroke sign; positive = compression for
synthetic recordings); ``force`` [N] is the damper force, positive when it resists
positive velocity (the converters orient measured force so the damper absorbs
power on average).

Base: linear viscous ``F = c v``. Effects add forces ``F_e(x, v, t)``: digressive
curve, bump/rebound asymmetry, friction, hysteresis, gas spring/offset, viscoelastic
lag; sensor effects act on the ``force`` channel.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from suspenv.core.space import Parameter
from suspenv.measurements import Recording
from suspenv.models.components.base import FRICTION_WIDTHS, LUGRE_BRISTLES, LinearForceModel


def sine_blocks(
    blocks: Sequence[tuple[float, float, float]], dt: float, name: str, test: str
) -> Recording:
    """Concatenated sine tests ``(amplitude [m], frequency [Hz], cycles)``, inputs only.

    Each block starts and ends at zero displacement, so the joined stroke is smooth
    in position; velocity is the analytic derivative.
    """
    xs, vs = [], []
    for amp, freq, cycles in blocks:
        n = int(round(cycles / freq / dt))
        t = np.arange(n) * dt
        w = 2 * np.pi * freq
        xs.append(amp * np.sin(w * t))
        vs.append(amp * w * np.cos(w * t))
    x, v = np.concatenate(xs), np.concatenate(vs)
    t = np.arange(x.size) * dt
    return Recording(
        name,
        test,
        t,
        {"displacement": x, "velocity": v},
        {},
        {"displacement": "m", "velocity": "m/s", "force": "N"},
        {"source": "synthetic", "sampling": {"dt_s": dt}, "blocks": [list(b) for b in blocks]},
    )


class DamperDynoModel(LinearForceModel):
    """Damper on a dyno; base ``F = c v``."""

    family = "damper"
    description = "damper on a dyno, force from imposed stroke (base: linear viscous F = c v)"
    base_parameters = (
        Parameter("c", 0.0, 1e6, unit="N s/m", default=1500.0, description="viscous damping"),
    )
    input_channels = ("displacement", "velocity")
    output_channels = ("force",)
    channel_units = {"displacement": "m", "velocity": "m/s", "force": "N"}
    # a damper's seal friction creeps before it slides (LuGre, its bristle stiffness
    # fitted), and breaks away above the level it slides at
    freed_parameters = {**FRICTION_WIDTHS, "lugre_friction": LUGRE_BRISTLES}
    device_words = {
        "lugre_friction": "seal friction of the damper (LuGre: pre-sliding, then a "
        "breakaway above the sliding level)",
    }
    candidate_effects = (
        "digressive_damping",
        "damper_asymmetry",
        "coulomb_friction",
        "lugre_friction",
        "dahl_hysteresis",
        "bouc_wen_hysteresis",
        "maxwell_viscoelastic",
        "gas_spring",
        "force_offset",
        "bump_stop",
        "rebound_stop",
        "bump_and_rebound_stops",
        "sensor_lag",
    )
    location = "damper"
    viscous_parameter = "c"
    regressors = (("c", "velocity", 1.0),)

    def example_recording(self, seed: int = 0) -> Recording:
        """Sine tests at several amplitudes and frequencies (velocity up to ~0.4 m/s), 2 ms."""
        rng = np.random.default_rng(seed)
        blocks = [
            (0.010, 0.5, 2),
            (0.020, 1.0, 2),
            (0.010, 3.0, 3),
            (0.006, 8.0, 4),
        ]
        blocks = [(a * (1 + 0.1 * rng.uniform(-1, 1)), f, c) for a, f, c in blocks]
        return sine_blocks(blocks, 0.002, f"damper_example_{seed}", "dyno_sine")
