"""Property-based tests of ``identify``'s two input doors: measured K&C folders
(:func:`~suspenv.measurements.knc_file.load_measurement`) and vehicle files
(:func:`~suspenv.models.mcpherson.vehicle_file.load_vehicle`), then the fit itself.

Every example edits a valid input (the reference axle's own rig results written in
the format, or the shipped reference vehicle file) the way a user's file goes wrong,
and holds three properties:

* **no traceback**: loading and a short identify (one free parameter, three polish
  evaluations) return or raise :class:`~suspenv.core.errors.ValidationError` /
  :class:`~suspenv.core.errors.EvaluationError`, nothing else;
* **no silent wrong result**: an edit a rule promises to catch (a unit a thousand times
  off, swapped sides, y negated, a value of 1e308, a misspelt key, a point on the other
  side, a strut top below the ball joint, a zero-length link) is refused; an accepted
  file loads to finite values within the plausibility limits, and identify answers
  finite numbers;
* **no hang**: each example ends within :data:`SECONDS`.

Every file is small (10 rig steps, three tests), so an example takes about 0.2 s.
"""

from __future__ import annotations

import os
import shutil
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from suspenv.core.errors import EvaluationError, ValidationError
from suspenv.measurements.knc_checks import LIMITS
from suspenv.measurements.knc_file import (
    CHANNELS,
    MANIFEST,
    from_results,
    load_measurement,
    write_measurement,
)
from suspenv.methods.curves.identify import run_identify
from suspenv.models.mcpherson.params import PARAMETER_NAMES
from suspenv.models.mcpherson.vehicle_file import REFERENCE_FILE, load_vehicle
from suspenv.rigs.knc import run_tests

FUZZ = settings(
    max_examples=30,
    deadline=None,
    database=None,
    derandomize=bool(os.environ.get("CI")),
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
#: longest an example may take [s] (about 0.2 s each; 100x that is a hang)
SECONDS = 20.0
#: identify's smallest job: one parameter, a three-evaluation polish, no extras
TINY = {
    "free": ["static_toe"],
    "global_evaluations": 0,
    "polish_nfev": 3,
    "workers": 1,
    "next_test": False,
    "rerun_next": False,
    "diagnose": False,
    "figures": False,
}
FILES = ("parallel.csv", "opposite.csv", "lateral.csv")
BOM = b"\xef\xbb\xbf"


@pytest.fixture(scope="module")
def base(tmp_path_factory) -> Path:
    """A valid measurement folder of the reference axle (parallel, opposite, lateral)."""
    folder = tmp_path_factory.mktemp("knc_base")
    v = load_vehicle(REFERENCE_FILE)
    res = run_tests(v.axle(), ("parallel", "opposite", "lateral"), 0.040, 10, v.effects)
    write_measurement(from_results(res, "car"), folder)
    return folder


@pytest.fixture(scope="module")
def reference():
    return load_vehicle(REFERENCE_FILE)


def _copy(base: Path, work: Path) -> Path:
    if work.exists():
        shutil.rmtree(work)
    shutil.copytree(base, work)
    return work


def _read(path: Path) -> tuple[list[str], list[list[str]]]:
    lines = path.read_text().splitlines()
    return lines[0].split(","), [ln.split(",") for ln in lines[1:]]


def _write(path: Path, header: list[str], rows: list[list[str]]) -> None:
    path.write_text("\n".join(",".join(r) for r in [header, *rows]) + "\n")


def _identify_or_refuse(measurement, vehicle) -> None:
    """A short identify: finite numbers or a named error."""
    try:
        res = run_identify(measurement, vehicle, TINY)
    except (ValidationError, EvaluationError):
        return
    assert np.all(np.isfinite(res.fit.x))
    assert all(np.isfinite(v) for v in res.curve_rms().values())


def _loaded_is_plausible(m) -> None:
    for t in m.tests.values():
        for c, v in t.channels.items():
            assert np.all(np.isfinite(v)), c
            assert np.max(np.abs(v)) <= LIMITS[CHANNELS[c]][0], c


# ------------------------------------------------------------------ K&C folder edits
#: edits a rule promises to catch, and edits it need not (refused or loaded, both fine)
CAUGHT = ("mm_labelled_m", "angle_cell", "huge_cell", "swap_sides", "negate_y", "typo")
BENIGN = ("bom", "drop_row", "duplicate_row", "relabel", "scale", "truncate", "blank_cell")
ANGLES = [c for c, q in CHANNELS.items() if q == "angle"]


def _edit_folder(folder: Path, kind: str, data: st.DataObject) -> None:
    path = folder / data.draw(st.sampled_from(FILES), label="file")
    header, rows = _read(path)
    row = data.draw(st.integers(0, len(rows) - 1), label="row")
    # the columns the loader reads (wheel_travel_* only stands in for a missing
    # wheel_centre_z channel; these files have one)
    cols = [i for i, h in enumerate(header) if "[" in h and not h.startswith("wheel_travel")]
    col = data.draw(st.sampled_from(cols), label="column")
    if kind == "mm_labelled_m":  # the whole file in mm, labelled m
        path.write_text(path.read_text().replace("[mm]", "[m]"))
    elif kind == "angle_cell":  # one angle of hundreds of degrees or more
        j = data.draw(
            st.sampled_from([i for i, h in enumerate(header) if h.split("_")[0] in ANGLES])
        )
        v = data.draw(st.floats(100.0, 1e308)) * data.draw(st.sampled_from([1, -1]))
        rows[row][j] = repr(v)
        _write(path, header, rows)
    elif kind == "huge_cell":
        rows[row][col] = data.draw(st.sampled_from(["1e308", "-1e308", "inf", "nan", "1e300"]))
        _write(path, header, rows)
    elif kind == "swap_sides":
        text = path.read_text().replace("_left [", "_TMP [").replace("_right [", "_left [")
        path.write_text(text.replace("_TMP [", "_right ["))
    elif kind == "negate_y":
        for j, h in enumerate(header):
            if h.startswith(("wheel_centre_y", "contact_y")):
                for r in rows:
                    r[j] = repr(-float(r[j]))
        _write(path, header, rows)
    elif kind == "typo":
        manifest = folder / MANIFEST
        key = data.draw(st.sampled_from(["travel_drive", "wheels", "channels", "file"]))
        manifest.write_text(manifest.read_text().replace(f"{key} =", f"{key[:-1]} =", 1))
    else:
        _edit_benign(path, header, rows, row, col, kind, data)


def _edit_benign(path, header, rows, row, col, kind, data) -> None:
    if kind == "bom":
        path.write_bytes(BOM + path.read_bytes())
        return
    if kind == "truncate":
        raw = path.read_bytes()
        path.write_bytes(raw[: data.draw(st.integers(0, len(raw)))])
        return
    if kind == "drop_row":
        del rows[row]
    elif kind == "duplicate_row":
        rows.insert(row, list(rows[row]))
    elif kind == "relabel":
        unit = data.draw(st.sampled_from(["m", "cm", "in", "rad", "mrad", "kN", "lbf", "?", ""]))
        header[col] = header[col].split("[")[0] + f"[{unit}]"
    elif kind == "scale":
        factor = data.draw(st.sampled_from([-1.0, 0.0, 10.0, 1e-3, 1.0001]))
        for r in rows:
            r[col] = repr(float(r[col]) * factor)
    elif kind == "blank_cell":
        rows[row][col] = ""
    _write(path, header, rows)


@FUZZ
@given(kind=st.sampled_from(CAUGHT + BENIGN), data=st.data())
def test_edited_knc_folders_are_refused_or_identified(
    tmp_path_factory, base, reference, kind, data
):
    folder = _copy(base, tmp_path_factory.getbasetemp() / "fuzz_knc")
    _edit_folder(folder, kind, data)
    start = time.perf_counter()
    try:
        m = load_measurement(folder)
    except ValidationError as exc:
        assert str(exc).strip()
        if kind == "typo":
            assert "did you mean" in str(exc)
        return
    assert kind not in CAUGHT, f"{kind}: loaded without a refusal"
    _loaded_is_plausible(m)
    if kind == "bom":  # the same values as without the BOM
        clean = load_measurement(base)
        for t, mt in clean.tests.items():
            for c, v in mt.channels.items():
                np.testing.assert_array_equal(m.tests[t].channels[c], v)
    _identify_or_refuse(m, reference)
    assert time.perf_counter() - start < SECONDS


# ------------------------------------------------------------------ vehicle file edits
IDX = {n: i for i, n in enumerate(PARAMETER_NAMES)}
POINTS = sorted({n.rsplit("_", 1)[0] for n in PARAMETER_NAMES if n[-2:] in ("_x", "_y", "_z")})


def _vehicle_text(reference, kind: str, data: st.DataObject) -> str:
    """A [design] / [design_right] / [constants] edit of the reference vehicle."""
    left = reference.left
    point = data.draw(st.sampled_from(POINTS), label="point")
    if kind == "other_side":  # a point's y with the wrong sign, on one side
        table = data.draw(st.sampled_from(["design", "design_right"]))
        return f"[{table}]\n{point}_y = {-left[IDX[point + '_y']]!r}\n"
    if kind == "wheel_other_side":
        return "[constants]\nwheel_centre = [0.0, 745.0, 20.0]\n"
    if kind == "strut_below":
        z = left[IDX["lower_ball_joint_z"]] - data.draw(st.floats(0.0, 500.0))
        return f"[design]\nstrut_top_z = {z!r}\n"
    if kind == "zero_link":
        a, b = data.draw(
            st.sampled_from(
                [
                    ("tie_rod_inner", "tie_rod_outer"),
                    ("tie_rod_outer", "tie_rod_inner"),
                    ("strut_axis_point", "strut_top"),
                    ("lower_ball_joint", "lca_front_bush"),
                    ("lca_rear_bush", "lca_front_bush"),
                ]
            )
        )
        return "[design]\n" + "".join(f"{a}_{c} = {left[IDX[f'{b}_{c}']]!r}\n" for c in "xyz")
    # benign: a hard point moved by up to 200 mm, or a stiffness scaled
    axis = data.draw(st.sampled_from("xyz"))
    name = f"{point}_{axis}"
    return f"[design]\n{name} = {left[IDX[name]] + data.draw(st.floats(-200.0, 200.0))!r}\n"


def _obeys_the_geometry_rules(v) -> None:
    """File-convention rules read from the values (every y < 0 on both sides, strut top
    above the ball joint)."""
    for x in (v.left, v.right):
        for p in POINTS:
            assert x[IDX[p + "_y"]] < 0, p
        assert x[IDX["strut_top_z"]] > x[IDX["lower_ball_joint_z"]]
    assert v.constants.wheel_centre[1] < 0


@FUZZ
@given(
    kind=st.sampled_from(
        ["other_side", "wheel_other_side", "strut_below", "zero_link", "move", "move"]
    ),
    data=st.data(),
)
def test_edited_vehicle_files_are_refused_or_identified(tmp_path, base, reference, kind, data):
    path = tmp_path / "vehicle.toml"
    path.write_text(_vehicle_text(reference, kind, data))
    start = time.perf_counter()
    try:
        v = load_vehicle(path)
    except ValidationError as exc:
        assert str(exc).strip()
        return
    assert kind == "move", f"{kind}: loaded without a refusal ({path.read_text()!r})"
    _obeys_the_geometry_rules(v)
    _identify_or_refuse(load_measurement(base), v)
    assert time.perf_counter() - start < SECONDS
