"""The independent concealed-effect generator (benchmarks.independent): files and
metadata per its contract, loading, determinism, the integrator against closed forms,
the energy sign of dampers and the declared units. Development seeds only (90000+)."""

from __future__ import annotations

import ast
import json
import math
from pathlib import Path

import numpy as np
import pytest

from benchmarks.independent import generate
from benchmarks.independent.cases import (
    FAMILIES,
    PLAUSIBLE,
    CaseSpec,
    make_case,
    plan,
)
from benchmarks.independent.devices import QuarterCar, simulate_quarter_car
from benchmarks.independent.effects import IN_LIBRARY, OUTSIDE, ForceLaw
from benchmarks.independent.export import to_recording, write_case
from benchmarks.independent.integrate import delayed, first_order_lag, integrate
from benchmarks.independent.signals import SumOfSines
from suspenv.measurements import load_recording

PACKAGE = Path(__file__).resolve().parents[1] / "suspenv" / "bench" / "independent"
CHANNELS = {
    "damper": ({"displacement", "velocity"}, {"force"}),
    "mr_damper": ({"displacement", "velocity", "coil_voltage"}, {"force"}),
    "friction_guide": ({"position", "velocity", "acceleration"}, {"force"}),
    "quarter_car_rig": ({"road"}, {"body_acceleration", "suspension_deflection"}),
}
SEED = 90003  # the only backlash case of this seed is in the quarter car


def test_no_engine_code_is_imported() -> None:
    for path in PACKAGE.glob("*.py"):
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module:
                names = [node.module]
            for name in names:
                assert not name.startswith(
                    ("suspenv.diagnosis", "suspenv.models", "suspenv.rigs")
                ), f"{path.name} imports {name}"


def test_plan_labels() -> None:
    for fam in FAMILIES:
        for seed in range(90000, 90012):
            specs = plan(fam, seed)
            assert [s.kind for s in specs] == ["control", "single", "single", "outside"]
            assert specs[0].label is None
            assert specs[1].label != specs[2].label
            assert {specs[1].label, specs[2].label} <= set(PLAUSIBLE[fam]) <= set(IN_LIBRARY)
            assert specs[3].label in OUTSIDE
            assert len({s.case_id for s in specs}) == 4
    mr = [s.label for seed in range(90000, 90010) for s in plan("mr_damper", seed)[1:3]]
    assert mr.count("hysteresis") == len(mr) // 2


@pytest.fixture(scope="module")
def generated(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("indep") / "bench"
    code = generate.main(
        ["--out", str(out), "--seeds", str(SEED), "--families", "damper,mr_damper,friction_guide"]
    )
    assert code == 0
    spec = plan("quarter_car_rig", 90023)[0]  # a quick quarter-car control
    write_case(make_case(spec), out)
    return out


def test_files_and_metadata_follow_the_contract(generated: Path) -> None:
    manifest = json.loads((generated / "manifest.json").read_text())
    assert manifest["generator"] == "benchmarks.independent"
    assert manifest["version"] and manifest["seeds"] == [SEED]
    assert manifest["families"] == ["damper", "mr_damper", "friction_guide"]
    assert len(manifest["cases"]) == 12
    ids = [*manifest["cases"], "quarter_car_rig-control-90023"]
    for cid in ids:
        fam = cid.split("-")[0]
        truth = json.loads((generated / "truth" / f"{cid}.json").read_text())
        assert truth["case_id"] == cid and truth["family"] == fam
        assert truth["kind"] in ("control", "single", "outside")
        assert set(truth) >= {
            "seed",
            "base",
            "effects",
            "noise",
            "units_declared",
            "positive_stroke",
            "positive_force",
        }
        assert truth["noise"]["kind"] in ("white", "coloured", "drift")
        assert set(truth["noise"]) >= {"rms", "details"}
        if truth["kind"] == "control":
            assert truth["effects"] == []
        else:
            (eff,) = truth["effects"]
            assert eff["in_library"] == (truth["kind"] == "single")
            assert eff["in_library"] == (eff["label"] in IN_LIBRARY)
            assert set(eff) == {"label", "in_library", "params", "model"}
            assert 0.03 < eff["params"]["achieved_ratio"] < 0.3
        rec = load_recording(generated / "cases" / f"{cid}.npz")
        ins, outs = CHANNELS[fam]
        assert ins <= set(rec.inputs) <= ins | {"actuator_force"}
        assert set(rec.outputs) == outs
        assert rec.n_samples <= 40_000
        rig = rec.meta["rig"]
        assert rec.meta["source"] == ("independent synthetic generator (benchmarks.independent)")
        assert rec.meta["sampling"]["dt_s"] == pytest.approx(rec.sample_interval)
        assert rig["device"] == fam
        assert rig["positive_stroke"] in ("compression", "extension")
        assert rig["positive_force"] in ("compression", "tension")
        assert rig["positive_stroke"] == truth["positive_stroke"]
        if fam == "quarter_car_rig":
            assert set(rig["known"]) == {"m_s", "m_u"}
            assert rig["known"]["m_s"] == truth["base"]["m_s"]
            assert ("extra_inputs" in rig) == ("actuator_force" in rec.inputs)
        else:
            assert rig["known"] == {} and "extra_inputs" not in rig
        if fam == "mr_damper":
            v = rec.inputs["coil_voltage"]
            assert np.all(v == v[0]) and 0 < v[0] < 10


def test_controls_cycle_the_noise_kind() -> None:
    kinds = set()
    for seed in (90000, 90001, 90002):
        spec = CaseSpec("damper", seed, "control", 0, None)
        kinds.add(make_case(spec).truth["noise"]["kind"])
    assert kinds == {"white", "coloured", "drift"}


def test_deterministic(tmp_path: Path) -> None:
    spec = plan("damper", 90001)[1]
    arrays = []
    for run in ("a", "b"):
        write_case(make_case(spec), tmp_path / run)
        with np.load(tmp_path / run / "cases" / f"{spec.case_id}.npz") as npz:
            arrays.append({k: npz[k].tobytes() for k in npz.files})
    assert arrays[0] == arrays[1]
    other = make_case(CaseSpec("damper", 90002, "single", 1, spec.label))
    assert other.time.size != make_case(spec).time.size or not np.array_equal(
        other.outputs["force"], make_case(spec).outputs["force"]
    )


def test_units_declared_give_si_after_load(tmp_path: Path) -> None:
    case = make_case(plan("damper", 90000)[0])
    si = to_recording(case)
    case.units = {"displacement": "in", "velocity": "in/s", "force": "lbf"}
    npz, _ = write_case(case, tmp_path)
    with np.load(npz) as raw:
        assert np.allclose(raw["in.displacement"] * 0.0254, si.inputs["displacement"])
        assert np.allclose(raw["out.force"] * 4.4482216152605, si.outputs["force"])
        header = json.loads(str(raw["__meta__"]))
        assert header["units"]["force"] == "lbf"
    rec = load_recording(npz)
    assert rec.units["force"] == "N" and rec.units["displacement"] == "m"
    assert rec.meta["converted_from"] == case.units
    for name in ("displacement", "velocity"):
        np.testing.assert_allclose(rec.inputs[name], si.inputs[name], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(rec.outputs["force"], si.outputs["force"], rtol=1e-12)


def test_damper_absorbs_power_in_the_declared_convention() -> None:
    signs = set()
    for seed in range(90000, 90006):
        for fam in ("damper", "mr_damper"):
            case = make_case(plan(fam, seed)[0])
            rig = case.meta["rig"]
            s = (1 if rig["positive_stroke"] == "compression" else -1) * (
                1 if rig["positive_force"] == "compression" else -1
            )
            signs.add((rig["positive_stroke"], rig["positive_force"]))
            power = s * np.mean(case.outputs["force"] * case.inputs["velocity"])
            assert power > 0, case.spec.case_id
    assert len(signs) >= 3


def test_quarter_car_matches_the_transfer_function() -> None:
    qc = QuarterCar(m_s=300.0, m_u=40.0, k_s=25e3, c_s=1.8e3, k_t=200e3)
    f, amp = 2.3, 0.01
    w = 2 * math.pi * f
    road = SumOfSines(np.array([amp]), np.array([w]), np.array([0.0]), duration=30.0, ramp=1.0)
    t = np.arange(0.0, 12.0, 1e-3)
    sim = simulate_quarter_car(qc, ForceLaw(0.0, qc.k_s, qc.c_s), road, t)
    M = np.diag([qc.m_s, qc.m_u])
    C = np.array([[qc.c_s, -qc.c_s], [-qc.c_s, qc.c_s]])
    K = np.array([[qc.k_s, -qc.k_s], [-qc.k_s, qc.k_s + qc.k_t]])
    z = np.linalg.solve(-(w**2) * M + 1j * w * C + K, np.array([0.0, qc.k_t * amp]))
    expected = {
        "suspension_deflection": z[1] - z[0],
        "body_acceleration": -(w**2) * z[0],
    }
    window = (t >= 7.0) & (t < 7.0 + 10 / f)
    basis = np.column_stack([np.sin(w * t[window]), np.cos(w * t[window])])
    for name, zc in expected.items():
        (a, b), *_ = np.linalg.lstsq(basis, sim.channels[name][window], rcond=None)
        # a sin + b cos = Im(zc e^{iwt}) with the road amp sin(wt) = Im(amp e^{iwt})
        got = complex(a, b)
        assert abs(got - zc) / abs(zc) < 1e-3, (name, got, zc)


def test_maxwell_element_against_closed_forms() -> None:
    km, tau, x0, v0 = 4e4, 0.02, 0.003, 0.1
    law = ForceLaw(0.0, 0.0, 0.0, "viscoelastic", "maxwell", {"km": km, "tau": tau})
    t = np.linspace(0.0, 0.1, 201)
    # relaxation after a displacement step: F = km x0 exp(-t / tau)
    relax = integrate(lambda tt, s: law.state_rate(0.0, 0.0, s), np.array([km * x0]), t)
    np.testing.assert_allclose(relax[:, 0], km * x0 * np.exp(-t / tau), rtol=1e-6)
    # constant stroke rate from rest: F = km v0 tau (1 - exp(-t / tau))
    ramp = integrate(lambda tt, s: law.state_rate(v0 * tt, v0, s), np.array([0.0]), t)
    expected = km * v0 * tau * (1 - np.exp(-t / tau))
    np.testing.assert_allclose(ramp[:, 0], expected, rtol=1e-6, atol=1e-9)


def test_bouc_wen_saturates_at_its_yield_displacement() -> None:
    A, beta, gamma, n = 1.0, 600.0, 400.0, 1.5
    p = {"A": A, "beta": beta, "gamma": gamma, "n": n, "alpha": 1.0}
    law = ForceLaw(0.0, 0.0, 0.0, "hysteresis", "bouc_wen", p)
    t = np.linspace(0.0, 4.0, 101)  # 0.2 m of travel, 30 times the approach length
    z = integrate(lambda tt, s: law.state_rate(0.0, 0.05, s), np.array([0.0]), t)
    assert z[-1, 0] == pytest.approx((A / (beta + gamma)) ** (1 / n), rel=1e-6)


def test_sensor_filters_against_closed_forms() -> None:
    dt, tau = 1e-3, 0.013
    t = np.arange(0.0, 0.2, dt)
    ramp = first_order_lag(t.copy(), dt, tau)  # u = t from rest: exact for FOH
    np.testing.assert_allclose(ramp, t - tau * (1 - np.exp(-t / tau)), atol=1e-13)
    sig = np.sin(2 * math.pi * 5 * t)
    d = delayed(sig, t, 0.0123)
    inside = t > 0.02
    np.testing.assert_allclose(d[inside], np.sin(2 * math.pi * 5 * (t[inside] - 0.0123)), atol=1e-6)


def test_refuses_a_non_empty_directory(tmp_path: Path) -> None:
    (tmp_path / "keep.txt").write_text("x")
    args = ["--out", str(tmp_path), "--seeds", "90000", "--families", "damper"]
    assert generate.main(args) == 2
    assert generate.parse_seeds("90000-90002,90007") == [90000, 90001, 90002, 90007]


def test_scalar_force_law_equals_the_vector_one() -> None:
    rng = np.random.default_rng(90000)
    laws = [
        ("friction", "tanh", {"Fc": 30.0, "vs": 0.004}),
        ("friction", "bingham", {"Fc": 30.0, "vs": 0.004}),
        ("friction", "stribeck", {"Fc": 30.0, "vs": 0.004, "fs_ratio": 1.5, "vst": 0.02}),
        (
            "friction",
            "lugre",
            {"Fc": 30.0, "fs_ratio": 1.5, "vst": 0.02, "x_pre": 1e-4, "tau_b": 5e-4},
        ),
        ("hysteresis", "bouc_wen", {"alpha": 2e4, "A": 1, "beta": 500, "gamma": 100, "n": 2}),
        ("digressive", "tanh", {"dc": 800.0, "vk": 0.1}),
        ("digressive", "two_slope", {"dc": 800.0, "vk": 0.1}),
        ("damper_asymmetry", "one_side", {"dc": 500.0, "side": -1.0}),
        ("viscoelastic", "maxwell", {"km": 1e4, "tau": 0.01}),
        ("progressive", "cubic", {"k3": 1e7}),
        ("end_stop", "linear", {"ks": 1e5, "gap": 0.01, "bump": 1.0, "rebound": 1.0}),
        ("cubic_damper", "cubic", {"c3": 3e3}),
        ("velocity_dead_zone", "dead_band", {"vdz": 0.02}),
    ]
    for label, variant, p in laws:
        law = ForceLaw(100.0, 2e3, 1.5e3, label, variant, p)
        x, v, s = rng.normal(0, 0.02, 50), rng.normal(0, 0.2, 50), rng.normal(0, 20.0, 50)
        vec = law.total(x, v, s)
        one = [law.total1(float(a), float(b), float(c)) for a, b, c in zip(x, v, s, strict=True)]
        np.testing.assert_allclose(one, vec, rtol=1e-12, err_msg=label + variant)
