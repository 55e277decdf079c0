"""The compiled ride loop (``ride_kernel``) against the numpy loop of ``RideModel``.

Reference: the numpy RK4 loop of :meth:`RideModel.simulate` (``RideModel.rhs``, the batch
on the last axis; its physics is tested against closed forms and the linear spectral
model in ``test_minibus_ride_model.py`` and ``test_ride_spectral.py``). The compiled loop
runs the same laws design by design with sums in another order, so the outputs must agree
to rounding (a few ulps of the largest value, grown over the run's few thousand steps:
1e-12 relative), with every effect the ride model supports, a seat mount, the linear
model, discarded settling steps and a recorded state history; and bad effect parameters
must be refused at construction.
"""

import numpy as np
import pytest

from benchmarks.ride_truth import random_road_inputs_recording
from suspenv.core.errors import ValidationError
from suspenv.diagnosis.ride.model import (
    _batch,
    half_step_inputs,
    pulse_inputs_recording,
    ride_effect,
)
from suspenv.models.minibus import STUDY_PICK, ride_kernel, vehicle_parameters
from suspenv.models.minibus.ride_model import RideModel, SeatMount

pytestmark = pytest.mark.skipif(not ride_kernel.AVAILABLE, reason="numba not installed")

B = 3
EFFECTS = [
    ride_effect("bump_stop", "rear_suspension", gap=0.012, k_stop=4e5),
    ride_effect("rebound_stop", "front_suspension", gap=0.01, k_stop=2e5),
    ride_effect("coulomb_friction", "front_damper", f_c=250.0),
    ride_effect("dahl_hysteresis", "rear_leaf", f_c=700.0, sigma=2e5),
]


def _params():
    X = np.tile(STUDY_PICK, (B, 1))
    X[1, 0] *= 1.3  # a stiffer front damper curve
    X[2, 3] *= 0.8  # a softer rear leaf
    return [vehicle_parameters(X, "no_load"), vehicle_parameters(X, "full_load")]


def _both(model: RideModel, rec) -> tuple:
    zh, zd, dt = half_step_inputs(rec)
    compiled = model.simulate(zh, zd, dt, record_states=True, discard=2)
    model._packed = None  # the numpy loop
    return compiled, model.simulate(zh, zd, dt, record_states=True, discard=2)


@pytest.mark.parametrize(
    "options",
    [
        {"effects": [_batch(e, 2 * B) for e in EFFECTS]},
        {"effects": [EFFECTS[0]]},
        {"seat": SeatMount()},
        {"linear": True},
        {},
    ],
    ids=["all_effects", "scalar_stop", "seat", "linear", "plain"],
)
@pytest.mark.parametrize("test", ["pulse", "random"])
def test_compiled_matches_numpy_loop(options, test):
    rec = (
        pulse_inputs_recording(50.0)
        if test == "pulse"
        else random_road_inputs_recording(60.0, "C", 3.0, seed=4)
    )
    a, b = _both(RideModel(_params(), **options), rec)
    assert a.ok.all() and b.ok.all()
    for key in ("body_acc", "acc_front", "acc_rear", "states"):
        x, y = getattr(a, key), getattr(b, key)
        assert x.shape == y.shape
        np.testing.assert_allclose(x, y, rtol=0, atol=1e-12 * np.max(np.abs(y)), err_msg=key)


@pytest.mark.parametrize(
    ("effect", "rule"),
    [
        (ride_effect("bump_stop", "front_suspension", gap=-0.01, k_stop=1e5), "gap >= 0"),
        (ride_effect("bump_stop", "front_suspension", gap=0.01, k_stop=1e5, p=0.5), "p >= 1"),
        (ride_effect("coulomb_friction", "rear_damper", f_c=100.0, v_eps=0.0), "v_eps > 0"),
    ],
)
def test_bad_effect_parameters_refused_at_construction(effect, rule):
    with pytest.raises(ValidationError, match=rule):
        RideModel(_params(), effects=[effect])
