"""The field-dependent MR damper and the missing-input check.

References: the MR law against scipy's ``solve_ivp`` of the same ODE (a second solver),
its u = 0 limit against the passive MR model with a Bouc-Wen element, its odd symmetry;
the check's definitions against closed forms (white noise's second difference has
variance 6 sigma^2; a finite filter of a signal is a time-invariant function of it), its
exact null p-value against a Monte Carlo simulation, its level under six noises
independent of the motion, and the check on synthetic cases whose truth is known (a
switching coil current recorded or not; the effect-free controls of
:mod:`benchmarks.component_truth`).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.signal import lfilter

from benchmarks.component_truth import MR_FIELD_TRUTH, make_case, mr_field_case
from suspenv.core.errors import ValidationError
from suspenv.diagnosis.checks import missing_input as mi
from suspenv.diagnosis.decision import DecisionRule
from suspenv.diagnosis.engine import diagnose
from suspenv.measurements import Recording
from suspenv.measurements.units import to_si
from suspenv.models.components import MRFieldDamperModel, make_component
from suspenv.models.components.base import lowpass
from suspenv.models.effects import make_effect

TRUTH = dict(MR_FIELD_TRUTH)


def _without(rec: Recording, channel: str) -> Recording:
    keep = {k: v for k, v in rec.inputs.items() if k != channel}
    units = {k: u for k, u in rec.units.items() if k != channel}
    return Recording(rec.name, rec.test, rec.time, keep, rec.outputs, units, rec.meta)


@pytest.fixture(scope="module")
def case():
    return mr_field_case(0)


# ------------------------------------------------------------------ the MR law
def _short(case, n=600):
    rec = case.recording
    sl = slice(0, n)
    return Recording(
        "short",
        rec.test,
        rec.time[sl],
        {k: v[sl] for k, v in rec.inputs.items()},
        {},
        {k: u for k, u in rec.units.items() if k != "force"},
    )


def test_field_law_matches_solve_ivp(case):
    # the same ODE, dz/dt = (xdot - (b |xdot| z + (1 - b) xdot |z|)) / x_y, integrated
    # in time by an adaptive Runge-Kutta solver along the piecewise-linear displacement
    rec = _short(case)
    model = make_component("mr_damper", field="coil_current")
    force = model.simulate(model.theta_from(TRUTH), rec)["force"]
    t, x = rec.time, rec.inputs["displacement"]
    xy, b = TRUTH["x_y"], TRUTH["shape"]

    def rhs(tt, z):
        k = min(int(np.searchsorted(t, tt, side="right")) - 1, t.size - 2)
        xd = (x[k + 1] - x[k]) / (t[k + 1] - t[k])
        return [(xd - (b * abs(xd) * z[0] + (1 - b) * xd * abs(z[0]))) / xy]

    z = [0.0]
    for k in range(t.size - 1):  # segment by segment: the slope is constant on each
        z.append(solve_ivp(rhs, (t[k], t[k + 1]), [z[-1]], rtol=1e-10, atol=1e-12).y[0, -1])
    u, v = rec.inputs["coil_current"], rec.inputs["velocity"]
    ref = (
        (TRUTH["c"] + TRUTH["c_field"] * u) * v
        + TRUTH["k"] * x
        + TRUTH["f_0"]
        + (TRUTH["f_y"] + TRUTH["f_field"] * u) * np.array(z)
    )
    # solver tolerance 1e-10 on z (|z| <= 1) times forces of a few hundred N
    assert np.max(np.abs(force - ref)) < 1e-5 * np.max(np.abs(ref))


def test_zero_field_is_the_passive_model_with_bouc_wen(case):
    rec = _short(case)
    zero = Recording(
        rec.name,
        rec.test,
        rec.time,
        {**rec.inputs, "coil_current": np.zeros_like(rec.time)},
        {},
        rec.units,
    )
    field = make_component("mr_damper", field="coil_current")
    f_field = field.simulate(field.theta_from(TRUTH), zero)["force"]
    bw = make_effect("bouc_wen_hysteresis").with_params(
        {"f_y": TRUTH["f_y"], "x_y": TRUTH["x_y"], "shape": TRUTH["shape"], "n": 1.0}
    )
    passive = make_component("mr_damper", [bw])
    base = {k: TRUTH[k] for k in ("c", "k", "f_0")}
    f_passive = passive.simulate(passive.theta_from(base), zero)["force"]
    np.testing.assert_allclose(f_field, f_passive, rtol=1e-12, atol=1e-9)


def test_field_law_is_odd_in_the_motion(case):
    # F(-x, -v, u) = -F(x, v, u) from rest (z0 = 0) without a static force
    rec = _short(case)
    flip = Recording(
        rec.name,
        rec.test,
        rec.time,
        {
            **rec.inputs,
            "displacement": -rec.inputs["displacement"],
            "velocity": -rec.inputs["velocity"],
        },
        {},
        rec.units,
    )
    model = make_component("mr_damper", field="coil_current")
    th = model.theta_from({**TRUTH, "f_0": 0.0})
    np.testing.assert_allclose(
        model.simulate(th, flip)["force"], -model.simulate(th, rec)["force"], atol=1e-9
    )


def test_field_option_and_units_are_checked():
    with pytest.raises(ValidationError, match="`field` must be one of"):
        MRFieldDamperModel(field="coil_flux")
    model = make_component("mr_damper", field="coil_voltage")
    assert model.parameter_units[model.parameter_names.index("f_field")] == "N/V"
    assert to_si(np.array([250.0]), "mA") == (pytest.approx(np.array([0.25])), "A")


# ------------------------------------------------------------------ the check's parts
def test_white_floor_and_time_invariant_definitions():
    rng = np.random.default_rng(0)
    e = rng.normal(0.0, 2.0, 20000)
    # var(e[k+2] - 2 e[k+1] + e[k]) = 6 sigma^2 for white noise: the floor is sigma
    assert mi.white_floor(e) == pytest.approx(2.0, rel=0.03)
    s = rng.normal(size=20000)
    # a finite filter within the lags is a time-invariant linear function of its input
    # (before the first sample, the input held at its first value): explained to rounding
    fir = np.convolve(np.pad(s, (2, 0), mode="edge"), [0.5, 0.3, -0.2], mode="valid")
    assert np.allclose(mi.time_invariant(fir, [s]), fir, atol=1e-9 * np.std(fir))
    # a step of the input is explained by its cell means (all but the bin straddling 0)
    step = np.sign(s)
    assert np.var(step - mi.time_invariant(step, [s])) < 0.05 * np.var(step)
    # independent of the input: what is explained is the fitted columns' share of the
    # noise, about (columns) / samples
    left = e - mi.time_invariant(e, [s])
    assert np.var(left) > (1.0 - 3.0 * (2 * mi.LAGS + 2 + mi.FINE_BINS) / e.size) * np.var(e)


def test_play_operator_closed_form_and_rate_independence():
    # width 1 from 0: dragged at x - 1/2 going up, held within the play at each
    # reversal, dragged at x + 1/2 going down (worked by hand from the definition)
    s = np.array([0.0, 1.0, 2.0, 3.0, 2.0, 1.0, 0.0, 1.0])
    assert mi.play(s, 1.0).tolist() == [0.0, 0.5, 1.5, 2.5, 2.5, 1.5, 0.5, 0.5]
    # rate-independent: samples added along the monotone stretches change nothing
    fine = np.interp(np.arange(0.0, 7.01, 0.25), np.arange(8.0), s)
    assert np.allclose(mi.play(fine, 1.0)[::4], mi.play(s, 1.0))
    assert np.array_equal(mi.play(s, 0.0), s)


def _bouc_wen(x: np.ndarray, x_y: float) -> np.ndarray:
    """A Bouc-Wen loop (n = 2, beta = gamma = 1/2) of unit force yielding at ``x_y``,
    by explicit Euler in 50 steps per sample."""
    z, out = 0.0, np.zeros(x.size)
    for i, dx in enumerate(np.diff(x) / 50.0, start=1):
        for _ in range(50):
            z += dx / x_y * (1.0 - 0.5 * z * z - 0.5 * np.sign(dx * z) * z * z)
        out[i] = z
    return out


def test_a_rate_independent_loop_is_a_time_invariant_function_with_memory():
    # a Bouc-Wen loop yielding at 0.1 % of the travel under a motion of changing
    # amplitude: the play operators (Prandtl-Ishlinskii) take it up to its noise, the
    # memoryless fit leaves more than twice the noise
    rng = np.random.default_rng(0)
    t = np.arange(6000) * 0.005
    x = np.sin(2 * np.pi * 0.7 * t) * (1 + 0.5 * np.sin(2 * np.pi * 0.05 * t))
    x = x + 0.2 * np.sin(2 * np.pi * 2.3 * t + 1.0)
    v = np.gradient(x, t)
    r = _bouc_wen(x, 0.003) + 0.1 * rng.normal(size=t.size)
    with_memory = r - mi.time_invariant(r, [x, v], memory=True)
    assert np.std(with_memory) < 1.1 * 0.1
    assert np.std(r - mi.time_invariant(r, [x, v])) > 2.0 * 0.1
    assert mi.judge(r, 3.0 * v + r, {"displacement": x, "velocity": v})["size"] < 1.2


def test_switching_test_tells_a_switched_gain_from_coloured_noise():
    rng = np.random.default_rng(1)
    t = np.arange(6000) * 0.01
    y = np.sin(2 * np.pi * 1.3 * t) + 0.5 * np.sin(2 * np.pi * 0.7 * t)
    coloured = lfilter([1.0], [1.0, -0.9], rng.normal(size=t.size))
    assert mi.switching(coloured, [y])["p_switching"] > 0.01
    level = np.where((t // 3.7) % 2 == 0, -1.0, 1.0)
    assert mi.switching(0.3 * level * y + 0.05 * coloured, [y])["p_switching"] < 1e-6


def test_a_short_recording_is_judged_in_the_shortest_blocks():
    # 500 samples (8 s sampled at 62.5 Hz): 20 blocks of 25, above the
    # fewest the test takes; a gain switched every 1.5 s is found at the decision rule's
    # alpha (p about 0.003 over 20 blocks), coloured noise is not
    rng = np.random.default_rng(6)
    t = np.arange(500) * 0.016
    y = np.sin(2 * np.pi * 1.3 * t) + 0.5 * np.sin(2 * np.pi * 0.7 * t)
    coloured = lfilter([1.0], [1.0, -0.9], rng.normal(size=t.size))
    level = np.where((t // 1.5) % 2 == 0, -1.0, 1.0)
    found = mi.switching(0.3 * level * y + 0.05 * coloured, [y])
    assert found["block_samples"] == mi.BLOCK_SAMPLES[0]
    assert found["p_switching"] < DecisionRule().alpha
    assert mi.switching(coloured, [y])["p_switching"] > 0.01


@pytest.mark.parametrize("n, k", [(20, 1), (30, 7)])
def test_lag1_p_value_is_exact_for_independent_gains(n, k):
    # the reference: the lag-1 autocorrelation of 200000 independent normal vectors
    # regressed on the same columns (Monte Carlo); at its 80, 95 and 99 % quantiles the
    # exact p-value agrees within 4 binomial standard errors of the simulation
    rng = np.random.default_rng(3)
    a = np.column_stack([np.ones(n), rng.normal(size=(n, k - 1))])
    q, _ = np.linalg.qr(a)
    z = rng.normal(size=(n, 200000))
    e = z - q @ (q.T @ z)
    lag = 0.5 * (np.eye(n, k=1) + np.eye(n, k=-1))
    rhos = np.einsum("ij,ij->j", e, lag @ e) / np.einsum("ij,ij->j", e, e)
    for level in (0.8, 0.95, 0.99):
        j = int(np.argmin(np.abs(rhos - np.quantile(rhos, level))))
        rho, p = mi.lag1_p(z[:, j], a)
        mc = float(np.mean(rhos >= rho))
        assert abs(p - mc) < 4 * np.sqrt(mc * (1 - mc) / rhos.size)


def _smoothed_walk(rng: np.random.Generator, n: int) -> np.ndarray:
    """A random walk averaged over a quarter of the record, peak 1 (the independent
    generator's drift, :func:`benchmarks.independent.noise.drift`)."""
    walk, win = np.cumsum(rng.normal(size=n)), n // 4
    smooth = np.convolve(np.pad(walk, win, mode="edge"), np.ones(win) / win, "same")[win:-win]
    return (smooth - smooth[0]) / np.max(np.abs(smooth - smooth[0]))


def _null_noise(kind: str, rng: np.random.Generator, t: np.ndarray) -> np.ndarray:
    """Noise independent of the motion: white, AR(1) with coefficient 0.9 (correlation
    time about 10 samples), exp(-1/28) (28 samples, the independent generator's longest)
    or 0.99; white plus a drift of twice its RMS over a third of a period (as the
    drifting controls); ``lowpass``: white noise low-passed at 50 Hz (``t`` sampled at
    1 kHz) as the outputs compared low-passed, plus a smoothed random walk of three
    times its RMS."""
    w = rng.normal(size=t.size)
    if kind == "drift":
        return w + 2.0 * np.sin(2 * np.pi * t / (3.0 * t[-1]) + rng.uniform(0, 2 * np.pi))
    if kind == "lowpass":
        e = lowpass(w, 1000.0, 50.0)
        return e + 3.0 * np.std(e) * _smoothed_walk(rng, t.size)
    return w if kind == "white" else lfilter([1.0], [1.0, -float(kind)], w)


def test_a_low_passed_residual_is_judged_at_its_pass_band_rate():
    # sampled at 1 kHz and low-passed at 50 Hz: every 10th sample (2 fc = 100 Hz); its
    # second differences there see the noise, at the recorded rate almost none (the
    # filter leaves next to nothing above fc, where the second difference's gain lies);
    # the floor within 20 % of the RMS (what the filter's roll-off keeps correlated)
    t = np.arange(40000) * 1e-3
    assert mi.pass_band_step(1000.0, 50.0) == 10 and mi.pass_band_step(1000.0, None) == 1
    e = lowpass(np.random.default_rng(5).normal(size=t.size), 1000.0, 50.0)
    assert mi.white_floor(e) < 0.05 * np.std(e)
    assert mi.white_floor(e[::10]) == pytest.approx(np.std(e), rel=0.2)


@pytest.mark.slow
@pytest.mark.parametrize(
    "kind, n",
    [(k, 4000) for k in ("white", "0.9", "0.965", "0.99", "drift", "lowpass")]
    + [("white", 500), ("0.9", 500)],
)
def test_switching_test_holds_its_level_under_the_null(kind, n):
    # noise independent of the motion, 600 seeded draws (the low-passed ones judged at
    # their pass-band rate): the rejection rate at 0.05 and at the decision rule's alpha
    # (0.01) stays within a one-sided binomial bound of it (3 standard deviations: 46
    # and 13 of 600)
    rng = np.random.default_rng(4)
    dt = 1e-3 if kind == "lowpass" else 1e-2
    t = np.arange(3 * n if kind == "lowpass" else n) * dt
    step = mi.pass_band_step(1.0 / dt, 50.0 if kind == "lowpass" else None)
    draws, p = 600, []
    for _ in range(draws):
        f = rng.uniform(0.5, 3.0, 3)
        y = np.sum([np.sin(2 * np.pi * fk * t + rng.uniform(0, 6.3)) for fk in f], axis=0)
        e = _null_noise(kind, rng, t)
        p.append(mi.switching(e[::step], [y[::step]])["p_switching"])
    for alpha in (0.05, DecisionRule().alpha):
        hits = int(np.sum(np.array(p) < alpha))
        assert hits <= draws * alpha + 3 * np.sqrt(draws * alpha * (1 - alpha)), (alpha, hits)


def test_a_ripple_along_a_recorded_input_is_a_relation_not_a_missing_input():
    # cogging: a force periodic in the position (pitch 1/10 of the travel), a function of
    # a recorded input that neither the coherence nor a coarse grid of cells sees
    rng = np.random.default_rng(2)
    t = np.arange(6000) * 0.01
    x = np.sin(2 * np.pi * 0.21 * t) + 0.3 * np.sin(2 * np.pi * 0.53 * t + 1.0)
    y = 3.0 * np.gradient(x, t)
    r = np.sin(2 * np.pi * x / 0.25) + 0.05 * rng.normal(size=t.size)
    n = mi.judge(r, y + r, {"position": x, mi.PREDICTION: y})
    # 64 bins over about 10 pitches: a staircase of 6 steps a period explains about 90 %
    # of a sine's variance
    assert n["time_invariant_share"] > 0.8
    assert mi.cause(n, 0.01) is None


# ------------------------------------------------------------------ the check in the loop
def test_switching_current_not_recorded_is_a_missing_input(case):
    diag = diagnose(_without(case.recording, "coil_current"), "mr_damper")
    found = diag.findings["missing_input"]
    assert found.remains and not found.confident and not diag.confident
    assert "an input the recording does not carry" in diag.verdict
    assert "no significant missing physics" not in diag.verdict.lower()
    assert "switching with no recorded cause" in diag.headline
    n = found.numbers["judged"][f"{case.recording.name} force"]
    assert n["share_of_output"] > 0.2 and n["size"] > mi.SIZE_LIMIT


def test_switching_current_recorded_is_diagnosed_whole(case):
    diag = diagnose(case.recording, "mr_damper")
    assert isinstance(diag.final_fit.model, MRFieldDamperModel)
    assert not diag.findings["missing_input"].remains
    assert not diag.unexplained and diag.named == []
    assert not any("not read" in a for a in diag.assumptions)
    # the force is explained to its noise: residual RMS within 20 % of the noise drawn
    rec = case.recording
    pred = diag.final_fit.model.simulate(diag.final_fit.theta, rec)["force"]
    rms = float(np.sqrt(np.mean((rec.outputs["force"] - pred) ** 2)))
    assert rms < 1.2 * case.truth.noise_rms
    got = {k: v["value"] for k, v in diag.final_params.items()}
    for name in ("c", "c_field", "f_y", "f_field", "x_y"):
        assert got[name] == pytest.approx(TRUTH[name], rel=0.05), name


def test_unread_recorded_input_is_named_in_the_finding(case):
    # a damper model does not read a coil current: the recording carries the cause, and
    # the finding says the model does not read it
    rec = case.recording
    diag = diagnose(rec, "damper")
    found = diag.findings["missing_input"]
    assert found.remains
    assert found.numbers["cause"] == "unread"
    assert "levels of the recorded coil_current explain the switching" in found.sentence
    # and the first screen says the channel is not read
    assert any("coil_current [A] is not read by the damper" in a for a in diag.assumptions)


@pytest.mark.parametrize("family", ["damper", "mr_damper"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_effect_free_controls_are_not_a_missing_input(family, seed):
    # seeds 0, 1, 2 are the white, coloured and drifting noise of the controls
    diag = diagnose(make_case(family, seed, 0).recording, family)
    assert not diag.findings["missing_input"].remains, diag.verdict


# ------------------------------------------------------------------ real recordings
@pytest.mark.realdata
def test_real_mr_damper_is_not_a_missing_input(shared_data):
    # the shaking-table runs (Vargas 2021) record no coil channel; at a constant field the
    # Bouc-Wen model leaves a residual that is a function of the motion (coherence above
    # the limit or a static relation), which is not an unrecorded input
    from suspenv.diagnosis.component.motion_inputs import conditioned
    from suspenv.measurements.catalog import REAL_CASES
    from suspenv.measurements.sources import load_mr_damper

    fit, hold, family, _ = REAL_CASES["mr_damper"](shared_data / "real")
    diag = diagnose(fit, family, holdout=hold)
    assert "hysteresis" in diag.named_families
    assert not diag.findings["missing_input"].remains
    version = str(diag.baseline.get("motion_version", "channel"))
    folder = shared_data / "real" / "mr_damper_shaking_table"
    for name in ("ensaio.vali.1.mat", "ensaio4.2.mat", "ensaio.B.10.mat"):
        (rec,), _ = conditioned(
            [load_mr_damper(folder / name)], ("displacement", "velocity"), version
        )
        for n in mi.judge_recording(diag.final_fit, rec).values():
            assert mi.cause(n, diag.rule.alpha) is None, name


def test_field_law_where_the_field_varies_within_or_between_recordings(case):
    from suspenv.diagnosis.component.rig import baseline_model, check_extra_inputs, describe_rig

    rec = _short(case)

    def at(level: float) -> Recording:
        u = np.full(rec.time.size, level)
        return Recording(
            f"at {level}", rec.test, rec.time, {**rec.inputs, "coil_current": u}, {}, rec.units
        )

    one = [at(0.5)]
    rig = describe_rig("mr_damper", one)
    assert rig.extra_inputs == {"coil_current": "recorded"}  # recorded under its name
    assert "field" not in baseline_model(rig, one).options
    assert check_extra_inputs(one, rig) == ["coil_current constant (0.5 A)"]
    two = [at(0.2), at(1.0)]
    assert baseline_model(describe_rig("mr_damper", two), two).options["field"] == "coil_current"


def test_element_gain_switching_tells_a_switched_fit_from_a_steady_one() -> None:
    """An element's improvement ``d`` whose gain on the residual follows a two-level
    switching (blocks of 400 samples at gain 1 or 0: what a switched damping leaves for an
    element fitted to its average) persists from block to block; the same ``d`` at a
    steady gain 1 in white noise does not (the exact null of independent gains)."""
    from suspenv.diagnosis.checks.switched_element import gain_lag1

    rng = np.random.default_rng(7)
    n, length = 8000, 50
    d = np.sin(2 * np.pi * np.arange(n) / 37.0)
    level = np.repeat(rng.integers(0, 2, n // 400), 400).astype(float)
    noise = 0.3 * rng.standard_normal(n)
    p_switched, rho_switched = gain_lag1(level * d + noise, d, length)
    p_steady, _ = gain_lag1(d + noise, d, length)
    assert p_switched < 1e-6 and rho_switched > 0.5
    assert p_steady > 0.01


def test_shape_beyond_a_switched_gain_tells_a_real_element_from_a_spurious_one() -> None:
    """A residual ``r = level(t) c s + e + noise``: a gain on ``s`` switched block-wise
    (the unrecorded input) plus, or not, a real element's shape ``e`` (a step in the
    sign of ``s``, as friction). Taking a level, a ramp and a gain on ``s`` out of each
    block removes the switched part exactly (it is such a gain within each block of 400,
    a multiple of the 50-sample blocks), so the coefficient of ``r`` on what is left of
    ``d = e`` is 1 where the element is there and 0 where it is not (within 4 standard
    errors, themselves small against the 1/2 between the two). With the gain alone taken
    out (``trend=False``, as beside a profiled input) the switched part still goes
    exactly, and the coefficient is the size of the shape in ``r`` over the element's: 1
    at its fitted size, 5 for an element fitted at a fifth of it."""
    from suspenv.diagnosis.checks.switched_element import beyond_switching

    rng = np.random.default_rng(8)
    n, length = 8000, 50
    t = np.arange(n) * 0.002
    s = np.sin(2 * np.pi * 1.1 * t) + 0.4 * np.sin(2 * np.pi * 2.9 * t)
    level = np.repeat(rng.integers(0, 2, n // 400), 400).astype(float)
    e = 0.3 * np.tanh(s / 0.02)
    noise = 0.05 * rng.standard_normal(n)
    beta, se = beyond_switching(level * s + e + noise, e, s, length)
    assert abs(beta - 1.0) < 4 * se and se < 0.05
    beta, se = beyond_switching(level * s + noise, e, s, length)
    assert abs(beta) < 4 * se and se < 0.05
    beta, se = beyond_switching(level * s + e + noise, e, s, length, trend=False)
    assert abs(beta - 1.0) < 4 * se and se < 0.05
    beta, se = beyond_switching(level * s + e + noise, 0.2 * e, s, length, trend=False)
    assert abs(beta - 5.0) < 4 * se and abs(beta - 1.0) > 20 * se
