"""Named elements judged again beside a zero drift of more shape (drift_check.py).

References: Legendre polynomials' closed-form values and orthogonality for the basis; for
the check, the truth of each synthetic case (a drifting zero and no element; an element
and no drift), simulated here by the component model and an independent random walk.
"""

from __future__ import annotations

import numpy as np
import pytest

from suspenv.diagnosis.component.drift_check import drifting_channels, judge_beside_drift
from suspenv.diagnosis.component.family import COMPONENT_RULE
from suspenv.diagnosis.component.motion import split
from suspenv.diagnosis.component.refit import refit_with
from suspenv.diagnosis.evidence import compare
from suspenv.diagnosis.fitting import DRIFT_ORDER, drift_basis, fit
from suspenv.diagnosis.hypothesis import Hypothesis
from suspenv.measurements import Recording
from suspenv.models.components import MRDamperModel
from suspenv.models.components.damper import sine_blocks
from suspenv.models.effects import make_effect


def test_the_basis_is_p4_to_p8_over_the_record():
    t = np.linspace(3.0, 19.0, 4001)  # a record that does not start at 0
    B = drift_basis(t)
    assert B.shape == (t.size, DRIFT_ORDER - 3)
    # P_n(1) = 1 and P_n(-1) = (-1)^n at the record's ends
    assert np.allclose(B[-1], 1.0)
    assert np.allclose(B[0], [(-1.0) ** n for n in range(4, DRIFT_ORDER + 1)])
    # P4 = (35 u^4 - 30 u^2 + 3) / 8 at the middle, u = 0
    assert B[t.size // 2, 0] == pytest.approx(3.0 / 8.0)
    # orthogonal to the baseline's P0..P3 (and to each other) over the record
    u = 2.0 * (t - t[0]) / (t[-1] - t[0]) - 1.0
    low = np.stack([np.ones_like(u), u, 0.5 * (3 * u**2 - 1), 0.5 * (5 * u**3 - 3 * u)], 1)
    gram = np.trapezoid(B[:, :, None] * low[:, None, :], u, axis=0)
    assert np.abs(gram).max() < 1e-5  # (the trapezoid rule on 4001 points)
    own = np.trapezoid(B[:, :, None] * B[:, None, :], u, axis=0)
    assert np.allclose(own, np.diag(2.0 / (2 * np.arange(4, DRIFT_ORDER + 1) + 1)), atol=1e-5)


def _mr_case(asymmetry: float, drift: float, seed: int = 2) -> Recording:
    """An MR damper on 16 s of sines (four blocks of 1-2 Hz, 10-20 mm), white noise of
    1 % of the force's spread, with a rebound damping ``asymmetry`` [N s/m] and a zero
    that wanders by ``drift`` times the force's range (a random walk smoothed over 3 s)."""
    rng = np.random.default_rng(seed)
    blocks = [(0.01 + 0.01 * rng.uniform(), float(f), 6) for f in rng.uniform(1.0, 2.0, 4)]
    rec = sine_blocks(blocks, 0.005, "mr_drift", "mr_sine")
    model = MRDamperModel()
    effects = []
    if asymmetry:
        effects.append(make_effect("damper_asymmetry").with_params({"dc_rebound": asymmetry}))
    truth = model.with_effects(effects)
    base = {"c0": 330.0, "c1": 100.0, "c": 540.0, "k": 2600.0, "f_0": 64.0}
    f = np.asarray(truth.simulate(truth.theta_from(base), rec)["force"], float)
    t = np.asarray(rec.time, float)
    walk = np.cumsum(rng.standard_normal(t.size))
    window = int(3.0 / (t[1] - t[0]))
    walk = np.convolve(walk, np.hanning(window) / np.hanning(window).sum(), mode="same")
    walk = (walk - walk.mean()) / np.ptp(walk) * drift * np.ptp(f)
    noisy = f + walk + 0.01 * float(np.std(f)) * rng.standard_normal(f.size)
    return Recording(
        "mr_drift",
        rec.test,
        rec.time,
        dict(rec.inputs),
        {"force": noisy},
        dict(rec.units),
        dict(rec.meta),
    )


def _judged(rec: Recording):
    """The element of a bump/rebound asymmetry refitted on the baseline with its cubic
    drift, named as a round names it, then judged again beside a drift of more shape."""
    sp = split(rec, "cycles")
    span = float(np.ptp(np.asarray(rec.time, float)))
    drift = make_effect("zero_drift", location="force").with_params({"span": span})
    base_model = MRDamperModel().with_effects([drift])
    assert drifting_channels(base_model) == ["force"]
    base = fit(base_model, sp.fit_recordings, sp.fit_masks)
    named = refit_with(base, "damper_asymmetry", sp.fit_recordings, sp.fit_masks, max_nfev=400)
    comp = compare(base, named, sp)
    h = Hypothesis.from_comparison("damper_asymmetry", "", "asymmetry", 1, base, named, comp)
    return h, judge_beside_drift(named, [h], sp, 400, COMPONENT_RULE)


def test_an_asymmetry_that_took_up_a_wandering_zero_is_withdrawn():
    # the truth holds no asymmetry; a zero wandering by 5 % of the force's range makes
    # its refit significant against the baseline's cubic drift (on this seed: of seeds
    # 0-7, the one where the search would name it, checked first)
    h, (final, out) = _judged(_mr_case(asymmetry=0.0, drift=0.05, seed=4))
    assert h.p_value_corrected < COMPONENT_RULE.alpha  # the search would name it
    assert [w.hypothesis for w in out] == [h]
    assert out[0].p_value_corrected >= COMPONENT_RULE.alpha or out[0].delta_bic_corrected >= 0
    assert [e.kind for e in final.model.effects] == ["zero_drift"]
    assert "beside a zero drift of more shape" in out[0].sentence()


@pytest.mark.parametrize("drift", [0.0, 0.05])
def test_a_real_asymmetry_is_kept_beside_the_drift(drift):
    # the truth holds a rebound damping 25 % above the compression's: its half-wave shape
    # within every cycle is no drift's, with or without a wandering zero
    h, (final, out) = _judged(_mr_case(asymmetry=135.0, drift=drift))
    assert out == []
    assert "damper_asymmetry" in [e.kind for e in final.model.effects]


@pytest.mark.parametrize(("family", "seed"), [("mr_damper", 5215), ("mr_damper", 5224)])
def test_the_reported_drifting_controls_name_nothing(family, seed):
    # the two false alarms of the independent set 5214-5225 (its generator shares no code
    # with the engine; reference: a control conceals nothing): a zero wandering by 2-5 %
    # of the force's range, before this check named a bump/rebound asymmetry
    from benchmarks.independent.cases import make_case, plan
    from benchmarks.independent.export import to_recording
    from suspenv.diagnosis.engine import diagnose

    (spec,) = [s for s in plan(family, seed) if s.kind == "control"]
    rec = to_recording(make_case(spec))
    diag = diagnose(rec, family)
    assert diag.named == [], diag.verdict
    (gone,) = [h for h in diag.hypotheses if h.withdrawn]
    assert gone.kind == "damper_asymmetry"
    assert "beside a zero drift of more shape" in diag.verdict
