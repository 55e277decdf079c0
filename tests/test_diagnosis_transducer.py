"""A named sensor gain judged beside a reading error that grows with the signal's size.

Reference: a closed form. A force read as ``g (F + q F |F| / Y)`` (``Y`` its largest
size) and fitted with a gain leaves the signed square ``g q Y u |u|`` (``u`` the
prediction over its largest size, ``g Y``): the check's error at full scale is ``q``
whatever the gain, and a pure gain leaves none.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from suspenv.diagnosis.component.transducer import _coefficient, curvature_left
from suspenv.diagnosis.decision import DecisionRule
from suspenv.diagnosis.engine import make_family
from suspenv.diagnosis.fitting import fit
from suspenv.models.components.damper import DamperDynoModel
from suspenv.models.effects import make_effect


def _gain_fitted(q: float, seed: int):
    """A damper's force read with gain 1.05 and the signed square ``q``, white noise of
    0.3 % of its largest size; the standard baseline and a force gain fitted."""
    model = DamperDynoModel()
    rec = model.example_recording(seed=seed)
    force = model.simulate(model.theta_from({"c": 1500.0}), rec)["force"]
    top = float(np.max(np.abs(force)))
    noise = 3e-3 * top * np.random.default_rng(seed).standard_normal(force.size)
    read = 1.05 * (force + q * force * np.abs(force) / top) + noise
    fam = make_family("damper")
    setup = fam.prepare(replace(rec, outputs={"force": read}), None, None)
    sp = setup.split
    gain = make_effect("sensor_gain", location="force")
    fitted = fit(
        setup.model.with_effects((*setup.model.effects, gain)), sp.fit_recordings, sp.fit_masks
    )
    return fitted, sp


@pytest.mark.parametrize("q", [0.08, -0.12])
def test_a_reading_error_growing_with_size_is_found_beside_the_gain(q):
    fitted, sp = _gain_fitted(q, seed=3)
    left = curvature_left(fitted, sp, "force", DecisionRule())
    assert left.significant and left.remains
    # the closed form's q, within 10 %: the baseline's gas force and drift take a part
    # of the square's remainder (4 % and 7 % here)
    assert left.error_at_full_scale == pytest.approx(q, rel=0.1)
    assert "non-linear transducer" in left.sentence()


def test_a_pure_gain_leaves_no_reading_error():
    fitted, sp = _gain_fitted(0.0, seed=3)
    left = curvature_left(fitted, sp, "force", DecisionRule())
    assert abs(left.z) < 4.0 and not left.remains
    assert "does not change" in left.sentence()


def test_the_heldout_coefficient_is_one_for_a_real_change_and_zero_for_noise():
    # closed form: a held-out residual that holds the change d (plus white noise) has
    # coefficient 1 on it, one that holds noise only 0; no change cannot be placed
    rng = np.random.default_rng(5)
    d = np.sin(np.linspace(0.0, 20.0, 2000))
    noise = 0.1 * rng.standard_normal(d.size)
    beta, se = _coefficient(d + noise, d)
    assert abs(beta - 1.0) < 4 * se and se < 0.01
    beta, se = _coefficient(noise, d)
    assert abs(beta) < 4 * se
    assert _coefficient(noise, np.zeros_like(d)) == (0.0, float("inf"))


def test_a_gain_the_heldout_samples_cannot_check_is_not_named_with_confidence():
    # development seed 214 conceals a non-linear deflection transducer (outside the
    # library); the fit samples show the signed square (z = 16), while the few held-out
    # cycles are of small amplitude and cannot place it: the named gain is not confident
    from benchmarks.component_truth import make_case
    from suspenv.diagnosis.engine import diagnose

    case = make_case("quarter_car_rig", 214, 0, outside=True)
    assert case.truth.effects[0]["kind"] == "transducer_nonlinearity"
    fam = make_family("quarter_car_rig", max_effects=2)
    diag = diagnose(case.recording, fam)
    assert diag.named_kinds == ["sensor_gain"] and not diag.confident
    (left,) = [x for x in diag.findings["beyond_library"] if hasattr(x, "heldout_coefficient")]
    assert left.significant and not left.confirmed
    assert "cannot confirm" in left.sentence()
