"""Recording format: round trip, splitting, and the loaders' bad-file messages."""

from __future__ import annotations

import json

import numpy as np
import pytest

from suspenv.measurements import (
    Recording,
    RecordingError,
    load_recording,
    save_recording,
    smooth_derivative,
    to_si,
)


def make_rec(n: int = 200) -> Recording:
    t = np.linspace(0.0, 1.0, n)
    x = 0.01 * np.sin(2 * np.pi * 2 * t)
    return Recording(
        "sine",
        "dyno_sine",
        t,
        {"displacement": x},
        {"force": 1000.0 * x},
        {"displacement": "m", "force": "N"},
        {"source": "synthetic", "sampling": {"dt_s": t[1] - t[0]}, "notes": "test"},
    )


def write_raw(path, header: dict, arrays: dict) -> None:
    with open(path, "wb") as fh:
        np.savez(fh, __meta__=np.array(json.dumps(header)), **arrays)


def good_header() -> dict:
    return {
        "format": "suspenv-recording",
        "version": 1,
        "name": "r",
        "test": "t",
        "inputs": ["displacement"],
        "outputs": ["force"],
        "units": {"time": "s", "displacement": "m", "force": "N"},
        "meta": {},
    }


def test_roundtrip_preserves_everything(tmp_path):
    rec = make_rec()
    path = save_recording(rec, tmp_path / "a")
    assert path.suffix == ".npz"
    back = load_recording(path, ["displacement"], ["force"], {"force": "N"})
    assert back.name == rec.name and back.test == rec.test
    assert np.array_equal(back.time, rec.time)
    assert np.array_equal(back.outputs["force"], rec.outputs["force"])
    assert back.units == rec.units and back.meta["sampling"]["dt_s"] == pytest.approx(rec.time[1])


def test_missing_channel_is_named(tmp_path):
    rec = make_rec()
    path = save_recording(rec, tmp_path / "a.npz")
    with pytest.raises(RecordingError, match="missing output channel 'acceleration'"):
        load_recording(path, require_outputs=["acceleration"])
    h = good_header()
    t = np.linspace(0, 1, 10)
    write_raw(tmp_path / "b.npz", h, {"time": t, "in.displacement": t})
    with pytest.raises(RecordingError, match="b.npz: missing output channel 'force'"):
        load_recording(tmp_path / "b.npz")


def test_unit_mismatch_is_named(tmp_path):
    h = good_header()
    h["units"]["force"] = "lbf"
    t = np.linspace(0, 1, 10)
    write_raw(tmp_path / "c.npz", h, {"time": t, "in.displacement": t, "out.force": t})
    with pytest.raises(
        RecordingError, match="channel 'force' must be in 'N', but its unit is 'lbf'"
    ):
        load_recording(tmp_path / "c.npz", expect_units={"force": "N"})


def test_non_monotonic_time_names_index_and_values(tmp_path):
    t = np.linspace(0, 1, 10)
    t[6] = t[4]
    write_raw(tmp_path / "d.npz", good_header(), {"time": t, "in.displacement": t, "out.force": t})
    with pytest.raises(
        RecordingError, match=r"strictly increasing, but time\[5\]=0.5555.* s and time\[6\]=0.444"
    ):
        load_recording(tmp_path / "d.npz")


def test_nan_run_names_channel_index_and_length(tmp_path):
    t = np.linspace(0, 1, 101)
    f = np.ones_like(t)
    f[40:47] = np.nan
    write_raw(tmp_path / "e.npz", good_header(), {"time": t, "in.displacement": t, "out.force": f})
    with pytest.raises(
        RecordingError,
        match=r"output channel 'force' has a run of 7 non-finite sample\(s\) starting at index 40 "
        r"\(t=0.4 s, value nan\)",
    ):
        load_recording(tmp_path / "e.npz")


def test_not_a_recording_and_wrong_length(tmp_path):
    np.savez(tmp_path / "f.npz", x=np.zeros(3))
    with pytest.raises(RecordingError, match="missing the '__meta__' JSON entry"):
        load_recording(tmp_path / "f.npz")
    (tmp_path / "g.npz").write_text("hello")
    with pytest.raises(RecordingError, match="not a readable .npz"):
        load_recording(tmp_path / "g.npz")
    h = good_header()
    h["format"] = "other"
    write_raw(tmp_path / "h.npz", h, {"time": np.arange(3.0)})
    with pytest.raises(RecordingError, match="format must be 'suspenv-recording'"):
        load_recording(tmp_path / "h.npz")
    t = np.linspace(0, 1, 10)
    write_raw(
        tmp_path / "i.npz", good_header(), {"time": t, "in.displacement": t[:9], "out.force": t}
    )
    with pytest.raises(RecordingError, match="'displacement' must have one value per time sample"):
        load_recording(tmp_path / "i.npz")
    with pytest.raises(RecordingError, match="does not exist"):
        load_recording(tmp_path / "nope.npz")


def test_channel_without_unit_rejected():
    t = np.linspace(0, 1, 5)
    with pytest.raises(RecordingError, match="output channel 'force' has no unit"):
        Recording("r", "t", t, {}, {"force": t}, {})


def test_splits_are_contiguous_and_cover_the_record():
    rec = make_rec(100)
    est, val = rec.split(0.7)
    assert est.n_samples == 70 and val.n_samples == 30
    assert est.time[-1] < val.time[0]
    assert est.meta["role"] == "estimation" and val.meta["role"] == "validation"
    e2, v2 = rec.split_blocks(5, validation=(1, 3))
    assert e2.n_samples + v2.n_samples == 100
    assert np.all(np.diff(e2.time) > 0) and v2.n_samples == 40
    seg = rec.segment(0.25, 0.5)
    assert seg.time[0] >= 0.25 and seg.time[-1] < 0.5
    with pytest.raises(RecordingError, match="0 < fraction < 1"):
        rec.split(1.5)
    with pytest.raises(RecordingError, match="holds 0 samples"):
        rec.segment(5.0, 6.0)


def test_unit_conversion_factors():
    # exact definitions: 1 in = 0.0254 m, 1 lbf = 4.4482216152605 N (NIST SP 811)
    assert to_si(np.array([1.0]), "in")[0] == pytest.approx([0.0254])
    assert to_si(np.array([1.0]), "lbf") == (pytest.approx([4.4482216152605]), "N")
    assert to_si(np.array([1.0]), "mm/s")[1] == "m/s"
    with pytest.raises(RecordingError, match="unknown unit 'furlong'"):
        to_si(np.array([1.0]), "furlong")


def test_smoothing_differentiator_against_analytic_derivative():
    t = np.arange(0, 2, 1e-3)
    w = 2 * np.pi * 3.0
    x = 0.01 * np.sin(w * t)
    v = smooth_derivative(x, t, window_s=0.02)
    inner = slice(20, -20)
    # analytic derivative 0.01 w cos(wt); cubic Savitzky-Golay gain error ~ (w window)^4 / 7000
    assert np.max(np.abs(v[inner] - 0.01 * w * np.cos(w * t[inner]))) < 2e-3 * 0.01 * w
    a = smooth_derivative(x, t, window_s=0.04, deriv=2)
    assert np.max(np.abs(a[inner] + 0.01 * w**2 * np.sin(w * t[inner]))) < 2e-2 * 0.01 * w**2
    t_bad = t.copy()
    t_bad[100:] += 0.01
    with pytest.raises(RecordingError, match="uniform sampling"):
        smooth_derivative(x, t_bad)


def test_read_recording_npz_and_unknown_type(tmp_path):
    from suspenv.measurements import read_recording

    path = save_recording(make_rec(), tmp_path / "r.npz")
    assert read_recording(path).name == "sine"
    (tmp_path / "x.txt").write_text("1 2 3")
    with pytest.raises(RecordingError, match=r"unknown recording type '.txt'"):
        read_recording(tmp_path / "x.txt")
    import scipy.io

    scipy.io.savemat(tmp_path / "y.mat", {"foo": [1.0]})
    with pytest.raises(RecordingError, match=r"unknown .mat layout.*\['foo'\]"):
        read_recording(tmp_path / "y.mat")
