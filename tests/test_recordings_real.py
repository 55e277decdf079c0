"""Converters for the real recordings in ../shared/data (skip when absent)."""

from __future__ import annotations

import numpy as np
import pytest

from suspenv.measurements import (
    RecordingError,
    load_damper_dyno,
    load_emps,
    load_emps_csv,
    load_mr_damper,
)

pytestmark = pytest.mark.realdata


def test_emps_mat_and_csv_agree_and_give_published_physics(shared_data):
    rec = load_emps(shared_data / "real/emps/DATA_EMPS.mat")
    assert rec.units["force"] == "N" and rec.sample_interval == pytest.approx(1e-3, rel=1e-3)
    a, v, f = rec.inputs["acceleration"], rec.inputs["velocity"], rec.outputs["force"]
    # least squares on F = m a + c v + f_c sign(v) + offset; published: m ~ 95 kg,
    # c ~ 204 N s/m, f_c ~ 20 N, offset ~ -3.2 N (data README, Janot et al.)
    X = np.c_[a, v, np.sign(v), np.ones_like(v)]
    m, c, fc, off = np.linalg.lstsq(X, f, rcond=None)[0]
    assert m == pytest.approx(95.0, rel=0.05)
    assert c == pytest.approx(204.0, rel=0.05)
    assert fc == pytest.approx(20.0, rel=0.1)
    assert off == pytest.approx(-3.2, abs=0.5)
    csv = load_emps_csv(shared_data / "real/emps/DATA_EMPS_SC.csv")
    # the de-scaled CSV position must match the 1 kHz record at the same times
    q = np.interp(csv.time, rec.time, rec.inputs["position"])
    assert np.max(np.abs(csv.inputs["position"] - q)) < 1e-5


def test_emps_pulses_file(shared_data):
    rec = load_emps(shared_data / "real/emps/DATA_EMPS_PULSES.mat")
    assert rec.test == "emps_pulses" and rec.meta["pulse_samples"] > 0


def test_damper_dyno_converted_to_si(shared_data):
    rec = load_damper_dyno(shared_data / "real/damper_dyno_fsae/TR22-FC0739-1-4-1-4.dat")
    assert rec.meta["original_units"] == {"Stroke": "in", "Load": "lbf", "Time": "Sec"}
    x, v, f = rec.inputs["displacement"], rec.inputs["velocity"], rec.outputs["force"]
    assert rec.sample_interval == pytest.approx(1 / 1024, rel=0.01)
    # a damper absorbs power: with the stated orientation mean(F v) > 0
    assert np.mean(f * v) > 0
    # stroke of a racing damper test: centimetres, not inches-as-metres
    assert 0.001 < np.ptp(x) < 0.1


def test_mr_damper_converted_to_si(shared_data):
    rec = load_mr_damper(shared_data / "real/mr_damper_shaking_table/ensaio.A.1.mat")
    x, v = rec.inputs["displacement"], rec.inputs["velocity"]
    assert np.ptp(x) < 0.05  # amplitudes 2-25 mm (data README)
    # the file's velocity column is the derivative of its position column (mm -> m, mm/s -> m/s)
    vg = np.gradient(x, rec.time)
    assert np.corrcoef(vg, v)[0, 1] > 0.99
    assert np.median(np.abs(v)) == pytest.approx(np.median(np.abs(vg)), rel=0.1)
    assert rec.meta["excitation_hz"] == pytest.approx(1.5)


def test_converters_reject_wrong_files(shared_data, tmp_path):
    with pytest.raises(RecordingError, match="missing variable 't'; the file holds"):
        load_emps(shared_data / "real/mr_damper_shaking_table/ensaio.A.1.mat")
    bad = tmp_path / "bad.dat"
    bad.write_text(
        "Stroke\tLoad\tTime\r\nmm\tN\ts\r\n"
        + "1\t2\t3\r\n" * 5
        + "Stroke\tLoad\tTime\r\nin\tlbf\tSec\r\n"
    )
    with pytest.raises(RecordingError, match="unit mismatch at line"):
        load_damper_dyno(bad)


def test_read_recording_dispatches_by_content(shared_data):
    from suspenv.measurements import read_recording

    real = shared_data / "real"
    expected = {
        "emps/DATA_EMPS.mat": "friction_guide",
        "emps/DATA_EMPS_SC.csv": "friction_guide",
        "damper_dyno_fsae/TR22-FC0739-1-4-1-4.dat": "damper",
        "mr_damper_shaking_table/ensaio.vali.1.mat": "mr_damper",
    }
    for rel, family in expected.items():
        assert read_recording(real / rel).meta["suggested_model"] == family, rel
