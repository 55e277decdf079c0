"""Output folders of ``suspenv diagnose``, ``suspenv knc`` and ``suspenv planar``: an
existing non-empty folder is refused unless ``--overwrite`` is given (then only the
command's own files are replaced, nothing is deleted), and file names made from data
(a vehicle's name, a recording's) stay plain file names inside ``--out``."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from suspenv.cli.main import main
from suspenv.measurements import Recording, save_recording
from suspenv.measurements.paths import check_output_dir, output_file, plain_file_name
from suspenv.models.mcpherson.vehicle_file import REFERENCE_FILE


def occupied(folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "keep.txt").write_text("the user's own file")
    return folder


def files_under(root: Path) -> set[Path]:
    return {p.relative_to(root) for p in root.rglob("*") if p.is_file()}


def refused(capsys, argv: list[str], folder: Path) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert str(folder) in err and "--overwrite" in err and "not empty" in err
    return err


# ------------------------------------------------------------------ file-name rules
def test_plain_file_names_never_leave_the_folder(tmp_path):
    for name, expected in (
        ("../../escape", "_.._escape"),
        ("/etc/passwd", "_etc_passwd"),
        ("..", "unnamed"),
        ("a b\\c:d", "a_b_c_d"),
        ("-rf", "rf"),
        (".hidden", "hidden"),
        ("ok_name-1.0", "ok_name-1.0"),
    ):
        assert plain_file_name(name) == expected
        assert output_file(tmp_path, name).parent == tmp_path
    assert len(plain_file_name("x" * 1000)) == 128


def test_check_output_dir_rules(tmp_path):
    assert check_output_dir(tmp_path / "new", False) == tmp_path / "new"
    assert not (tmp_path / "new").exists()  # creates nothing
    (tmp_path / "empty").mkdir()
    check_output_dir(tmp_path / "empty", False)
    occupied(tmp_path / "full")
    from suspenv.core.errors import ValidationError

    with pytest.raises(ValidationError, match=r"exists and is not empty; pass --overwrite"):
        check_output_dir(tmp_path / "full", False)
    check_output_dir(tmp_path / "full", True)
    (tmp_path / "file").write_text("x")
    with pytest.raises(ValidationError, match="is a file"):
        check_output_dir(tmp_path / "file", True)


# ------------------------------------------------------------------ suspenv knc
def vehicle_named(tmp_path: Path, name: str) -> Path:
    text = REFERENCE_FILE.read_text().replace(
        'name = "mcpherson_reference"', f"name = {json.dumps(name)}"
    )
    path = tmp_path / "vehicle.toml"
    path.write_text(text)
    return path


def test_knc_refuses_a_non_empty_folder_then_overwrites_its_own_files(tmp_path, capsys):
    out = occupied(tmp_path / "out")
    argv = ["knc", "reference", "--test", "parallel", "--steps", "10", "--out", str(out)]
    refused(capsys, argv, out)
    assert files_under(out) == {Path("keep.txt")}
    assert main([*argv, "--overwrite"]) == 0
    assert files_under(out) == {
        Path("keep.txt"),
        Path("knc.toml"),
        Path("mcpherson_reference_parallel.csv"),
    }
    assert (out / "keep.txt").read_text() == "the user's own file"
    assert main([*argv, "--overwrite"]) == 0  # again: the same file replaced


def test_knc_vehicle_name_with_dot_dot_stays_inside_out(tmp_path, capsys):
    vehicle = vehicle_named(tmp_path, "../../escape")
    out = tmp_path / "a" / "b" / "out"
    argv = ["knc", str(vehicle), "--test", "parallel", "--steps", "10", "--out", str(out)]
    assert main(argv) == 0
    assert files_under(out) == {Path("knc.toml"), Path("_.._escape_parallel.csv")}
    # nothing else was written anywhere under the test folder
    assert files_under(tmp_path) == {
        Path("vehicle.toml"),
        Path("a/b/out/knc.toml"),
        Path("a/b/out/_.._escape_parallel.csv"),
    }
    assert "wrote" in capsys.readouterr().out


def test_knc_vehicle_name_as_absolute_path_stays_inside_out(tmp_path):
    vehicle = vehicle_named(tmp_path, str(tmp_path / "elsewhere"))
    out = tmp_path / "out"
    argv = ["knc", str(vehicle), "--test", "parallel", "--steps", "10", "--out", str(out)]
    assert main(argv) == 0
    written = files_under(out)
    assert len(written) == 2 and all(p.parent == Path(".") for p in written)
    assert not (tmp_path / "elsewhere_parallel.csv").exists()


# ------------------------------------------------------------------ suspenv planar
def test_planar_refuses_a_non_empty_folder_then_overwrites(tmp_path, capsys):
    out = occupied(tmp_path / "plots")
    argv = ["planar", "double_wishbone", "--plot", "--points", "5", "--out", str(out)]
    refused(capsys, argv, out)
    assert files_under(out) == {Path("keep.txt")}
    assert main([*argv, "--overwrite"]) == 0
    assert files_under(out) == {
        Path("keep.txt"),
        Path("double_wishbone.png"),
        Path("double_wishbone_curves.png"),
    }
    # without --plot nothing is written, so an occupied folder does not matter
    assert main(["planar", "double_wishbone", "--points", "5", "--out", str(out)]) == 0


# ------------------------------------------------------------------ suspenv diagnose
def damper_file(folder: Path) -> Path:
    t = np.arange(0.0, 4.0, 0.002)
    x = 0.01 * np.sin(2 * np.pi * 2.0 * t)
    v = 0.01 * 2 * np.pi * 2.0 * np.cos(2 * np.pi * 2.0 * t)
    rec = Recording(
        "damper_run",
        "dyno_sine",
        t,
        {"displacement": x, "velocity": v},
        {"force": 1500.0 * v},
        {"displacement": "m", "velocity": "m/s", "force": "N"},
    )
    return save_recording(rec, folder / "damper_run.npz")


def test_diagnose_refuses_a_non_empty_folder_then_overwrites(tmp_path, capsys, monkeypatch):
    import suspenv.diagnosis.engine as engine
    import suspenv.reports.diagnosis as reports

    calls = []

    def fake_diagnose(recordings, family, holdout=None, **kw):
        calls.append(family)
        return SimpleNamespace(
            verdict="no significant missing physics",
            headline="No significant missing physics",
            evidence=[],
            baseline={},
        )

    def fake_report(diag, out_dir):
        out_dir = Path(out_dir)
        out_dir.mkdir(parents=True, exist_ok=True)
        (out_dir / "report.md").write_text(f"run {len(calls)}")
        return [out_dir / "report.md"]

    # the folder rules only: the diagnosis and the report are stand-ins
    monkeypatch.setattr(engine, "diagnose", fake_diagnose)
    monkeypatch.setattr(reports, "write_diagnosis_report", fake_report)
    rec = damper_file(tmp_path)
    out = occupied(tmp_path / "out")
    argv = ["diagnose", str(rec), "--model", "damper", "--out", str(out)]
    refused(capsys, argv, out)
    assert calls == []  # refused before any work
    assert main([*argv, "--overwrite"]) == 0
    assert main([*argv, "--overwrite"]) == 0
    assert (out / "report.md").read_text() == "run 2"
    assert (out / "keep.txt").read_text() == "the user's own file"
    # the default folder is named from the data as a plain file name, in the working dir
    monkeypatch.chdir(tmp_path)
    assert main(["diagnose", str(rec), "--model", "damper"]) == 0
    assert (tmp_path / "diagnosis_damper_run" / "report.md").is_file()


def test_diagnose_prints_what_it_did_to_a_smoothed_velocity_channel(tmp_path, capsys):
    # a dyno file whose velocity is a Savitzky-Golay derivative of a noisy displacement
    from scipy.signal import savgol_filter

    t = np.arange(0.0, 8.0, 0.002)
    rng = np.random.default_rng(0)
    x = 0.01 * np.sin(2 * np.pi * 1.5 * t) + 0.004 * np.sin(2 * np.pi * 6.0 * t)
    v = np.gradient(x, t)
    xm = x + 2e-5 * rng.standard_normal(t.size)
    rec = Recording(
        "smoothed",
        "dyno_sine",
        t,
        {"displacement": xm, "velocity": savgol_filter(xm, 31, 2, deriv=1, delta=0.002)},
        {"force": 1500.0 * v + 2.0 * rng.standard_normal(t.size)},
        {"displacement": "m", "velocity": "m/s", "force": "N"},
    )
    path = save_recording(rec, tmp_path / "smoothed.npz")
    assert main(["diagnose", str(path), "--model", "damper", "--out", str(tmp_path / "o")]) == 0
    printed = capsys.readouterr().out
    assert "low-passed at" in printed
    assert "the velocity channel is not the derivative of the displacement" in printed
