"""Optional physics of the McPherson axle: strut friction, progressive bushings, and one
effect vocabulary for the solver, the fitted model and the truth generator."""

from __future__ import annotations

import numpy as np
import pytest

from suspenv.core.errors import ValidationError
from suspenv.metrics.knc import loop_width, objectives_subset
from suspenv.models.effects import make_effect
from suspenv.models.mcpherson import AxleSolver, axle_effect, build_axle, reference_design
from suspenv.rigs.knc import run_tests


@pytest.fixture(scope="module")
def axle():
    return build_axle(reference_design()[None, :])


def test_strut_friction_loop_width_matches_hand_calculation(axle):
    # reference: hand calculation. A saturated friction force f between rod and tube
    # reverses between the branches (2 f along the strut); through the motion ratio MR it
    # acts on the wheel, which shares it between the tyre (k_t) and the suspension
    # (wheel rate k_w) in parallel, so the tyre sees 2 f MR k_t / (k_t + k_w).
    f = 100.0
    eff = [axle_effect("coulomb_friction", "strut", f_c=f, sigma=5e6)]
    res = run_tests(axle, ("parallel",), steps=10, effects=eff)
    assert res["parallel"].ok.all()
    plain = run_tests(axle, ("parallel",), steps=10)
    k_w = objectives_subset(plain, ("par_susp_ride_rate_pos",))[0, 0]
    k_t = axle.constants.tyre_rate
    mr = AxleSolver(axle).motion_ratio_kinematic[0, 0]
    r = res["parallel"]
    gap = r.branch("tyre_fz", "up") - r.branch("tyre_fz", "down")
    hand = 2 * f * mr * k_t / (k_t + k_w)
    assert gap[0, r.static_index, 0] == pytest.approx(hand, rel=0.03)


def test_progressive_bushings_stiffen_and_keep_the_loop_closed(axle):
    # reference: a cubic term only adds stiffness (energy argument) and is elastic
    eff = [axle_effect("cubic_stiffness", "lower_arm_and_top_mount", ratio=0.5)]
    res = run_tests(axle, ("parallel",), steps=10, effects=eff)
    plain = run_tests(axle, ("parallel",), steps=10)
    assert loop_width(res).max() < 0.05  # elastic: no loop
    name = ("par_susp_ride_rate_pos",)
    assert objectives_subset(res, name)[0, 0] > objectives_subset(plain, name)[0, 0]
    d = res["parallel"].branch("tyre_fz", "down") - plain["parallel"].branch("tyre_fz", "down")
    assert np.abs(d).max() > 1.0


def test_truth_and_fitted_model_are_the_same_code():
    # reference: the truth generator and the fitted model place the same effects-library
    # objects through the same solver and sensor elements, so a model holding a truth
    # case's effects at the reference design reproduces its noise-free loops bit for bit
    from suspenv.rigs.knc_axle import KncAxleModel
    from suspenv.rigs.knc_truth import measure_truth, truth_effects

    truth = {
        "hysteresis": {"f_c": 95.0, "bushings": ["lca_front", "lca_rear"]},
        "friction": {"f_c": 70.0},
        "progressive": {"ratio": 0.3},
        "sensor_gain": {"gain": 0.97},
        "sensor_offset": {"offset": -6.0},
    }
    tests = ("parallel", "lateral")
    recs = measure_truth(truth, seed=2, steps=4, noise_scale=0.0, tests=tests)
    effects, tolerance = truth_effects(truth)
    assert tolerance is None
    assert [e.name for e in effects] == [
        "dahl_hysteresis@lower_arm",
        "coulomb_friction",
        "cubic_stiffness",
        "sensor_gain",
        "sensor_offset",
    ]
    model = KncAxleModel(effects, tests=tests)
    theta = model.initial_guess()
    assert dict(zip(model.parameter_names, theta, strict=True))["coulomb_friction.f_c"] == 70.0
    for test, rec in recs.items():
        pred = model.simulate(theta, rec)
        for name, measured in rec.outputs.items():
            assert np.array_equal(pred[name], measured), (test, name)


def test_effects_are_rejected_where_the_solver_cannot_place_them(axle):
    with pytest.raises(
        ValidationError, match=r"coulomb_friction element sits at 'strut'.*'lca_front'"
    ):
        AxleSolver(axle, [make_effect("coulomb_friction", location="lca_front", f_c=50.0)])
    with pytest.raises(ValidationError, match=r"`location` must be a bushing.*'wishbone'"):
        run_tests(
            axle,
            ("parallel",),
            steps=4,
            effects=[make_effect("dahl_hysteresis", location="wishbone")],
        )
    with pytest.raises(
        ValidationError, match=r"dahl_hysteresis element sits at a bushing.*'strut'"
    ):
        axle_effect("dahl_hysteresis", "strut")
    with pytest.raises(ValidationError, match=r"simulates the kinds.*'bump_stop'"):
        axle_effect("bump_stop", "top_mount")
    with pytest.raises(ValidationError, match=r"`f_c > 0` must hold, but got 0.0"):
        axle_effect("dahl_hysteresis", "top_mount", f_c=0.0)
    with pytest.raises(ValidationError, match=r"`sigma` must stay at its default"):
        axle_effect("dahl_hysteresis", "top_mount", sigma=3e4)
    with pytest.raises(ValidationError, match=r"bushing 'top_mount' already has one"):
        AxleSolver(
            axle,
            [
                axle_effect("dahl_hysteresis", "top_mount"),
                axle_effect("dahl_hysteresis", "bushings"),
            ],
        )


def test_candidates_are_kind_at_location_effects_of_the_library():
    from suspenv.models.mcpherson import MOMENT_ARM, bushings_at
    from suspenv.rigs.knc_axle import (
        KncAxleModel,
        base_kind,
        effect_words,
        make_candidate,
    )

    top = make_candidate("dahl_hysteresis@top_mount", f_c=90.0)
    assert (top.kind, top.name, top.location, top.params["f_c"]) == (
        "dahl_hysteresis",
        "dahl_hysteresis@top_mount",
        "top_mount",
        90.0,
    )
    plain = make_candidate("dahl_hysteresis")
    assert (plain.name, plain.params["f_c"]) == ("dahl_hysteresis", 40.0)
    assert bushings_at(plain.location) == ("lca_front", "lca_rear", "top_mount")
    assert effect_words(plain) == (
        "rubber bushing hysteresis (Dahl) in the lower-arm bushes and top mount"
    )
    assert effect_words(make_candidate("sensor_gain")) == (
        "sensor gain (calibration) error in the wheel-load cells"
    )
    assert base_kind("dahl_hysteresis@lower_arm") == "dahl_hysteresis"
    assert MOMENT_ARM == 0.05
    model = KncAxleModel([top, make_candidate("lr_asymmetry", d_static_toe=0.04)])
    assert model.parameter_names[-6:] == (
        "dahl_hysteresis@top_mount.f_c",
        "lr_asymmetry.d_static_toe",
        "lr_asymmetry.d_static_camber",
        "lr_asymmetry.d_tie_rod_inner_z",
        "lr_asymmetry.d_lower_ball_joint_z",
        "lr_asymmetry.d_top_mount_kz",
    )
    assert set(KncAxleModel.candidate_effects) >= {"dahl_hysteresis@lower_arm", "coulomb_friction"}
    with pytest.raises(ValidationError, match=r"written `kind@location`"):
        make_candidate("dahl_hysteresis:top_mount")
    with pytest.raises(ValidationError, match=r"sits at 'strut'.*'top_mount'"):
        make_candidate("coulomb_friction@top_mount")
    with pytest.raises(ValidationError, match=r"location == 'tyre_fz'"):
        KncAxleModel([make_effect("sensor_gain", location="toe")])
