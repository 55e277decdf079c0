"""Plausibility rules of measured K&C folders (suspenv/measurements/knc_checks.py): each
bad file of the kinds users write (a wrong unit, swapped sides, y against ISO 8855, a spike, a
misspelt key, a BOM) is named on loading, before any fit; clean data, simulated or
noisy, raise nothing and warn nothing (the rules do not fire on what a rig records).

References: the reference axle's own rig results (``suspenv.rigs.knc.run_tests``)
written in the format, edited by hand in the way each rule describes."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from suspenv.measurements import RecordingError
from suspenv.measurements.knc_checks import LIMITS, MIN_TRACK
from suspenv.measurements.knc_file import (
    MANIFEST,
    from_results,
    load_measurement,
    write_measurement,
)
from suspenv.models.mcpherson.vehicle_file import REFERENCE_FILE, load_vehicle
from suspenv.rigs.knc import run_tests


@pytest.fixture(scope="module")
def results():
    v = load_vehicle(REFERENCE_FILE)
    return run_tests(v.axle(), ("parallel", "opposite", "single", "lateral"), 0.040, 10, v.effects)


@pytest.fixture
def folder(tmp_path, results):
    write_measurement(from_results(results, "car"), tmp_path)
    return tmp_path


def _table(path: Path) -> tuple[list[str], list[list[str]]]:
    lines = path.read_text().splitlines()
    return lines[0].split(","), [ln.split(",") for ln in lines[1:]]


def _write(path: Path, header: list[str], rows: list[list[str]]) -> None:
    path.write_text("\n".join(",".join(r) for r in [header, *rows]) + "\n")


def scale_column(path: Path, column: str, factor: float, row: int | None = None) -> None:
    """Multiply a column (or one data row of it) by ``factor``."""
    header, rows = _table(path)
    j = header.index(column)
    for i, r in enumerate(rows):
        if row is None or i == row:
            r[j] = repr(float(r[j]) * factor)
    _write(path, header, rows)


def swap_sides(path: Path) -> None:
    """Exchange every ``_left`` column with its ``_right`` one (headers renamed)."""
    header, rows = _table(path)
    swap = {"_left ": "_right ", "_right ": "_left "}
    new = []
    for h in header:
        for a, b in swap.items():
            if a in h:
                h = h.replace(a, b)
                break
        new.append(h)
    _write(path, new, rows)


def swap_travel(path: Path) -> None:
    """Exchange the left and right wheel travel and wheel-centre height columns."""
    text = path.read_text()
    for c in ("wheel_travel", "wheel_centre_z"):
        text = (
            text.replace(f"{c}_left [mm]", "TMP")
            .replace(f"{c}_right [mm]", f"{c}_left [mm]")
            .replace("TMP", f"{c}_right [mm]")
        )
    path.write_text(text)


def refused(path: Path, pattern: str) -> str:
    with pytest.raises(RecordingError, match=pattern) as exc:
        load_measurement(path)
    return str(exc.value)


# ------------------------------------------------------------------ clean data
def test_simulated_data_pass_without_a_warning(folder):
    assert load_measurement(folder).meta["warnings"] == []


def test_noisy_data_pass_without_a_warning(tmp_path, results):
    """Gaussian noise of a rig's size (0.01 mm, 0.005 deg, 5 N) on every channel: no rule
    fires (the spike rule needs SPIKE_SIGMA = 20 robust deviations, which Gaussian noise
    reaches with probability ~1e-80)."""
    rng = np.random.default_rng(7)
    m = from_results(results, "car")
    size = {"tyre_fz": 5.0, "spring_force": 5.0}
    for t in m.tests.values():
        for c, v in t.channels.items():
            sigma = size.get(c, math.radians(0.005) if "_" not in c else 1e-5)
            v += rng.normal(scale=sigma, size=v.shape)
    write_measurement(m, tmp_path)
    assert load_measurement(tmp_path).meta["warnings"] == []


def test_the_test_car_with_its_concealed_effects_passes_without_a_warning(tmp_path):
    """The built-in test car (hysteresis, tolerances, rig noise) in the travel tests and
    two compliance tests: what a rig records with a real axle's loops and kinks is no
    error and no spike."""
    from suspenv.methods.curves.identify import measure_test_car

    tests = ("parallel", "opposite", "single", "lateral", "aligning")
    m, _ = measure_test_car(0, tests=tests, steps=10)
    write_measurement(m, tmp_path)
    assert load_measurement(tmp_path).meta["warnings"] == []


def test_a_bom_is_accepted(folder):
    """Excel's "CSV UTF-8" starts the file with U+FEFF; the values are the same."""
    before = load_measurement(folder)
    p = folder / "parallel.csv"
    p.write_bytes(b"\xef\xbb\xbf" + p.read_bytes())
    after = load_measurement(folder)
    for c, v in before.tests["parallel"].channels.items():
        np.testing.assert_array_equal(after.tests["parallel"].channels[c], v)


# ------------------------------------------------------------------ keys
def test_a_misspelt_key_is_refused_with_the_nearest(folder):
    text = (folder / MANIFEST).read_text().replace("travel_drive =", "travel_drve =")
    (folder / MANIFEST).write_text(text)
    msg = refused(folder, "unknown key 'travel_drve'")
    assert "did you mean 'travel_drive'?" in msg


def test_an_unknown_key_of_a_test_table_is_refused(folder):
    text = (
        (folder / MANIFEST)
        .read_text()
        .replace('file = "lateral.csv"', 'file = "lateral.csv"\nfiel = "x"')
    )
    (folder / MANIFEST).write_text(text)
    msg = refused(folder, r"\[tests.lateral\]: unknown key 'fiel'")
    assert "did you mean 'file'?" in msg


# ------------------------------------------------------------------ magnitudes
def test_millimetres_labelled_metres_are_refused(folder):
    p = folder / "parallel.csv"
    p.write_text(p.read_text().replace("stroke [mm]", "stroke [m]"))
    msg = refused(p.parent, "the drive reaches 40000 mm")
    assert f"limit is {LIMITS['travel'][0] * 1e3:g} mm" in msg and "declared unit" in msg


def test_metres_labelled_millimetres_are_refused(folder):
    p = folder / "lateral.csv"
    header, _ = _table(p)
    (col,) = [h for h in header if h.startswith("force")]
    p.write_text(p.read_text().replace(col, "force [kN]"))
    refused(folder, "the drive reaches 2.5e.06 N")  # 2500 kN: beyond 1e5 N


def test_a_toe_of_hundreds_of_degrees_is_refused(folder):
    scale_column(folder / "opposite.csv", "toe_left [deg]", 1000.0)
    refused(folder, r"toe_left reaches .* deg at data row .*implausible angle")


def test_a_spike_of_1e308_is_refused_before_the_noise_estimate(folder):
    scale_column(folder / "single.csv", "toe_right [deg]", 0.0, row=4)
    header, rows = _table(folder / "single.csv")
    rows[4][header.index("toe_right [deg]")] = "1e308"
    _write(folder / "single.csv", header, rows)
    refused(folder, r"toe_right reaches 1e\+308 deg at data row 5")


# ------------------------------------------------------------------ sides
def test_swapped_sides_are_refused(folder):
    swap_sides(folder / "parallel.csv")
    msg = refused(folder, "the track")
    assert "swapped" in msg


def test_right_values_mirrored_outboard_are_refused(folder):
    scale_column(folder / "parallel.csv", "wheel_centre_y_right [mm]", -1.0)
    msg = refused(folder, f"must be at least {MIN_TRACK * 1e3:g} mm")
    assert "mirrored outboard" in msg


def test_negated_y_is_refused(folder):
    for c in ("wheel_centre_y", "contact_y"):
        for s in ("left", "right"):
            scale_column(folder / "lateral.csv", f"{c}_{s} [mm]", -1.0)
    refused(folder, "lateral.csv .*track.*y is negated")


def test_swapped_travel_columns_of_the_opposite_test_are_refused(folder):
    """Only the wheel travel and height columns exchanged: the track is right, but the
    left wheel falls as the left pad rises."""
    p = folder / "opposite.csv"
    swap_travel(p)
    refused(folder, "opposite test .*the left wheel must rise with the stroke")


def test_swapped_travel_columns_of_the_single_test_are_refused(folder):
    p = folder / "single.csv"
    swap_travel(p)
    refused(folder, "single test .*must move less than the driven left one")


# ------------------------------------------------------------------ opposed tests
@pytest.fixture(scope="module")
def opposed_results():
    v = load_vehicle(REFERENCE_FILE)
    return run_tests(v.axle(), ("lateral_opposed", "aligning_opposed"), 0.040, 10, v.effects)


@pytest.fixture
def opposed(tmp_path, opposed_results):
    write_measurement(from_results(opposed_results, "car"), tmp_path)
    return tmp_path


def test_opposed_tests_pass_clean(opposed):
    assert load_measurement(opposed).meta["warnings"] == []


@pytest.mark.parametrize("test", ["lateral_opposed", "aligning_opposed"])
def test_swapped_sides_of_an_opposed_test_are_refused_by_the_track(opposed, test):
    """The track rule holds for the opposed tests as for the others. In
    ``aligning_opposed`` no direction rule applies (a moment moves no contact point
    along it), so the track is the only rule that sees the swap."""
    swap_sides(opposed / f"{test}.csv")
    msg = refused(opposed, rf"{test}\.csv \(test '{test}'\): .*the track")
    assert "swapped" in msg


@pytest.mark.parametrize("test", ["lateral_opposed", "aligning_opposed"])
def test_right_values_mirrored_outboard_in_an_opposed_test_are_refused(opposed, test):
    scale_column(opposed / f"{test}.csv", "wheel_centre_y_right [mm]", -1.0)
    msg = refused(opposed, rf"{test}\.csv .*must be at least {MIN_TRACK * 1e3:g} mm")
    assert "mirrored outboard" in msg


def _set_column(path: Path, column: str, values: np.ndarray) -> None:
    header, rows = _table(path)
    j = header.index(column)
    for r, v in zip(rows, values, strict=True):
        r[j] = repr(float(v))
    _write(path, header, rows)


def _column(path: Path, column: str) -> np.ndarray:
    header, rows = _table(path)
    return np.array([float(r[header.index(column)]) for r in rows])


def test_wheel_travel_with_its_own_origin_is_accepted(folder):
    """The travel and the wheel-centre height are the same motion; a travel measured
    from another origin (+5 mm) is the same data."""
    p = folder / "parallel.csv"
    z = _column(p, "wheel_centre_z_left [mm]")
    _set_column(p, "wheel_travel_left [mm]", z - z[0] + 5.0)
    load_measurement(folder)


@pytest.mark.parametrize(
    "how, column",
    [
        ("pad stroke", "wheel_travel_left [mm]"),  # the pad's travel as the wheel's
        ("negated", "wheel_travel_right [mm]"),  # bump negative
        ("cm labelled mm", "wheel_travel_left [mm]"),  # a tenth of the travel
    ],
)
def test_wheel_travel_against_the_wheel_centre_height_is_refused(folder, how, column):
    """Reference: the simulated wheel-centre height of the same file (the travel is
    its change from static). Each edit is one a user makes: the pad's stroke written
    as the wheel travel (the tyre deflects, so it is about 1.25 times the wheel
    centre's on the reference car), the sign of bump flipped, a unit off by ten."""
    p = folder / "parallel.csv"
    travel = _column(p, column)
    new = {
        "pad stroke": _column(p, "stroke [mm]"),
        "negated": -travel,
        "cm labelled mm": travel / 10.0,
    }[how]
    _set_column(p, column, new)
    side = column.split("_")[2].split()[0]
    msg = refused(folder, f"parallel.csv .*wheel_travel_{side} must be wheel_centre_z_{side}")
    assert "data row" in msg and "the limit is" in msg


def test_a_contact_moving_against_the_force_is_refused(folder):
    """The left contact point's motion reflected about its mean (its position and the
    track unchanged): it then moves against the lateral force, which no compliance does
    (the sign of a column against ISO 8855)."""
    header, rows = _table(folder / "lateral.csv")
    j = header.index("contact_y_left [mm]")
    y = np.array([float(r[j]) for r in rows])
    for r, v in zip(rows, 2 * y.mean() - y, strict=True):
        r[j] = repr(float(v))
    _write(folder / "lateral.csv", header, rows)
    refused(folder, "contact_y_left must move along the force")


# ------------------------------------------------------------------ spikes
def test_a_moderate_spike_is_a_warning_naming_the_row(folder):
    """One camber reading 0.5 deg off on a curve of a few degrees: inside every limit,
    so a warning (on the identify report's first screen), with the row."""
    header, rows = _table(folder / "parallel.csv")
    j = header.index("camber_left [deg]")
    rows[7][j] = repr(float(rows[7][j]) + 0.5)
    _write(folder / "parallel.csv", header, rows)
    warnings = load_measurement(folder).meta["warnings"]
    assert len(warnings) == 1
    assert "camber_left at data row 8" in warnings[0] and "spike" in warnings[0]
