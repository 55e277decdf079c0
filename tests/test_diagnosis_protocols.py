"""The typed model seam (`suspenv.diagnosis.protocols`) and the one fitter vs closed forms."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import pytest

from suspenv.diagnosis.fitting import fit
from suspenv.diagnosis.protocols import DiagnosableModel, RecordingLike
from suspenv.diagnosis.ride.model import MinibusRideAdapter
from suspenv.measurements import Recording
from suspenv.models.components import make_component
from suspenv.models.effects import make_effect
from suspenv.rigs.knc_axle import KncAxleModel, make_candidate

#: every member the diagnosis reads (the protocol's own list, checked against it below)
MEMBERS = (
    "family",
    "location",
    "parameter_names",
    "output_channels",
    "effects",
    "effect_defaults",
    "candidate_effects",
    "unpack",
    "bounds",
    "initial_guess",
    "simulate",
    "with_effects",
    "difference_step",
    "refine_start",
    "jacobian_model",
    "force_view",
)


def _models() -> dict[str, DiagnosableModel]:
    friction = make_effect("coulomb_friction", f_c=20.0, v_eps=1e-3)
    return {
        "damper": make_component("damper"),
        "mr_damper": make_component("mr_damper", [make_effect("bouc_wen_hysteresis")]),
        "friction_guide": make_component("friction_guide", [friction]),
        "quarter_car": make_component("quarter_car_rig"),
        "knc_axle": KncAxleModel([make_candidate("coulomb_friction")]),
        "minibus_ride": MinibusRideAdapter(),
    }


def test_protocol_lists_the_members_the_diagnosis_reads() -> None:
    declared = {
        n for n in vars(DiagnosableModel) if not n.startswith("_") and n not in ("register",)
    }
    assert declared == set(MEMBERS)


@pytest.mark.parametrize("name", list(_models()))
def test_every_model_satisfies_the_diagnosable_model_protocol(name: str) -> None:
    model = _models()[name]
    assert isinstance(model, DiagnosableModel)
    for member in MEMBERS:  # explicit, besides the structural isinstance
        assert hasattr(model, member), member
    p = len(model.parameter_names)
    lo, hi = model.bounds()
    assert lo.shape == hi.shape == (p,)
    assert isinstance(model.family, str) and model.family
    assert isinstance(model.location, str)
    assert isinstance(model.effect_defaults, Mapping)
    theta = 0.5 * (lo + hi)
    step = model.difference_step(theta, lo, hi)
    assert step.shape == (p,) and np.all(step > 0)
    twin = model.jacobian_model()
    assert isinstance(twin, DiagnosableModel)
    assert twin.parameter_names == model.parameter_names
    again = model.with_effects(model.effects)
    assert isinstance(again, DiagnosableModel)
    assert again.parameter_names == model.parameter_names


def test_models_without_the_hooks_answer_the_defaults() -> None:
    damper = make_component("damper")
    rec = damper.example_recording()
    theta = damper.initial_guess(rec)
    assert damper.refine_start(theta, [rec], None) is None
    assert damper.jacobian_model() is damper
    assert damper.force_view(theta, rec) is None
    assert damper.effect_defaults == {}
    # the quarter car has its own: a coarser twin and the friction width it needs
    qc = make_component("quarter_car_rig")
    assert qc.jacobian_model() is not qc
    assert qc.effect_defaults["coulomb_friction"]["v_eps"] == 0.01
    # no recorded channels to refine from: no refinement
    assert (
        qc.refine_start(qc.initial_guess(qc.example_recording()), [qc.example_recording()], None)
        is None
    )
    knc = KncAxleModel()
    assert knc.refine_start(knc.initial_guess(), [], None) is None
    assert knc.jacobian_model() is knc


def test_difference_steps_are_the_models_own() -> None:
    # component models: 1e-6 max(|theta|, 1); K&C axle: max(3e-3 |theta|, 1e-3 (hi - lo))
    damper = make_component("damper", [make_effect("digressive_damping")])
    lo, hi = damper.bounds()
    theta = damper.initial_guess(damper.example_recording())
    np.testing.assert_array_equal(
        damper.difference_step(theta, lo, hi), 1e-6 * np.maximum(np.abs(theta), 1.0)
    )
    knc = KncAxleModel()
    lo, hi = knc.bounds()
    theta = knc.initial_guess()
    np.testing.assert_array_equal(
        knc.difference_step(theta, lo, hi),
        np.maximum(3e-3 * np.abs(theta), 1e-3 * (hi - lo)),
    )


def test_recordings_satisfy_the_recording_protocol() -> None:
    rec = make_component("damper").example_recording()
    assert isinstance(rec, Recording) and isinstance(rec, RecordingLike)
    assert not isinstance(object(), RecordingLike)


def test_an_object_without_the_hooks_is_not_a_diagnosable_model() -> None:
    class Partial:
        family = "partial"
        parameter_names = ("k",)

    assert not isinstance(Partial(), DiagnosableModel)


# ------------------------------------------------------------------ fit: closed forms
class TwoChannelLinear:
    """``force = k x + c v`` and ``damping = c v`` (a second cell on the damper alone):
    linear in ``theta``, so weighted least squares has a closed form.

    ``gain`` scales the predictions (1: the true model); ``twin``: the Jacobian twin is
    the same model with gain 1.2 (wrong sensitivities); ``start``: ``refine_start``'s
    answer."""

    family = "two_channel_linear"
    location = "damper"
    parameter_names: tuple[str, ...] = ("k", "c")
    output_channels = ("force", "damping")
    effects: tuple = ()
    effect_defaults: Mapping[str, Mapping[str, float]] = {}

    def __init__(self, gain: float = 1.0, twin: bool = False, start: np.ndarray | None = None):
        self.gain, self.twin, self.start = gain, twin, start

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return np.array([-1e7, -1e7]), np.array([1e7, 1e7])

    def initial_guess(self, rec: RecordingLike) -> np.ndarray:
        return np.array([1.0, 1.0])

    def simulate(self, theta: np.ndarray, rec: RecordingLike) -> dict[str, np.ndarray]:
        k, c = theta[..., 0, None], theta[..., 1, None]
        x, v = rec.inputs["x"], rec.inputs["v"]
        return {"force": self.gain * (k * x + c * v), "damping": self.gain * c * v}

    def with_effects(self, effects: Sequence[object]) -> TwoChannelLinear:
        return TwoChannelLinear(self.gain, self.twin, self.start)

    def difference_step(self, theta: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        return 1e-6 * np.maximum(np.abs(theta), 1.0)

    def refine_start(
        self,
        theta0: np.ndarray,
        recordings: Sequence[RecordingLike],
        masks: Sequence[np.ndarray | None] | None,
    ) -> np.ndarray | None:
        return self.start

    def jacobian_model(self) -> TwoChannelLinear:
        return TwoChannelLinear(gain=1.2) if self.twin else self

    def force_view(self, theta: np.ndarray, rec: RecordingLike) -> dict[str, np.ndarray] | None:
        return None


#: scipy.optimize.least_squares' default step tolerance (the fit's ``tol=None``)
XTOL = 1e-8


def _two_channel_recording(seed: int = 0) -> Recording:
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 3.0, 0.004)
    x = 0.02 * np.sin(2 * np.pi * 1.1 * t) + 0.006 * np.sin(2 * np.pi * 3.7 * t)
    v = np.gradient(x, t)
    force = 15000.0 * x + 900.0 * v + rng.normal(0.0, 8.0, t.size)
    damping = 900.0 * v + rng.normal(0.0, 3.0, t.size)
    units = {"x": "m", "v": "m/s", "force": "N", "damping": "N"}
    return Recording(
        "two_channel", "sine", t, {"x": x, "v": v}, {"force": force, "damping": damping}, units
    )


def _columns(rec: Recording, scales: Mapping[str, float], mask: np.ndarray | None = None):
    """The scaled, stacked regression: ``A = [[x, v] / s_force; [0, v] / s_damping]``,
    ``b = [force / s_force; damping / s_damping]`` (rows of ``mask`` only)."""
    m = np.ones(rec.n_samples, bool) if mask is None else mask
    x, v = rec.inputs["x"][m], rec.inputs["v"][m]
    sf, sd = scales["force"], scales["damping"]
    A = np.vstack([np.c_[x, v] / sf, np.c_[np.zeros_like(v), v] / sd])
    b = np.concatenate([rec.outputs["force"][m] / sf, rec.outputs["damping"][m] / sd])
    return A, b


def _weighted_lstsq(
    rec: Recording, scales: Mapping[str, float], mask: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Independent reference: ``numpy.linalg.lstsq`` on :func:`_columns`; returns theta
    and the OLS standard errors ``sqrt(diag(s^2 (A^T A)^-1))``, ``s^2 = SSR / (n - p)``."""
    A, b = _columns(rec, scales, mask)
    beta, *_ = np.linalg.lstsq(A, b, rcond=None)
    r = b - A @ beta
    s2 = r @ r / (A.shape[0] - A.shape[1])
    return beta, np.sqrt(np.diag(s2 * np.linalg.inv(A.T @ A)))


def test_fit_of_a_linear_model_equals_weighted_lstsq() -> None:
    # reference: numpy.linalg.lstsq on the same columns, each channel divided by its
    # scale (the measured spread by default, given scales otherwise), and the OLS
    # standard errors of those columns
    rec = _two_channel_recording()
    res = fit(TwoChannelLinear(), rec)
    assert res.channels == ["force", "damping"]
    spread = {c: float(np.std(rec.outputs[c])) for c in res.channels}
    assert res.scales == spread
    beta, se = _weighted_lstsq(rec, spread)
    # tolerance: the fit is scipy's least_squares at its default xtol = 1e-8 (its last
    # step below 1e-8 of |theta|; a linear model's Gauss-Newton step lands on the closed
    # form up to that), so theta equals lstsq to XTOL relative, not to round-off
    np.testing.assert_allclose(res.theta, beta, rtol=XTOL)
    np.testing.assert_allclose(res.stderr, se, rtol=1e-5)
    # given scales weigh the channels differently; the fit follows the closed form
    scales = {"force": 50.0, "damping": 1.0}
    res = fit(TwoChannelLinear(), rec, scales=scales)
    beta_w, se_w = _weighted_lstsq(rec, scales)
    assert abs(beta_w[1] - beta[1]) > 1e-4 * abs(beta[1])  # the weights matter here
    np.testing.assert_allclose(res.theta, beta_w, rtol=XTOL)
    np.testing.assert_allclose(res.stderr, se_w, rtol=1e-5)
    # a mask: only those samples
    mask = np.arange(rec.n_samples) % 4 != 1
    res = fit(TwoChannelLinear(), [rec], masks=[mask], scales=scales)
    beta_m, _ = _weighted_lstsq(rec, scales, mask)
    np.testing.assert_allclose(res.theta, beta_m, rtol=XTOL)
    assert res.n == {"force": int(mask.sum()), "damping": int(mask.sum())}


def test_the_twin_steers_but_the_reported_jacobian_is_the_models_own() -> None:
    # reference: for a linear model the scaled-residual Jacobian is -A (closed form);
    # the twin predicts 1.2x, so its own Jacobian would be -1.2 A
    rec = _two_channel_recording(1)
    scales = {"force": 40.0, "damping": 4.0}
    res = fit(TwoChannelLinear(twin=True), rec, scales=scales)
    A, _ = _columns(rec, scales)
    np.testing.assert_allclose(res.extra["jacobian"], -A, rtol=1e-5, atol=1e-9 * np.abs(A).max())
    beta, _ = _weighted_lstsq(rec, scales)
    np.testing.assert_allclose(res.theta, beta, rtol=1e-6)


def test_a_refined_start_is_kept_only_where_it_is_better() -> None:
    rec = _two_channel_recording(2)
    scales = {"force": 40.0, "damping": 4.0}
    beta, _ = _weighted_lstsq(rec, scales)
    res = fit(TwoChannelLinear(start=beta), rec, scales=scales, max_nfev=1)
    np.testing.assert_allclose(res.theta, beta, rtol=1e-9)  # one evaluation: the start
    far = np.array([-5e6, -5e6])
    res = fit(TwoChannelLinear(start=far), rec, scales=scales, max_nfev=1)
    assert np.all(np.abs(res.theta - far) > 1e5)  # the worse start was dropped


def test_a_model_without_free_parameters_is_evaluated() -> None:
    rec = _two_channel_recording(3)

    class Fixed(TwoChannelLinear):
        parameter_names: tuple[str, ...] = ()

        def bounds(self) -> tuple[np.ndarray, np.ndarray]:
            return np.zeros(0), np.zeros(0)

        def initial_guess(self, rec: RecordingLike) -> np.ndarray:
            return np.zeros(0)

        def simulate(self, theta: np.ndarray, rec: RecordingLike) -> dict[str, np.ndarray]:
            v = rec.inputs["v"]
            return {"force": 900.0 * v, "damping": 900.0 * v}

    res = fit(Fixed(), rec, scales={"force": 1.0, "damping": 1.0})
    assert res.theta.shape == (0,) and res.message == "no free parameters"
    want = float(np.sum((rec.outputs["damping"] - 900.0 * rec.inputs["v"]) ** 2))
    assert res.ssr["damping"] == pytest.approx(want, rel=1e-12)
