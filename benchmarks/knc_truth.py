"""Blind K&C cases outside the library, and the truth's signal-to-noise: benchmark tools.

The test car's recordings come from the package (:func:`suspenv.rigs.knc_truth.measure_truth`);
this module conceals physics outside the K&C library in them (:func:`conceal_outside`:
a strut bump stop, progressive or preloaded bushings, subframe compliance, load-cell
cross-talk, a toe sign the recordings do not declare), draws the blind cases outside
the library (:func:`outside_case`), and measures how visible a concealed effect is with
the truth known (:func:`truth_snr`, the benchmark side of
:mod:`suspenv.diagnosis.knc.detectability`) and a loop's opening at the static
position (:func:`loop_gap_at_static`). Used by ``benchmarks/knc_diagnosis.py`` and
the tests, never by a diagnosis.

Units: SI (ISO 8855, lateral outboard positive; forces [N], travel [m]).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.diagnosis.fitting import stacked_residual
from suspenv.diagnosis.knc.detectability import DETECTABLE_SNR
from suspenv.diagnosis.knc.family import fit_axle
from suspenv.measurements import Recording
from suspenv.measurements.knc import CHANNELS, SIDES, half_loops, rig_test
from suspenv.rigs.knc import FORCE_AMPLITUDE
from suspenv.rigs.knc_axle import KncAxleModel
from suspenv.rigs.knc_truth import BLIND_TESTS, measure_truth

#: the blind cases' fitted tests (single-wheel travel is held out)
FITTED_TESTS = tuple(t for t in BLIND_TESTS if t != "single")


def add_strut_stop(
    recs: Mapping[str, Recording],
    gap: float = 0.02,
    k_stop: float = 2.0e4,
    sides: Sequence[str] = ("left", "right"),
) -> None:
    """Conceal a strut bump stop (a jounce bumper, outside the K&C model's library) in
    ``recs``: past ``gap`` [m] of a side's pad travel (bump positive) the tyre load cell
    of that side reads ``k_stop`` [N/m] times the travel beyond the gap more (wheel load
    positive up). The stop acts on the load cell only (the kinematic channels are left
    as the solver gave them), in every travel test; compliance tests hold the pads at
    zero travel and are not touched."""
    for rec in recs.values():
        for side in sides:
            pad = np.asarray(rec.inputs.get(f"pad_{side}", np.zeros(0)), float)
            key = f"tyre_fz_{side}"
            if pad.size and key in rec.outputs:
                over = np.maximum(pad - gap, 0.0)
                rec.outputs[key] = np.asarray(rec.outputs[key], float) + k_stop * over


# ------------------------------------------------------------------ outside the library
#: physics outside the K&C library (and a convention the recordings do not declare) of
#: the blind cases outside the library, each concealed by :func:`conceal_outside`
OUTSIDE_KINDS = (
    "strut_stop",
    "progressive_bushing",
    "preloaded_bushing",
    "subframe_compliance",
    "load_cell_crosstalk",
    "toe_sign",
)
#: compliance tests and the contact-point channels their force moves
COMPLIANCE_TESTS = {"lateral": "contact_lateral", "longitudinal": "contact_x"}
#: outputs a bushing's deflection moves in a compliance test
BUSHING_CHANNELS = ("toe", "camber", "contact_lateral", "contact_x")


def _compliance_shape(recs: Mapping[str, Recording], shape: Any) -> None:
    """Reshape every compliance output's response to the force: the part of channel ``y``
    that follows the force ``F`` [N] (``y - y0``, ``y0`` its least-squares value at
    ``F = 0``) becomes ``(y - y0) * shape(F)``: a bushing whose rate is not constant."""
    for test in COMPLIANCE_TESTS:
        rec = recs.get(test)
        if rec is None:
            continue
        F = np.asarray(rec.inputs["force"], float)
        A = np.stack([np.ones_like(F), F], axis=1)
        g = shape(F)
        for side in ("left", "right"):
            for ch in BUSHING_CHANNELS:
                y = np.asarray(rec.outputs[f"{ch}_{side}"], float)
                y0 = np.linalg.lstsq(A, y, rcond=None)[0][0]
                rec.outputs[f"{ch}_{side}"] = y0 + (y - y0) * g


def conceal_outside(recs: Mapping[str, Recording], kind: str, p: Mapping[str, Any]) -> None:
    """Conceal outside-library ``kind`` (:data:`OUTSIDE_KINDS`) with parameters ``p`` in
    ``recs`` (after the sensor noise, on the channels the physics reaches):

    * ``strut_stop``: :func:`add_strut_stop` (``gap`` [m], ``k_stop`` [N/m], ``sides``);
    * ``progressive_bushing``: the compliance response stiffens with the force,
      ``(y - y0) / (1 + b (F / F_ref)^2)`` (``b``, ``f_ref`` [N]);
    * ``preloaded_bushing``: nothing moves until the force passes the preload,
      ``(y - y0) max(|F| - F_p, 0) / |F|`` (``f_p`` [N]);
    * ``subframe_compliance``: the subframe moves on its mounts under the sum of both
      wheels' forces: both contact points move ``2 F / k`` more (``k`` [N/m]);
    * ``load_cell_crosstalk``: each tyre load cell reads ``c F`` of the horizontal
      contact force ``F`` (``c`` [-]);
    * ``toe_sign``: both toe channels recorded toe-out positive (sign reversed).
    """
    if kind == "strut_stop":
        add_strut_stop(recs, p["gap"], p["k_stop"], p["sides"])
    elif kind == "progressive_bushing":
        _compliance_shape(recs, lambda F: 1.0 / (1.0 + p["b"] * (F / p["f_ref"]) ** 2))
    elif kind == "preloaded_bushing":
        _compliance_shape(
            recs,
            lambda F: np.maximum(np.abs(F) - p["f_p"], 0.0) / np.maximum(np.abs(F), 1e-9),
        )
    elif kind in ("subframe_compliance", "load_cell_crosstalk"):
        for test, contact in COMPLIANCE_TESTS.items():
            rec = recs.get(test)
            if rec is None:
                continue
            F = np.asarray(rec.inputs["force"], float)
            for side in ("left", "right"):
                key = f"{contact}_{side}" if kind == "subframe_compliance" else f"tyre_fz_{side}"
                add = 2.0 * F / p["k"] if kind == "subframe_compliance" else p["c"] * F
                rec.outputs[key] = np.asarray(rec.outputs[key], float) + add
    elif kind == "toe_sign":
        for rec in recs.values():
            for side in ("left", "right"):
                rec.outputs[f"toe_{side}"] = -np.asarray(rec.outputs[f"toe_{side}"], float)
    else:
        raise ValidationError(f"outside kind must be one of {OUTSIDE_KINDS}, but got {kind!r}")


def draw_outside(kind: str, rng: np.random.Generator) -> dict[str, Any]:
    """Seeded parameters of one outside-library ``kind`` (SI, see :func:`conceal_outside`)."""
    if kind == "strut_stop":  # 15-30 mm of bump, 10-40 kN/m, both sides, the left or right
        sides = [["left", "right"], ["left"], ["right"]][int(rng.integers(3))]
        return {"gap": rng.uniform(0.015, 0.030), "k_stop": rng.uniform(1e4, 4e4), "sides": sides}
    if kind == "progressive_bushing":  # 25-50 % stiffer at the test force
        return {"b": rng.uniform(0.25, 0.5), "f_ref": FORCE_AMPLITUDE}
    if kind == "preloaded_bushing":  # preload 10-25 % of the test force
        return {"f_p": rng.uniform(0.10, 0.25) * FORCE_AMPLITUDE}
    if kind == "subframe_compliance":  # lateral mount rate 2-6 kN/mm for the subframe
        return {"k": rng.uniform(2e6, 6e6)}
    if kind == "load_cell_crosstalk":  # 1-3 % of the horizontal force, either sign
        return {"c": float(rng.choice([-1.0, 1.0])) * rng.uniform(0.01, 0.03)}
    if kind == "toe_sign":
        return {}
    raise ValidationError(f"outside kind must be one of {OUTSIDE_KINDS}, but got {kind!r}")


def outside_case(
    seed: int, steps: int = 8, amplitude: float = 0.040, tests: Sequence[str] = BLIND_TESTS
) -> tuple[dict[str, Any], dict[str, Any]]:
    """``(case, truth)`` of a blind case outside the K&C library: kind
    ``OUTSIDE_KINDS[seed % 6]`` (:func:`conceal_outside`), its size and the noise level
    drawn from the seed, on the plain test car. A correct verdict names nothing with
    confidence and reports the residual left."""
    kind = OUTSIDE_KINDS[int(seed) % len(OUTSIDE_KINDS)]
    rng = np.random.default_rng([seed, 77])
    params = {k: (float(v) if np.ndim(v) == 0 else v) for k, v in draw_outside(kind, rng).items()}
    noise = float(rng.uniform(0.5, 2.0))
    recs = measure_truth({}, seed, amplitude, steps, noise, tests)
    conceal_outside(recs, kind, params)
    for r in recs.values():
        r.meta.pop("seed", None)
        r.name = f"knc-outside-{seed}:{rig_test(r)}"
    truth = {"seed": int(seed), "case_type": kind, "outside": params, "noise_scale": noise}
    return {"id": f"knc-outside-{seed}", "recordings": recs}, truth


def noise_levels(noise_scale: float) -> dict[str, float]:
    """Noise (1 sigma, channel unit) of every recorded channel at ``noise_scale``."""
    from suspenv.models.mcpherson.truth import CHANNEL_NOISE

    if not noise_scale > 0:
        raise ValidationError(f"`noise_scale > 0` must hold, but got {noise_scale}")
    return {
        f"{c}_{s}": noise_scale * CHANNEL_NOISE[rig]
        for c, (rig, _, _) in CHANNELS.items()
        for s in SIDES
    }


def truth_snr(
    effects: Mapping[str, Mapping],
    seed: int,
    noise_scale: float,
    steps: int = 8,
    amplitude: float = 0.040,
    tests: Sequence[str] = FITTED_TESTS,
) -> dict[str, Any]:
    """Signal-to-noise of the concealed ``effects`` of a truth vehicle in ``tests``.

    Returns ``{"snr", "lambda", "lambda_by_channel", "detectable"}``; ``lambda`` of
    the plain model's residual on the noise-free loops, fitted by the diagnosis' own
    K&C fit (:func:`suspenv.diagnosis.knc.family.fit_axle`; see the module docstring).
    """
    sigma = noise_levels(noise_scale)
    if not effects:
        return {"snr": 0.0, "lambda": 0.0, "lambda_by_channel": {}, "detectable": False}
    recs = measure_truth(effects, seed, amplitude, steps, noise_scale=0.0, tests=tuple(tests))
    fr = [recs[t] for t in tests]
    res = fit_axle(KncAxleModel(tests=tuple(tests)), fr, sigma, max_nfev=60, tol=1e-10)
    r = stacked_residual(res.model, res.theta, fr, list(sigma), sigma)
    n = sum(rec.n_samples for rec in fr)
    per: dict[str, float] = {}
    k = 0
    for rec in fr:  # stacked order: recording, then channel
        for c in sigma:
            per[c] = per.get(c, 0.0) + float(np.sum(r[k : k + rec.n_samples] ** 2))
            k += rec.n_samples
    assert k == n * len(sigma)
    lam = float(sum(per.values()))
    snr = float(np.sqrt(lam))
    return {
        "snr": snr,
        "lambda": lam,
        "lambda_by_channel": per,
        "detectable": bool(snr >= DETECTABLE_SNR),
    }


def loop_gap_at_static(rec: Any, values: np.ndarray) -> float:
    """Gap between a loop's two branches at the static position (grid centre): rising
    minus falling branch, in the channel's unit. Not :func:`suspenv.metrics.knc.loop_width`
    (the largest gap of a rig result over the whole stroke)."""
    down, up = half_loops(rec, values)
    i0 = int(rec.meta["steps"]) // 2
    return float(up[i0] - down[i0])
