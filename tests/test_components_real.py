"""Component models on the real recordings (skip when ../shared/data is absent)."""

from __future__ import annotations

import numpy as np
import pytest

from suspenv.diagnosis.fitting import fit
from suspenv.measurements import load_emps, load_mr_damper
from suspenv.models.components import make_component
from suspenv.models.effects import make_effect

pytestmark = pytest.mark.realdata


def test_emps_friction_guide_fit_matches_published_values(shared_data):
    rec = load_emps(shared_data / "real/emps/DATA_EMPS.mat").decimate(5)
    est, val = rec.split(0.6)
    model = make_component(
        "friction_guide",
        [make_effect("coulomb_friction", f_c=10.0, v_eps=1e-3), make_effect("force_offset")],
    )
    res = fit(model, est)
    v = dict(zip(res.names, res.theta, strict=True))
    # published physics (data README; Janot et al.): c ~ 204 N s/m, F_c ~ 20 N, offset ~ -3.2 N
    assert v["c"] == pytest.approx(204.0, rel=0.15)
    assert v["coulomb_friction.f_c"] == pytest.approx(20.0, rel=0.15)
    assert v["force_offset.offset"] == pytest.approx(-3.2, abs=1.0)
    # held-out error: the friction model beats the mass + viscous base on the validation part
    base = make_component("friction_guide")
    base_fit = fit(base, est)
    err_base = np.sqrt(
        np.mean((base.simulate(base_fit.theta, val)["force"] - val.outputs["force"]) ** 2)
    )
    err_fric = np.sqrt(
        np.mean((model.simulate(res.theta, val)["force"] - val.outputs["force"]) ** 2)
    )
    assert err_fric < 0.6 * err_base


def test_mr_damper_hysteresis_improves_fit(shared_data):
    rec = load_mr_damper(shared_data / "real/mr_damper_shaking_table/ensaio.A.1.mat").segment(0, 8)
    base = make_component("mr_damper")
    hyst = make_component("mr_damper", [make_effect("bouc_wen_hysteresis")])
    e_base = fit(base, rec).rms()["force"]
    e_hyst = fit(hyst, rec).rms()["force"]
    # data README: one friction-like hysteretic term roughly halves the error
    assert e_hyst < 0.7 * e_base


def test_damper_dyno_digressive_curve_improves_held_out_error(shared_data):
    from suspenv.measurements import load_damper_dyno

    rec = load_damper_dyno(shared_data / "real/damper_dyno_fsae/TR22-FC0739-1-4-1-4.dat")
    est, val = rec.decimate(4).split_blocks(5, validation=(1, 3))

    def held_out(model):
        res = fit(model, est)
        pred = model.simulate(res.theta, val)["force"]
        return np.sqrt(np.mean((pred - val.outputs["force"]) ** 2)), res

    e_lin, _ = held_out(make_component("damper"))
    e_dig, res = held_out(make_component("damper", [make_effect("digressive_damping")]))
    # data README: the force-velocity curve is digressive; the knee sits at low speed
    assert e_dig < 0.7 * e_lin
    assert res.params()["digressive_damping.v_knee"]["value"] < 0.1


def test_converted_recordings_survive_the_file_format(shared_data, tmp_path):
    from suspenv.measurements import load_recording, save_recording

    rec = load_emps(shared_data / "real/emps/DATA_EMPS_PULSES.mat")
    back = load_recording(save_recording(rec, tmp_path / "emps"), expect_units={"force": "N"})
    assert np.array_equal(back.outputs["force"], rec.outputs["force"])
    assert back.meta["gtau_N_per_V"] == rec.meta["gtau_N_per_V"]
