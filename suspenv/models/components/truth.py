"""Truth generator: "measured" recordings from a model with (concealed) effects.

``simulate_truth`` runs a component model (typically with effects the fit model
lacks) on the inputs of a recording and adds Gaussian measurement noise, returning
a new :class:`Recording` whose metadata records neither the effects nor the
parameters (the case stays blind; the caller keeps the truth).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.measurements import Recording
from suspenv.models.components.base import ComponentModel


def simulate_truth(
    model: ComponentModel,
    theta: np.ndarray,
    rec_inputs: Recording,
    noise_std: float | Mapping[str, float] = 0.0,
    seed: int | None = None,
    name: str | None = None,
) -> Recording:
    """A recording of ``model`` at ``theta`` driven by the inputs of ``rec_inputs``, plus noise.

    Args:
        model: the truth model (base + effects).
        theta: its parameter vector ``(p,)``, ordered as ``model.parameter_names``.
        rec_inputs: a recording providing ``time`` and the model's input channels;
            the new recording keeps those the model reads (``model.reads_inputs``),
            optional ones where given (its outputs, if any, are ignored).
        noise_std: a float is a *relative* noise level: Gaussian noise with standard
            deviation ``noise_std * RMS(channel)`` per output; a mapping gives the
            absolute standard deviation per output channel in its unit.
        seed: seed of the noise generator.
        name: name of the new recording (default ``"<inputs name>:truth"``).
    """
    th = np.asarray(theta, dtype=float)
    if th.ndim != 1:
        raise ValidationError(f"theta must be one parameter vector (p,), but got shape {th.shape}")
    clean = model.simulate(th, rec_inputs)
    rng = np.random.default_rng(seed)
    outputs = {}
    for ch, y in clean.items():
        if isinstance(noise_std, Mapping):
            sd = float(noise_std.get(ch, 0.0))
        else:
            sd = float(noise_std) * float(np.sqrt(np.mean(y**2)))
        if sd < 0:
            raise ValidationError(f"`noise_std >= 0` must hold, but got {sd} for channel {ch!r}")
        outputs[ch] = y + sd * rng.standard_normal(y.shape)
    # every channel the model read (an MR damper's coil current too), in its recorded unit
    read = [c for c in model.reads_inputs if c in rec_inputs.inputs]
    inputs = {c: rec_inputs.inputs[c].copy() for c in read}
    units = {c: rec_inputs.units[c] for c in read}
    units.update({c: model.channel_units[c] for c in model.output_channels})
    meta = {k: v for k, v in rec_inputs.meta.items() if k in ("source", "sampling", "blocks")}
    meta["notes"] = "simulated recording with measurement noise"
    return Recording(
        name or f"{rec_inputs.name}:truth",
        rec_inputs.test,
        rec_inputs.time.copy(),
        inputs,
        outputs,
        units,
        meta,
    )
