"""What the readers and the diagnosis refuse, and that each refusal names the rule and the
value: too few samples or cycles, units converted or refused, implausible magnitudes,
archives that would expand past the read limit."""

from __future__ import annotations

import io
import json
import tracemalloc
import zipfile

import numpy as np
import pytest
import scipy.io

from benchmarks.component_truth import make_case
from suspenv.core.errors import ValidationError
from suspenv.diagnosis.component.motion import MIN_FIT_PASSES, centre_passes
from suspenv.diagnosis.engine import diagnose
from suspenv.diagnosis.sufficiency import PLAUSIBLE, check_values
from suspenv.measurements import (
    Recording,
    RecordingError,
    load_recording,
    read_recording,
    save_recording,
)
from suspenv.measurements.limits import DEFAULT_MAX_READ_BYTES, MAX_READ_ENV, read_limit
from suspenv.measurements.sources.road_profile import load_profile_txt, profile_recording

#: 1 lbf in N, exact by definition (NIST SP 811: 0.45359237 kg x 9.80665 m/s^2)
LBF = 4.4482216152605
DAMPER_UNITS = {"displacement": "m", "velocity": "m/s", "force": "N"}


def write_raw(path, header: dict, arrays: dict) -> None:
    with open(path, "wb") as fh:
        np.savez(fh, __meta__=np.array(json.dumps(header)), **arrays)


def header(units: dict[str, str], inputs=("displacement",), outputs=("force",)) -> dict:
    return {
        "format": "suspenv-recording",
        "version": 1,
        "name": "r",
        "test": "dyno_sine",
        "inputs": list(inputs),
        "outputs": list(outputs),
        "units": {"time": "s", **units},
        "meta": {},
    }


def damper_recording(n: int, periods: float, name: str = "x") -> Recording:
    """A damper on a dyno: sine stroke of ``periods`` periods over ``n`` samples, F = c v."""
    t = np.linspace(0.0, 2.0, n)
    w = 2 * np.pi * periods / 2.0
    x = 0.01 * np.sin(w * t)
    v = 0.01 * w * np.cos(w * t)
    return Recording(
        name,
        "dyno_sine",
        t,
        {"displacement": x, "velocity": v},
        {"force": 1500.0 * v},
        DAMPER_UNITS,
    )


# ------------------------------------------------------------------ too few samples
def test_two_sample_recording_is_refused_with_the_minimum():
    rec = damper_recording(2, 1.0)
    with pytest.raises(ValidationError) as info:
        diagnose(rec, "damper")
    msg = str(info.value)
    assert msg.startswith("recording 'x': 2 samples; a diagnosis of the damper model needs")
    assert "needs at least about" in msg
    # the reason: observations per parameter of the largest model, and the held-out part
    assert "10 observations" in msg and "per parameter" in msg and "held-out part 30" in msg
    assert "last 30 % of each recording" in msg


def test_too_few_cycles_are_refused():
    # plenty of samples (2000), but the stroke makes one period: up and down once
    rec = damper_recording(2000, 1.0)
    with pytest.raises(ValidationError, match=r"passes its centre 2 times in the fitted part") as e:
        diagnose(rec, "damper")
    assert f"needs at least {MIN_FIT_PASSES}" in str(e.value)
    # the pass counter: k periods of a sine pass their centre 2k - 1 times, noise ignored
    t = np.linspace(0, 1, 4001)
    rng = np.random.default_rng(0)
    for k in (1, 2, 5):
        x = np.sin(2 * np.pi * k * t) + 0.01 * rng.standard_normal(t.size)
        assert centre_passes(x) == 2 * k - 1


# ------------------------------------------------------------------ units
def test_lbf_is_converted_to_newtons_on_reading(tmp_path):
    t = np.linspace(0.0, 1.0, 50)
    f_lbf = np.linspace(-200.0, 350.0, 50)
    x_in = np.linspace(-1.0, 1.0, 50)
    write_raw(
        tmp_path / "lbf.npz",
        header({"displacement": "in", "force": "lbf"}),
        {"time": t, "in.displacement": x_in, "out.force": f_lbf},
    )
    rec = read_recording(tmp_path / "lbf.npz")
    assert rec.units["force"] == "N" and rec.units["displacement"] == "m"
    # hand conversion: 1 lbf = 4.4482216152605 N, 1 in = 0.0254 m
    assert rec.outputs["force"][0] == pytest.approx(-200.0 * 4.4482216152605, rel=1e-15)
    assert rec.outputs["force"][-1] == pytest.approx(350.0 * 4.4482216152605, rel=1e-15)
    assert rec.outputs["force"][-1] == pytest.approx(1556.8775653411750, rel=1e-14)
    assert np.array_equal(rec.outputs["force"], f_lbf * LBF)
    assert rec.inputs["displacement"][-1] == pytest.approx(0.0254, rel=1e-15)
    assert rec.meta["converted_from"] == {"displacement": "in", "force": "lbf"}


def test_non_si_recording_is_refused_not_taken_as_si():
    t = np.linspace(0.0, 1.0, 5)
    with pytest.raises(RecordingError, match=r"channel 'force' is in 'lbf', which is not SI"):
        Recording("r", "dyno_sine", t, {}, {"force": t}, {"force": "lbf"})
    with pytest.raises(RecordingError, match=r"'lbf' -> 'N'"):
        Recording("r", "dyno_sine", t, {}, {"force": t}, {"force": "lbf"})


def test_unknown_unit_is_refused_with_the_value(tmp_path):
    t = np.linspace(0.0, 1.0, 50)
    write_raw(
        tmp_path / "u.npz",
        header({"displacement": "m", "force": "furlong"}),
        {"time": t, "in.displacement": t, "out.force": t},
    )
    with pytest.raises(RecordingError, match=r"u.npz: .*channel 'force' has the unknown unit "):
        load_recording(tmp_path / "u.npz")
    with pytest.raises(RecordingError, match=r"unknown unit 'furlong'"):
        Recording("r", "t", t, {}, {"force": t}, {"force": "furlong"})


def test_channel_in_another_quantity_than_the_model_reads_is_refused():
    rec = damper_recording(2000, 10.0)
    wrong = Recording(
        rec.name,
        rec.test,
        rec.time,
        dict(rec.inputs),
        dict(rec.outputs),
        {**DAMPER_UNITS, "force": "m/s"},
    )
    with pytest.raises(ValidationError, match=r"'force' is in 'm/s', but the damper model reads"):
        diagnose(wrong, "damper")


# ------------------------------------------------------------------ implausible values
def test_data_scaled_by_1e300_are_refused_as_implausible():
    rec = make_case("damper", 1, 0).recording
    big = rec.with_outputs({"force": rec.outputs["force"] * 1e300})
    with pytest.raises(ValidationError) as info:
        diagnose(big, "damper")
    msg = str(info.value)
    assert "output channel 'force' reaches" in msg and "e+30" in msg
    assert f"implausible force: the limit is {PLAUSIBLE['N'][0]:.6g} N" in msg
    # every channel: an implausible stroke too (mm numbers read as m, times 1e4)
    far = Recording(
        rec.name,
        rec.test,
        rec.time,
        {k: v * (1e4 if k == "displacement" else 1.0) for k, v in rec.inputs.items()},
        dict(rec.outputs),
        dict(rec.units),
    )
    with pytest.raises(ValidationError, match=r"input channel 'displacement' reaches .* m"):
        diagnose(far, "damper")


def test_non_finite_values_are_refused_by_the_check():
    class Rec:  # any object with a recording's members (RecordingLike)
        name, test = "duck", "dyno_sine"
        time = np.linspace(0.0, 1.0, 10)
        inputs = {"displacement": np.zeros(10)}
        outputs = {"force": np.r_[np.zeros(4), np.nan, np.zeros(5)]}
        units = {"time": "s", "displacement": "m", "force": "N"}
        meta: dict = {}

    with pytest.raises(ValidationError, match=r"'force' has 1 non-finite sample\(s\), the first"):
        check_values(Rec(), DAMPER_UNITS)


# ------------------------------------------------------------------ memory bounds
def test_npz_bomb_is_refused_before_allocation(tmp_path):
    path = tmp_path / "bomb.npz"
    zeros = np.zeros(1_000_000)  # 8 MB of float64 per channel once expanded
    with open(path, "wb") as fh:
        np.savez_compressed(
            fh,
            __meta__=np.array(json.dumps(header({"displacement": "m", "force": "N"}))),
            time=zeros,
            **{"in.displacement": zeros, "out.force": zeros},
        )
    del zeros
    assert path.stat().st_size < 1e5  # 24 MB of zeros compress to about 25 kB
    limit = 2**20
    tracemalloc.start()
    try:
        with pytest.raises(RecordingError) as info:
            read_recording(path, max_bytes=limit)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < limit  # refused from the archive's directory, nothing expanded
    msg = str(info.value)
    assert msg.startswith("bomb.npz: the archive's 4 member(s) expand to")
    assert f"more than the read limit of {limit} bytes" in msg and MAX_READ_ENV in msg


def test_npz_header_claiming_more_than_it_holds_is_refused(tmp_path):
    # a .npy header declaring 10^12 float64 values over 16 bytes of data
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        buf, {"descr": "<f8", "fortran_order": False, "shape": (10**12,)}
    )
    buf.write(np.zeros(2).tobytes())
    path = tmp_path / "liar.npz"
    for member in ("time.npy", "time"):  # numpy reads an array whatever the member's name
        with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as zf:
            zf.writestr(member, buf.getvalue())
        with pytest.raises(RecordingError, match=rf"'{member}' declares an array of shape"):
            load_recording(path)


def test_object_arrays_are_never_unpickled(tmp_path):
    path = tmp_path / "obj.npz"
    np.savez(path, __meta__=np.array("{}"), time=np.array([object(), 1], dtype=object))
    with pytest.raises(RecordingError, match=r"'time.npy' is an object array"):
        load_recording(path)


def test_read_limit_from_the_environment(tmp_path, monkeypatch):
    assert read_limit() == DEFAULT_MAX_READ_BYTES == 512 * 2**20
    rec = damper_recording(200, 3.0)
    path = save_recording(rec, tmp_path / "r.npz")
    monkeypatch.setenv(MAX_READ_ENV, "1000")
    with pytest.raises(RecordingError, match="more than the read limit of 1000 bytes"):
        read_recording(path)
    monkeypatch.setenv(MAX_READ_ENV, "lots")
    with pytest.raises(RecordingError, match=f"{MAX_READ_ENV} must be a positive whole number"):
        read_recording(path)
    monkeypatch.delenv(MAX_READ_ENV)
    assert read_recording(path).n_samples == 200


def test_text_and_mat_files_are_bounded(tmp_path):
    csv = tmp_path / "DATA_EMPS_SC.csv"
    csv.write_text("time_exp,q_ref,q_meas,v_est,u_in,u_tot\n" + "0,0,0,0,0,0\n" * 1000)
    with pytest.raises(RecordingError, match=r"a text file of \d+ bytes .* may expand to"):
        read_recording(csv, max_bytes=40_000)
    mat = tmp_path / "bomb.mat"
    scipy.io.savemat(mat, {"qm": np.zeros(500_000), "t": np.zeros(500_000)}, do_compression=True)
    assert mat.stat().st_size < 100_000
    with pytest.raises(RecordingError, match=r"bomb.mat: the MATLAB file's variables expand to"):
        read_recording(mat, max_bytes=2**20)
    # a profile whose distance would resample into 4e12 grid points
    x = np.r_[np.linspace(0.0, 1.0, 15), 1e12]
    with pytest.raises(ValidationError, match=r"on a 0.25 m grid has 4e\+12 points"):
        profile_recording(x, np.zeros(16))
    txt = tmp_path / "p.txt"
    txt.write_text("0 1\n1 x\n")
    with pytest.raises(ValidationError, match=r"p.txt: not a table of numbers"):
        load_profile_txt(txt)


# ------------------------------------------------------------------ K&C loops
def test_part_of_a_knc_loop_is_refused():
    from suspenv.rigs.knc_truth import measure_truth

    recs = measure_truth({}, seed=0, steps=6, tests=("parallel", "opposite", "single"))
    part = recs["opposite"].select(slice(0, 9))
    with pytest.raises(ValidationError, match=r"9 samples, but the whole loop .* steps=6 has 13"):
        diagnose({**recs, "opposite": part}, "knc", holdout="single")


# ------------------------------------------------------------------ the CLI says it in one line
def test_cli_prints_the_refusal_as_one_line(tmp_path, capsys):
    from suspenv.cli.main import main

    path = save_recording(damper_recording(2, 1.0), tmp_path / "two.npz")
    rc = main(["diagnose", str(path), "--model", "damper", "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert rc == 2
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith("suspenv diagnose: error: recording 'x': 2 samples; a diagnosis")
    assert not (tmp_path / "out").exists()  # nothing written for refused data
