"""Diagnosis of K&C rig recordings of the McPherson axle: planted cases with known answers.

The "measured" recordings come from a truth vehicle with concealed effects (the same
solver with another effect list, plus seeded sensor noise); the diagnosis sees only
the recordings. Coarse loops (6 grid intervals over the +-40 mm stroke) keep the default set quick.
"""

from __future__ import annotations

import numpy as np
import pytest
from strict_json import strict_loads

from benchmarks.knc_truth import loop_gap_at_static
from suspenv.core.errors import ValidationError
from suspenv.diagnosis.engine import diagnose
from suspenv.diagnosis.knc.family import KncFamily, split_tests
from suspenv.measurements import load_recording, save_recording
from suspenv.measurements.knc import half_loops
from suspenv.models.effects import make_effect
from suspenv.models.mcpherson import build_axle, reference_design
from suspenv.reports.diagnosis.knc import write_knc_report
from suspenv.rigs.knc import run_tests
from suspenv.rigs.knc_axle import KncAxleModel, make_candidate
from suspenv.rigs.knc_recording import from_recording, to_recording
from suspenv.rigs.knc_truth import blind_case, measure_truth

STEPS = 6


#: every effect family, without the location variants of the hysteresis (quicker)
FAMILIES = (
    "dahl_hysteresis",
    "coulomb_friction",
    "cubic_stiffness",
    "lr_asymmetry",
    "sensor_gain",
    "sensor_offset",
)


@pytest.fixture(scope="module")
def hysteresis_case():
    recs = measure_truth({"hysteresis": {"f_c": 80.0}}, seed=3, steps=STEPS)
    return recs, diagnose(recs, KncFamily(max_effects=1), holdout="single", candidates=FAMILIES)


@pytest.fixture(scope="module")
def noise_case():
    recs = measure_truth({}, seed=4, steps=STEPS)
    return recs, diagnose(recs, "knc", holdout="single", candidates=FAMILIES)


# ------------------------------------------------------------------ recordings
def test_recording_round_trip_matches_rig_branches(tmp_path):
    res = run_tests(build_axle(reference_design()[None]), ("opposite",), steps=STEPS)["opposite"]
    rec = to_recording(res)
    # reference: the rig's own branch extraction (KCResult.branch)
    down, up = half_loops(rec, rec.outputs["toe_right"])
    np.testing.assert_allclose(down, res.branch("toe", "down")[0, :, 1])
    np.testing.assert_allclose(up, res.branch("toe", "up")[0, :, 1])
    # lateral channels are outboard positive: the right wheel's y is negated
    np.testing.assert_allclose(
        rec.outputs["contact_lateral_right"], -res.channels["contact_y"][0, :, 1]
    )
    back = from_recording(rec)
    np.testing.assert_allclose(back.channels["contact_y"], res.channels["contact_y"])
    save_recording(rec, tmp_path / "opp.npz")
    again = load_recording(tmp_path / "opp.npz")
    assert again.meta["rig"] == "knc" and again.test == "knc_opposite"
    np.testing.assert_allclose(again.outputs["tyre_fz_left"], rec.outputs["tyre_fz_left"])


def test_parallel_travel_of_a_symmetric_axle_is_symmetric():
    # reference: mirror symmetry of the axle (left/right channels equal in parallel travel)
    recs = measure_truth({}, seed=0, steps=STEPS, noise_scale=0.0, tests=("parallel",))
    r = recs["parallel"]
    for c in ("toe", "camber", "tyre_fz", "contact_lateral", "contact_x"):
        np.testing.assert_allclose(r.outputs[f"{c}_left"], r.outputs[f"{c}_right"], atol=1e-7)


def test_model_asymmetry_and_gain_equal_hand_built_sides():
    # reference: the two sides built by hand (right - left = d, centred on the design)
    rec = measure_truth({}, seed=0, steps=STEPS, noise_scale=0.0, tests=("parallel",))["parallel"]
    model = KncAxleModel(
        [
            make_candidate("lr_asymmetry", d_static_toe=0.04, d_tie_rod_inner_z=1.0),
            make_candidate("sensor_gain", gain=1.03),
        ]
    )
    pred = model.simulate(model.initial_guess(rec), rec)
    x = reference_design()
    left, right = x.copy(), x.copy()
    from suspenv.models.mcpherson.params import PARAMETER_NAMES

    for name, d in (("static_toe", 0.04), ("tie_rod_inner_z", 1.0)):
        j = PARAMETER_NAMES.index(name)
        left[j] -= d / 2
        right[j] += d / 2
    res = run_tests(build_axle(left[None], right[None]), ("parallel",), steps=STEPS)["parallel"]
    np.testing.assert_allclose(pred["toe_left"], res.channels["toe"][0, :, 0], atol=1e-9)
    np.testing.assert_allclose(pred["toe_right"], res.channels["toe"][0, :, 1], atol=1e-9)
    np.testing.assert_allclose(pred["tyre_fz_right"], 1.03 * res.channels["tyre_fz"][0, :, 1])


def test_model_with_concealed_effect_reproduces_the_truth_exactly():
    # reference: the truth vehicle's own loops (same solver, same effect list)
    rec = measure_truth({"friction": {"f_c": 150.0}}, seed=0, steps=4, noise_scale=0.0)["parallel"]
    model = KncAxleModel([make_candidate("coulomb_friction", f_c=150.0)])
    pred = model.simulate(model.initial_guess(rec), rec)
    np.testing.assert_allclose(pred["tyre_fz_left"], rec.outputs["tyre_fz_left"], atol=1e-6)
    assert model.parameter_names[-1] == "coulomb_friction.f_c"
    batch = model.simulate(np.vstack([model.initial_guess(rec)] * 2), rec)
    assert batch["toe_left"].shape == (2, rec.n_samples)


def test_a_batch_reads_its_cached_rows_before_the_cache_forgets_them():
    # reference: the same rows simulated one at a time (a batch's rows are independent)
    rec = measure_truth({}, seed=0, steps=4, noise_scale=0.0, tests=("parallel",))["parallel"]
    model = KncAxleModel(tests=("parallel",))
    thetas = model.initial_guess(rec) + np.outer(np.arange(66) * 1e-4, np.eye(8)[0])
    alone = [model.simulate(th, rec)["toe_left"] for th in thetas[:64]]  # 64 rows cached
    batch = model.simulate(thetas[[0, 64, 65]], rec)["toe_left"]  # row 0 the oldest
    last = KncAxleModel(tests=("parallel",)).simulate(thetas[65], rec)["toe_left"]
    np.testing.assert_array_equal(batch[0], alone[0])
    np.testing.assert_allclose(batch[2], last, atol=1e-12)


# ------------------------------------------------------------------ planted cases
def test_hysteresis_is_named_and_its_loop_width_recovered(hysteresis_case):
    recs, diag = hysteresis_case
    assert diag.named_kinds[:1] == ["dahl_hysteresis"]
    assert "rubber bushing hysteresis" in diag.named[0].words
    # reference: the truth vehicle's noise-free loop (same seed, zero noise)
    exact = measure_truth({"hysteresis": {"f_c": 80.0}}, seed=3, steps=STEPS, noise_scale=0.0)
    rec = exact["parallel"]
    sides = ("left", "right")
    true_w = np.mean([loop_gap_at_static(rec, rec.outputs[f"tyre_fz_{s}"]) for s in sides])
    pred = diag.final_fit.model.simulate(diag.final_fit.theta, rec)
    fit_w = np.mean([loop_gap_at_static(rec, pred[f"tyre_fz_{s}"]) for s in sides])
    assert true_w > 20.0  # the loop is real and well above the 1 N noise
    assert abs(fit_w / true_w - 1.0) < 0.20


def test_hysteresis_refit_improves_held_out_single_wheel_travel(hysteresis_case):
    _, diag = hysteresis_case
    c = diag.comparison
    assert diag.holdout.startswith("rig test(s) single")
    assert c is not None and c.heldout_reduction > 0.05
    fz = "tyre_fz_left"
    assert c.heldout_rms_after[fz] < 0.8 * c.heldout_rms_before[fz]


def test_friction_is_not_preferred_to_hysteresis(hysteresis_case):
    _, diag = hysteresis_case
    lr: dict[str, float] = {}
    for h in diag.hypotheses:
        lr[h.kind] = max(lr.get(h.kind, 0.0), h.lr_statistic_corrected)
    assert lr["dahl_hysteresis"] > lr["coulomb_friction"]


def test_left_right_tolerance_is_named_asymmetry():
    recs = measure_truth({"asymmetry": {}}, seed=5, steps=STEPS)
    diag = diagnose(recs, KncFamily(max_effects=1), holdout="single", candidates=FAMILIES)
    assert diag.named_kinds == ["lr_asymmetry"]
    assert diag.named[0].heldout_reduction > 0.05
    # reference: the truth's own right-minus-left static toe (ADAMS/Car deg, seeded)
    from suspenv.models.mcpherson.truth import truth_vehicle

    truth = truth_vehicle(5, hysteresis=False, noise=False)
    from suspenv.models.mcpherson.params import PARAMETER_NAMES

    j = PARAMETER_NAMES.index("static_toe")
    d_true = truth.right[j] - truth.left[j]
    d_fit = diag.named[0].params["lr_asymmetry.d_static_toe"]["value"]
    assert abs(d_fit - d_true) < 0.3 * abs(d_true) + 0.005


def test_noise_only_claims_nothing(noise_case):
    _, diag = noise_case
    assert diag.named == []
    assert diag.verdict.startswith("no significant missing physics")
    # under pure noise the score tests stay near N(0, 1)
    assert max(s.score for s in diag.signatures) < 3.0
    # the K&C rule judges held-out data in noise units: every refit's held-out z is
    # computed (the fits are weighted by noise levels) and the verdict quotes the
    # strongest candidate's
    comps = [h.comparison for h in diag.hypotheses if h.comparison is not None]
    assert comps and all(np.isfinite(c.heldout_z) for c in comps)
    assert "held-out z = " in diag.verdict


def test_report_files(noise_case, tmp_path):
    _, diag = noise_case
    paths = write_knc_report(diag, tmp_path)
    names = {p.name for p in paths}
    assert {"report.md", "diagnosis.json", "residual_map.png", "left_right.png"} <= names
    data = strict_loads((tmp_path / "diagnosis.json").read_text())
    assert data["family"] == "knc" and data["model"] == "knc_axle" and data["named"] == []
    assert "no significant" in (tmp_path / "report.md").read_text()


# ------------------------------------------------------------------ blind cases and input
def test_blind_case_keeps_the_truth_apart():
    case, truth = blind_case(11, steps=4)
    again, truth2 = blind_case(11, steps=4)
    assert truth == truth2
    assert set(case) == {"id", "recordings"}
    for rec in case["recordings"].values():
        assert "seed" not in rec.meta and "effects" not in rec.meta
    np.testing.assert_array_equal(
        case["recordings"]["parallel"].outputs["toe_left"],
        again["recordings"]["parallel"].outputs["toe_left"],
    )


def test_bad_input_names_the_rule():
    recs = measure_truth({}, seed=0, steps=4, noise_scale=0.0, tests=("parallel",))
    with pytest.raises(ValidationError, match="some but not all"):
        split_tests(recs, "parallel")
    with pytest.raises(ValidationError, match="candidates must be among"):
        diagnose(
            measure_truth({}, seed=0, steps=4, tests=("parallel", "single")),
            "knc",
            candidates=["bump_stop"],
        )
    with pytest.raises(ValidationError, match="K&C effect kind"):
        KncAxleModel([make_effect("bouc_wen_hysteresis")])
    with pytest.raises(ValidationError, match="truth effects must be among"):
        measure_truth({"magic": {}})


@pytest.mark.slow
def test_held_out_other_amplitude_for_friction():
    # fit on 40 mm loops, validate on 25 mm loops of the same vehicle
    fit_recs = measure_truth(
        {"friction": {"f_c": 150.0}}, seed=7, steps=STEPS, tests=("parallel", "opposite")
    )
    held = measure_truth(
        {"friction": {"f_c": 150.0}}, seed=8, steps=STEPS, amplitude=0.025, tests=("single",)
    )
    diag = diagnose(fit_recs, "knc", holdout=list(held.values()))
    assert diag.named_kinds[:1] == ["coulomb_friction"]
    assert diag.comparison.heldout_reduction > 0.05


def test_cli_targets(tmp_path):
    from suspenv.cli.targets import resolve_target

    target = resolve_target("knc-blind:12")
    recs = target.recordings
    assert target.family == "knc" and target.holdout == ["single"]
    assert set(recs) == {"parallel", "opposite", "single", "lateral", "longitudinal"}
    assert target.stem == "knc_blind_12"
    for test, rec in recs.items():
        save_recording(rec, tmp_path / f"{test}.npz")
    assert resolve_target(str(tmp_path)).family == "knc"
    again = resolve_target(str(tmp_path / "single.npz"))
    assert again.family == "knc" and set(again.recordings) == set(recs)
    with pytest.raises(ValidationError, match="TARGET must be"):
        resolve_target(str(tmp_path / "missing.npz"))
    with pytest.raises(ValidationError, match="integer seed"):
        resolve_target("knc-blind:x")


@pytest.mark.slow
def test_default_candidates_locate_lower_arm_hysteresis():
    # lower-arm bushes only: the location variants compete; a top-mount-only loop
    # would not fit the toe/camber loops the lower-arm bushes leave
    recs = measure_truth(
        {"hysteresis": {"f_c": 100.0, "bushings": ["lca_front", "lca_rear"]}}, seed=9, steps=STEPS
    )
    diag = diagnose(recs, "knc")
    assert diag.named_kinds[:1] == ["dahl_hysteresis"]
    assert "lower-arm" in diag.named[0].words
    assert "coulomb_friction" not in diag.named_kinds


def test_location_ambiguity_is_stated_only_for_equal_fits():
    from suspenv.diagnosis.hypothesis import Hypothesis
    from suspenv.diagnosis.knc.family import location_ambiguities

    def hyp(location: str, lr: float, significant: bool = True) -> Hypothesis:
        h = Hypothesis(
            "dahl_hysteresis",
            location,
            "hysteresis",
            location,
            1,
            5.0,
            "",
            lr,
            lr,
            1,
            1e-9,
            -lr,
            0.1,
        )
        h.significant = significant
        return h

    win = hyp("", 195.3)
    close, far, weak = (hyp("lower_arm", 194.2), hyp("x", 120.0), hyp("y", 195, False))
    amb = location_ambiguities(win, [win, close, far, weak])
    assert [(a.a, a.b) for a in amb] == [("dahl_hysteresis", "dahl_hysteresis@lower_arm")]
    assert "cannot separate" in amb[0].sentence()


# ------------------------------------------------------------------ blind plan, detectability
def test_blind_plan_covers_every_kind_and_location():
    from collections import Counter

    from benchmarks.knc_diagnosis import DEV_SEEDS, REPORT_SEEDS
    from suspenv.rigs.knc_truth import (
        BLIND_PLAN,
        HYSTERESIS_LOCATIONS,
        TRUTH_KIND,
        blind_truth,
        case_type,
    )

    # reference: the minimum composition (>= 18 single, >= 6 two-effect, >= 6 none)
    for seeds in (REPORT_SEEDS, DEV_SEEDS):
        types = Counter(case_type(s) for s in seeds)
        n_one = sum(v for t, v in types.items() if t != "none" and "+" not in t)
        n_two = sum(v for t, v in types.items() if "+" in t)
        assert len(seeds) >= 30 and n_one >= 18 and n_two >= 6 and types["none"] >= 6
        singles = {t for t in types if t != "none" and "+" not in t}
        assert {t.split("@")[0] for t in singles} == set(TRUTH_KIND)
        assert {f"hysteresis@{w}" for w in HYSTERESIS_LOCATIONS} <= singles
    assert not set(DEV_SEEDS) & set(REPORT_SEEDS)
    assert len(BLIND_PLAN) == len(REPORT_SEEDS)
    t = blind_truth(REPORT_SEEDS[0] + 2 * len(BLIND_PLAN))
    assert t["case_type"] == case_type(REPORT_SEEDS[0])
    assert (
        len(t["expected_kinds"])
        == len(t["effects"])
        == len([] if t["case_type"] == "none" else t["case_type"].split("+"))
    )


def test_truth_snr_scales_inversely_with_the_noise():
    from benchmarks.knc_truth import truth_snr

    eff = {"hysteresis": {"f_c": 60.0, "bushings": ["top_mount"]}}
    a = truth_snr(eff, 0, 1.0, steps=STEPS)
    b = truth_snr(eff, 0, 2.0, steps=STEPS)
    # reference: the noise-weighted fit is invariant to a common noise factor, so the
    # noncentrality sum((d / sigma)^2) scales exactly with 1 / noise^2
    assert a["snr"] > 0
    assert b["snr"] == pytest.approx(a["snr"] / 2.0, rel=0.02)
    # the top mount shows only in the wheel load (in series with the spring)
    top = max(a["lambda_by_channel"], key=a["lambda_by_channel"].get)
    assert top.startswith("tyre_fz")
    assert truth_snr({}, 0, 1.0)["snr"] == 0.0


def test_noise_only_verdict_states_what_the_tests_cannot_see(noise_case, tmp_path):
    from benchmarks.knc_truth import truth_snr
    from suspenv.diagnosis.knc.detectability import DETECTABLE_SNR

    _, diag = noise_case
    lim = diag.detection_limits
    assert set(lim) == {
        "dahl_hysteresis@top_mount",
        "dahl_hysteresis@lower_arm",
        "coulomb_friction",
    }
    assert "top mount below f_c ~" in diag.verdict
    # top-mount hysteresis is far harder to see in vertical travel than lower-arm hysteresis
    assert lim["dahl_hysteresis@top_mount"]["limit"] > 5 * lim["dahl_hysteresis@lower_arm"]["limit"]
    # reference: an independent computation from the truth side (the plain model fitted
    # to the noise-free loops of a truth carrying the element at the stated limit)
    f_c = lim["dahl_hysteresis@top_mount"]["limit"]
    snr = truth_snr({"hysteresis": {"f_c": f_c, "bushings": ["top_mount"]}}, 4, 1.0, steps=STEPS)
    assert snr["snr"] == pytest.approx(DETECTABLE_SNR, rel=0.3)
    assert diag.to_dict()["findings"]["detection_limits"] == lim
    write_knc_report(diag, tmp_path)
    assert "could not have seen" in (tmp_path / "report.md").read_text()


def test_top_mount_hysteresis_below_the_noise_is_not_claimed():
    from benchmarks.knc_truth import truth_snr
    from suspenv.diagnosis.knc.detectability import DETECTABLE_SNR

    eff = {"hysteresis": {"f_c": 15.0, "bushings": ["top_mount"]}}
    # reference: the truth's own signal-to-noise (noise-free loops vs the plain model)
    assert truth_snr(eff, 5, 1.5, steps=STEPS)["snr"] < DETECTABLE_SNR
    diag = diagnose(measure_truth(eff, seed=5, steps=STEPS, noise_scale=1.5), "knc")
    assert diag.named == []
    assert "top mount below f_c ~" in diag.verdict


def test_benchmark_scores_undetectable_cases_apart():
    from benchmarks.knc_diagnosis import summarise

    def row(ctype, n, ok, detectable, seconds=10.0):
        return {
            "case_type": ctype,
            "n_true": n,
            "top1_ok": ok if n == 1 else None,
            "all_found": bool(ok),
            "detectable": detectable if n else None,
            "false_alarms": 0 if (ok or n) else 1,
            "where_ok": None,
            "heldout_ratio": 0.9,
            "model_error_ratio": 0.4,
            "excess_ratio": 0.5,
            "param_rel_err": 0.1,
            "seconds": seconds,
            "cpu_seconds": seconds / 2,
        }

    rows = [
        row("friction", 1, True, True),
        row("friction", 1, True, True),
        row("hysteresis@top_mount", 1, False, False),
        row("none", 0, False, None),
        row("none", 0, True, None),
    ]
    s = summarise(rows)
    # reference: counted by hand from the rows above
    assert s["top1_accuracy_one_effect"] == pytest.approx(2 / 3)
    assert s["top1_accuracy_one_effect_detectable"] == 1.0
    assert s["one_effect_undetectable_cases"] == 1
    assert s["top1_accuracy_one_effect_undetectable"] == 0.0
    assert s["top1_by_case_type"] == {"friction": "2/2", "hysteresis@top_mount": "0/1"}
    assert s["false_alarm_rate_no_effect"] == 0.5
    assert s["median_cpu_seconds_per_diagnosis"] == 5.0


def test_sensor_offset_the_fit_mimics_is_found_by_the_score_test():
    from suspenv.diagnosis.knc.score_test import score_test

    # a wheel-load offset that the bushing positions and top-mount rate largely absorb:
    # its residual no longer looks like a constant, but the score test against the
    # model sees what the fitted parameters cannot follow
    recs = measure_truth({"sensor_offset": {"offset": -11.0}}, seed=107, steps=STEPS)
    diag = diagnose(recs, "knc", candidates=("sensor_offset", "sensor_gain"))
    assert diag.named_kinds[:1] == ["sensor_offset"]
    # reference: the truth's offset
    assert diag.named[0].params["sensor_offset.offset"]["value"] == pytest.approx(-11.0, rel=0.2)
    # reference: for an element entering the outputs linearly the score statistic and
    # the likelihood-ratio statistic of the refit estimate the same noncentrality
    lm, k = score_test(diag.base_fit, diag.fit_recordings, "sensor_offset")
    assert k == 1
    assert 0.4 < lm / diag.named[0].lr_statistic < 2.5


# ------------------------------------------------------------------ compliance tests
def test_compliance_recording_round_trip_and_each_wheels_own_drive():
    from suspenv.measurements.knc import drive, is_force_test
    from suspenv.reports.diagnosis.knc import left_minus_right

    axle = build_axle(reference_design()[None])
    res = run_tests(axle, ("lateral", "longitudinal"), steps=STEPS, force_amplitude=2000.0)
    for test, r in res.items():
        rec = to_recording(r)
        assert is_force_test(rec) and rec.units["force"] == "N"
        assert rec.meta["amplitude"] == 2000.0 and rec.meta["amplitude_unit"] == "N"
        np.testing.assert_array_equal(rec.inputs["pad_left"], 0.0)
        f = r.grid[r.path] / 2000.0
        # lateral: a +y force is outboard on the left wheel, inboard on the right
        np.testing.assert_allclose(drive(rec, "left"), f)
        np.testing.assert_allclose(drive(rec, "right"), -f if test == "lateral" else f)
        back = from_recording(rec)
        np.testing.assert_allclose(back.grid, r.grid)
        np.testing.assert_allclose(back.channels["toe"], r.channels["toe"])
        # reference: mirror symmetry of the axle; at equal own drive both wheels agree
        for c in ("toe", "camber", "tyre_fz", "contact_lateral", "contact_x"):
            size = 1.0 + np.abs(rec.outputs[f"{c}_left"]).max()  # wheel load ~4 kN
            np.testing.assert_allclose(left_minus_right(rec, rec.outputs, c), 0.0, atol=1e-7 * size)


def test_model_replays_travel_and_compliance_recordings_like_the_rig():
    # reference: the rig run directly on the same axle (two batches: m and N amplitudes)
    recs = measure_truth(
        {}, seed=0, steps=4, noise_scale=0.0, tests=("parallel", "lateral"), force_amplitude=1500.0
    )
    model = KncAxleModel(tests=("parallel", "lateral"))
    theta = model.initial_guess()
    direct = run_tests(
        build_axle(reference_design()[None]),
        ("parallel", "lateral"),
        steps=4,
        force_amplitude=1500.0,
    )
    for test, rec in recs.items():
        pred = model.simulate(theta, rec)
        np.testing.assert_allclose(pred["toe_left"], direct[test].channels["toe"][0, :, 0])
        np.testing.assert_allclose(pred["camber_right"], direct[test].channels["camber"][0, :, 1])


@pytest.mark.slow
def test_top_mount_hysteresis_above_the_noise_is_named_at_the_top_mount():
    # planted: a top-mount Dahl element well above the detection limit (truth_snr >= 5)
    from benchmarks.knc_truth import truth_snr
    from suspenv.diagnosis.knc.detectability import DETECTABLE_SNR

    eff = {"hysteresis": {"f_c": 150.0, "bushings": ["top_mount"]}}
    assert truth_snr(eff, 5, 0.7, steps=STEPS)["snr"] > DETECTABLE_SNR
    recs = measure_truth(
        eff, seed=5, steps=STEPS, noise_scale=0.7, tests=("parallel", "opposite", "single")
    )
    diag = diagnose(recs, KncFamily(max_effects=1))
    assert diag.named_kinds == ["dahl_hysteresis"]
    assert next(iter(diag.named[0].params)).startswith("dahl_hysteresis@top_mount")


@pytest.mark.slow
def test_a_second_round_after_friction_claims_nothing_false():
    # planted: strut friction alone; the polished friction model is the second round's
    # null, so no elastic or sensor candidate may gain likelihood from its convergence
    recs = measure_truth({"friction": {"f_c": 120.0}}, seed=21, steps=STEPS, noise_scale=0.6)
    diag = diagnose(recs, KncFamily(max_effects=2), candidates=FAMILIES)
    assert diag.named_kinds == ["coulomb_friction"]
    second = [h for h in diag.hypotheses if h.round == 2]
    assert second and max(h.lr_statistic_corrected for h in second) < 20.0
