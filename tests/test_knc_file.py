"""The measured-K&C format (suspenv/measurements/knc_file.py, docs/knc.md "Measured K&C
format"): the round trip through ``suspenv knc``, unit conversion, the refusals (one
test per rule, each message naming the rule and the value), the noise estimate and
the grid."""

from __future__ import annotations

import contextlib
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from suspenv.cli.main import main
from suspenv.core.errors import ValidationError
from suspenv.measurements import RecordingError
from suspenv.measurements.knc import branch_index
from suspenv.measurements.knc_file import (
    CHANNELS,
    MANIFEST,
    MeasuredTest,
    estimate_noise,
    from_results,
    load_measurement,
    write_measurement,
    write_test_csv,
)
from suspenv.metrics.knc import OBJECTIVE_NAMES, OBJECTIVES, objectives
from suspenv.models.mcpherson.vehicle_file import REFERENCE_FILE, load_vehicle
from suspenv.rigs.knc import ALL_TESTS, RIG_TESTS, loop_path, run_tests
from suspenv.rigs.knc_measured import measured_results, on_grid


# ------------------------------------------------------------------ fixtures
@pytest.fixture(scope="module")
def reference_results():
    """``run_tests`` of the reference vehicle, every test, the CLI's defaults."""
    v = load_vehicle(REFERENCE_FILE)
    return run_tests(v.axle(), RIG_TESTS, 0.040, 30, v.effects, force_amplitude=2500.0)


@pytest.fixture(scope="module")
def cli_folder(tmp_path_factory):
    """What ``suspenv knc reference --test all`` writes."""
    out = tmp_path_factory.mktemp("knc") / "out"
    assert main(["knc", "reference", "--test", "all", "--out", str(out)]) == 0
    return out


@pytest.fixture(scope="module")
def small_results():
    v = load_vehicle(REFERENCE_FILE)
    return run_tests(v.axle(), ("parallel", "lateral"), 0.040, 10, v.effects)


@pytest.fixture
def folder(tmp_path, small_results):
    """A valid two-test measurement folder (parallel, lateral; 21 samples each)."""
    write_measurement(from_results(small_results, "car"), tmp_path)
    return tmp_path


def edit_csv(path: Path, fn) -> None:
    """Rewrite a CSV: ``fn(header: list[str], rows: list[list[str]])`` edits in place."""
    lines = path.read_text().splitlines()
    header, rows = lines[0].split(","), [ln.split(",") for ln in lines[1:]]
    fn(header, rows)
    path.write_text("\n".join(",".join(r) for r in [header, *rows]) + "\n")


def drop_columns(*names: str):
    """An :func:`edit_csv` edit removing the columns ``names``."""

    def fn(header: list[str], rows: list[list[str]]) -> None:
        keep = [i for i, h in enumerate(header) if h not in names]
        assert len(keep) == len(header) - len(names)
        for r in [header, *rows]:
            r[:] = [r[i] for i in keep]

    return fn


def edit_toml(path: Path, old: str, new: str) -> None:
    text = path.read_text()
    assert old in text, old
    path.write_text(text.replace(old, new, 1))


def refused(path: Path, pattern: str, **kw) -> str:
    with pytest.raises(RecordingError, match=pattern) as exc:
        load_measurement(path, **kw)
    return str(exc.value)


def solver_zero_bound(opp) -> np.ndarray:
    """Largest |opp_roll_force| [N/mm^2] and |opp_roll_rate| [N*m/deg^2] a mirrored axle
    may show from the solver's tolerance alone. Each tyre force is within kt x 1e-6 m of
    its exact value (the solver's position tolerance), so half the force difference is
    within kt x 1e-6 m and the roll moment within that x the contact track; a 7-point
    least-squares quadratic on spacing h turns a noise e into a curvature 2c of at most
    2 sum|k^2 - 4| / (84 h^2) e = 0.476 e / h^2 (k = -3..3). Spacing: the smallest step of
    half the wheel-travel difference [mm] and of the roll angle [deg] near static."""
    st, kt = opp.static_index, 252.18e3  # N/m, the reference tyre rate
    z = opp.branch("wheel_centre_z", "down")[0][st - 3 : st + 4]
    cy = opp.branch("contact_y", "down")[0][st]
    wy = opp.branch("wheel_centre_y", "down")[0][st]
    half = 0.5 * (z[:, 0] - z[:, 1]) * 1e3
    roll = np.degrees(np.arctan((z[:, 0] - z[:, 1]) / (wy[0] - wy[1])))
    noise = kt * 1e-6 * np.array([1.0, cy[0] - cy[1]])
    h = np.array([np.abs(np.diff(half)).min(), np.abs(np.diff(roll)).min()])
    return 0.476 * noise / h**2


# ------------------------------------------------------------------ round trip
def test_cli_output_loads_back_to_the_simulated_channels(cli_folder, reference_results):
    m = load_measurement(cli_folder)
    assert set(m.tests) == set(RIG_TESTS)
    assert m.meta["files"]["parallel"] == "mcpherson_reference_parallel.csv"
    for test, res in reference_results.items():
        mt = m.tests[test]
        np.testing.assert_array_equal(mt.branch, branch_index(30).astype(int))
        np.testing.assert_allclose(mt.drive, res.grid[res.path], rtol=1e-14, atol=1e-15)
        assert mt.uniform_steps() == 30
        for name, v in res.channels.items():
            if name not in CHANNELS:
                continue
            # 15 significant digits of the mm/deg values (5e-16 relative) and the unit
            # conversion's rounding
            scale = np.max(np.abs(v[0])) or 1.0
            np.testing.assert_allclose(mt.channels[name], v[0], rtol=0, atol=1e-13 * scale)
        assert all(s == "estimated" for s in m.noise_source.values())


def test_round_trip_gives_the_simulations_40_objectives(cli_folder, reference_results):
    m = load_measurement(cli_folder)
    F_sim = objectives(reference_results)[0]
    F_file = objectives(measured_results(m))[0]
    assert len(F_file) == len(OBJECTIVES) == 40
    # the reference axle is mirrored: in opposite travel the roll force and roll rate
    # curvatures are zero by symmetry, and the simulation's values are the solver's
    # convergence noise (solver_zero_bound) that the file's 15 significant digits shift
    # relatively; those two are compared absolutely (reference: the simulation itself),
    # all others relatively
    zero = np.isin(OBJECTIVE_NAMES, ("opp_roll_force", "opp_roll_rate"))
    bound = solver_zero_bound(reference_results["opposite"])
    assert np.all(np.abs(F_sim[zero]) <= bound), (F_sim[zero], bound)
    np.testing.assert_allclose(F_file[~zero], F_sim[~zero], rtol=1e-6, atol=0)
    # the file's rounding (5e-16 of ~4 kN, 0.5 e / h^2 as above) moves them by < 5e-11
    np.testing.assert_allclose(F_file[zero], F_sim[zero], rtol=0, atol=1e-9)


def test_on_grid_of_an_exact_loop_is_the_rig_result(small_results):
    res = small_results["parallel"]
    kc = on_grid(from_results(small_results, "car").tests["parallel"])
    np.testing.assert_array_equal(kc.grid, res.grid)
    np.testing.assert_array_equal(kc.path, res.path)
    for name in CHANNELS:
        np.testing.assert_array_equal(kc.channels[name], res.channels[name])


def test_golden_loop_path_and_its_branches():
    """The loop order written out by hand for 4 intervals (design at index 2): design ->
    bump (+end) -> rebound (-end) -> design, and the branch of every step."""
    from suspenv.measurements.knc import branch_index

    np.testing.assert_array_equal(loop_path(4), [2, 3, 4, 3, 2, 1, 0, 1, 2])
    np.testing.assert_array_equal(branch_index(4), [0, 0, 0, 1, 1, 1, 1, 2, 2])


def test_on_grid_interpolates_irregular_samples_of_a_known_curve():
    """A loop sampled at irregular drive points of known straight lines (ascending
    y = 1 + 2x, descending y = 1 + 2x + 0.5: a hysteresis offset): on the grid, both
    branches are the lines themselves (linear interpolation is exact on a line)."""
    rng = np.random.default_rng(3)
    up1 = np.sort(rng.uniform(0, 1, 8))
    down = np.sort(rng.uniform(-1, 1, 15))[::-1]
    up2 = np.sort(rng.uniform(-1, 0, 7))
    x = np.r_[0.0, up1, 1.0, down, -1.0, up2]
    b = np.r_[np.zeros(10), np.ones(16), np.full(7, 2)].astype(int)
    y = 1 + 2 * x + 0.5 * (b == 1)
    y[9] = 1 + 2 * 1.0  # +end: the turning point (branch 0) lies on both lines' start
    mt = MeasuredTest("parallel", x, b, {"toe": np.c_[y, y]})
    kc = on_grid(mt, 10)
    np.testing.assert_allclose(kc.grid, np.linspace(-1, 1, 11))
    up = kc.branch("toe", "up")[0, :, 0]
    down_g = kc.branch("toe", "down")[0, :, 0]
    np.testing.assert_allclose(up[1:-1], 1 + 2 * kc.grid[1:-1], atol=1e-12)
    np.testing.assert_allclose(down_g[1:-1], 1.5 + 2 * kc.grid[1:-1], atol=1e-12)
    # the ends are the turning points both branches share (the samples at -1 and +1)
    assert up[0] == down_g[0] == pytest.approx(-0.5)
    assert up[-1] == down_g[-1] == pytest.approx(3.0)


def test_declared_noise_round_trips_and_the_rest_is_estimated(tmp_path, small_results):
    m = from_results(small_results, "car", noise={"toe": math.radians(0.01)})
    assert m.noise_source["toe"] == "declared" and m.noise_source["camber"] == "estimated"
    write_measurement(m, tmp_path)
    assert "toe = { sigma = 0.01" in (tmp_path / MANIFEST).read_text()
    back = load_measurement(tmp_path)
    assert back.noise["toe"] == pytest.approx(math.radians(0.01), rel=1e-12)
    assert back.noise_source["toe"] == "declared"
    assert back.noise_source["camber"] == "estimated"


def test_lateral_values_are_raw_iso_y_on_each_wheel(folder):
    """Golden sign test: the file holds raw ISO 8855 y (left wheel y > 0, right y < 0;
    never mirrored outboard), and the left column lands in column 0."""
    header = (folder / "parallel.csv").read_text().splitlines()[0].split(",")
    row = (folder / "parallel.csv").read_text().splitlines()[1].split(",")
    y_left = float(row[header.index("wheel_centre_y_left [mm]")])
    y_right = float(row[header.index("wheel_centre_y_right [mm]")])
    assert y_left > 500 and y_right < -500
    m = load_measurement(folder)
    y = m.tests["parallel"].channels["wheel_centre_y"]
    assert y[0, 0] == pytest.approx(y_left * 1e-3) and y[0, 1] == pytest.approx(y_right * 1e-3)


def test_units_are_converted_to_si(folder):
    """Columns rewritten in other units (values converted by hand with the exact
    definitions 1 in = 25.4 mm, 1 lbf = 4.4482216152605 N, 1 kgf = 9.80665 N,
    1 mrad = 1e-3 rad) load to the same SI values."""
    ref = load_measurement(folder)

    def to_other(header, rows):
        conv = {
            "stroke [mm]": ("stroke [in]", 1 / 25.4),
            "toe_left [deg]": ("toe_left [rad]", math.pi / 180),
            "camber_left [deg]": ("camber_left [mrad]", 1e3 * math.pi / 180),
            "tyre_fz_left [N]": ("tyre_fz_left [lbf]", 1 / 4.4482216152605),
            "tyre_fz_right [N]": ("tyre_fz_right [kgf]", 1 / 9.80665),
            "contact_y_left [mm]": ("contact_y_left [m]", 1e-3),
        }
        for i, h in enumerate(header):
            if h in conv:
                header[i], f = conv[h]
                for r in rows:
                    r[i] = repr(float(r[i]) * f)

    edit_csv(folder / "parallel.csv", to_other)
    m = load_measurement(folder)
    a, b = m.tests["parallel"], ref.tests["parallel"]
    np.testing.assert_allclose(a.drive, b.drive, rtol=1e-12)
    for name in ("toe", "camber", "tyre_fz", "contact_y"):
        np.testing.assert_allclose(a.channels[name], b.channels[name], rtol=1e-12)
    assert a.units["tyre_fz_left [lbf]"] == "lbf"


def test_moment_units(tmp_path, small_results):
    """The aligning test's moment column in lbf*ft (1 lbf*ft = 4.4482216152605 *
    0.3048 N*m) loads in N*m."""
    m = from_results({"parallel": small_results["parallel"]}, "car")
    mt = m.tests.pop("parallel")
    mt.test = "aligning"
    m.tests["aligning"] = mt
    mt.drive = mt.drive * 5000.0  # a moment of +-200 N*m
    write_measurement(m, tmp_path)

    def to_lbf_ft(header, rows):
        i = header.index("moment [N*m]")
        header[i] = "moment [lbf*ft]"
        for r in rows:
            r[i] = repr(float(r[i]) / (4.4482216152605 * 0.3048))

    edit_csv(tmp_path / "aligning.csv", to_lbf_ft)
    back = load_measurement(tmp_path).tests["aligning"]
    np.testing.assert_allclose(back.drive, mt.drive, rtol=1e-12)
    assert back.drive.max() == pytest.approx(200.0)


# ------------------------------------------------------------------ refusals
def test_refuses_a_missing_channel_column(folder):
    edit_csv(folder / "parallel.csv", drop_columns("toe_left [deg]"))
    msg = refused(folder, r"missing column\(s\) \['toe_left'\]")
    assert "parallel.csv" in msg


def test_refuses_an_unknown_unit(folder):
    edit_csv(
        folder / "parallel.csv",
        lambda h, rows: h.__setitem__(h.index("toe_left [deg]"), "toe_left [grad]"),
    )
    refused(folder, r"column 'toe_left \[grad\]': unknown unit 'grad'")


def test_refuses_a_unit_of_the_wrong_quantity(folder):
    edit_csv(
        folder / "parallel.csv",
        lambda h, rows: h.__setitem__(h.index("toe_left [deg]"), "toe_left [mm]"),
    )
    refused(folder, r"the unit must be a angle .* but got 'mm' \(a length\)")


def test_refuses_a_non_monotonic_drive_within_a_branch(folder):
    def swap(header, rows):
        i = header.index("stroke [mm]")
        rows[2][i], rows[3][i] = rows[3][i], rows[2][i]

    edit_csv(folder / "parallel.csv", swap)
    refused(
        folder, r"'stroke \[mm\]' must increase strictly within branch 0, but rows 3 and 4 hold"
    )


def test_refuses_a_nan_run(folder):
    def holes(header, rows):
        i = header.index("camber_right [deg]")
        for r in rows[4:7]:
            r[i] = "nan"

    edit_csv(folder / "parallel.csv", holes)
    refused(
        folder,
        r"'camber_right \[deg\]' must be finite, but holds 3 .* first run of 3 from data row 5",
    )


def test_refuses_a_test_without_both_wheels(folder):
    def drop_right(header, rows):
        keep = [i for i, h in enumerate(header) if "_right" not in h]
        for r in [header, *rows]:
            r[:] = [r[i] for i in keep]

    edit_csv(folder / "lateral.csv", drop_right)
    refused(
        folder,
        r"lateral.csv \(test 'lateral'\): missing column\(s\) \[.*'toe_right'.*\].*a test "
        r"needs both wheels",
    )


def test_one_wheel_measurement_refused_for_identification_but_read_for_compliance(folder):
    for name in ("parallel.csv", "lateral.csv"):

        def drop_right(header, rows):
            keep = [i for i, h in enumerate(header) if "_right" not in h]
            for r in [header, *rows]:
                r[:] = [r[i] for i in keep]

        edit_csv(folder / name, drop_right)
    edit_toml(folder / MANIFEST, 'wheels = ["left", "right"]', 'wheels = ["left"]')
    refused(folder, r"a test needs both wheels, but wheels = \['left'\]")
    m = load_measurement(folder, both_wheels=False)
    assert m.wheels == ("left",)
    toe = m.tests["lateral"].channels["toe"]
    assert np.isfinite(toe[:, 0]).all() and np.isnan(toe[:, 1]).all()


def test_refuses_an_unknown_test(folder):
    edit_toml(folder / MANIFEST, "[tests.lateral]", "[tests.cornering]")
    refused(folder, r"unknown test 'cornering'")


def test_refuses_a_wrong_format_version(folder):
    edit_toml(folder / MANIFEST, "version = 1", "version = 2")
    refused(folder, r"knc.toml: version must be 1, but got 2")


def test_refuses_a_wrong_format_name(folder):
    edit_toml(folder / MANIFEST, 'format = "suspenv-knc"', 'format = "adams-knc"')
    refused(folder, r"format must be 'suspenv-knc', but got 'adams-knc'")


def test_refuses_a_wrong_sign_convention(folder):
    edit_toml(folder / MANIFEST, 'sign_convention = "ISO 8855"', 'sign_convention = "SAE J670"')
    refused(folder, r"sign_convention must be 'ISO 8855' .* but got 'SAE J670'")


def test_refuses_too_few_samples(folder):
    edit_csv(folder / "parallel.csv", lambda h, rows: rows.__delitem__(slice(4, None)))
    refused(folder, r"`samples >= 5` must hold, but got 4 rows")


def test_refuses_an_unknown_column(folder):
    edit_csv(
        folder / "parallel.csv",
        lambda h, rows: h.__setitem__(h.index("toe_left [deg]"), "teo_left [deg]"),
    )
    refused(folder, r"column 'teo_left \[deg\]' is not one of this test's columns")


def test_refuses_a_branch_outside_0_1_2(folder):
    edit_csv(folder / "parallel.csv", lambda h, rows: rows[0].__setitem__(1, "3"))
    refused(folder, r"'branch' must be 0, 1 or 2, but row 1 holds 3")


def test_refuses_a_channel_the_caller_requires(folder):
    edit_toml(folder / MANIFEST, '"caster", ', "")
    edit_csv(folder / "parallel.csv", drop_columns("caster_left [deg]", "caster_right [deg]"))
    refused(folder, r"missing channel\(s\) \['caster'\]", require=("toe", "caster"))


def test_refuses_a_folder_without_manifest(tmp_path):
    refused(tmp_path, r"no knc.toml found")


# ------------------------------------------------------------------ noise
def _noisy_loop(sigma: float, seed: int, irregular: bool) -> MeasuredTest:
    """A 121-sample loop of smooth curves (the toe-like y = 0.01 x + 0.002 x^2 and a
    force-like 300 x + hysteresis) plus white Gaussian noise of known sigma."""
    steps = 60
    grid = np.linspace(-40.0, 40.0, steps + 1)
    x = grid[loop_path(steps)]
    if irregular:  # keep the order within each branch, move the points
        rng = np.random.default_rng(seed + 100)
        x = x + rng.uniform(-0.3, 0.3, x.size) * (grid[1] - grid[0])
        x[0] = 0.0
    b = branch_index(steps).astype(int)
    rng = np.random.default_rng(seed)
    toe = 0.01 * x + 0.002 * x**2
    fz = 300.0 * x + 50.0 * (b == 1)
    noise = rng.normal(0.0, sigma, (x.size, 2))
    return MeasuredTest(
        "parallel",
        x,
        b,
        {"toe": np.c_[toe, toe] + noise, "tyre_fz": np.c_[fz, fz] + 1000 * noise},
    )


@pytest.mark.parametrize("irregular", [False, True])
def test_noise_estimate_recovers_a_known_sigma(irregular):
    """Third-difference (local parabola) residuals with the MAD: the estimate of white
    noise of known sigma is within 20 % (about 230 residuals per channel)."""
    for seed in range(3):
        sigma = 0.02
        est = estimate_noise([_noisy_loop(sigma, seed, irregular)])
        assert est["toe"] == pytest.approx(sigma, rel=0.2)
        assert est["tyre_fz"] == pytest.approx(1000 * sigma, rel=0.2)


def test_noise_estimate_of_noise_free_data_is_small_and_positive(small_results):
    m = from_results(small_results, "car")
    assert all(s > 0 for s in m.noise.values())
    # far below any rig's noise: toe 1e-4 deg, positions 1e-3 mm
    assert m.noise["toe"] < math.radians(1e-4)
    assert m.noise["wheel_centre_y"] < 1e-6


def test_estimated_noise_is_marked_estimated_on_load(folder):
    m = load_measurement(folder)
    assert set(m.noise) == set(m.meta["channels"])
    assert set(m.noise_source.values()) == {"estimated"}


# ------------------------------------------------------------------ command line
def test_cli_reads_a_measured_folder_and_analyses_its_compliance(folder, capsys):
    assert main(["knc", str(folder)]) == 0
    out = capsys.readouterr().out
    assert "parallel           21 samples, stroke -40 to 40 mm, branches [0, 1, 2]" in out
    assert "lateral test, toe of the left wheel against force" in out
    assert "lateral test, toe of the right wheel against force" in out
    assert "(estimated)" in out


def test_cli_says_why_a_coarse_loop_has_no_compliance_analysis(tmp_path, capsys):
    """A loop of 6 steps has one drive value within 0.25 x its reach (the small-drive
    slope needs two): the analysis names that and the command goes on."""
    v = load_vehicle(REFERENCE_FILE)
    res = run_tests(v.axle(), ("lateral", "aligning"), 0.040, 6, v.effects)
    write_measurement(from_results(res, "coarse"), tmp_path)
    assert main(["knc", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    for test in res:
        assert f"{test} test, toe of the right wheel: no compliance analysis: " in out
    assert "small-drive samples need 2 distinct drive values" in out


def test_cli_refuses_a_bad_measured_folder_with_the_rule(folder, capsys):
    edit_toml(folder / MANIFEST, "version = 1", "version = 7")
    assert main(["knc", str(folder)]) == 2
    assert "knc.toml: version must be 1, but got 7" in capsys.readouterr().err


def test_write_test_csv_writes_one_test_of_the_format(tmp_path, small_results):
    m = from_results({"lateral": small_results["lateral"]}, "lateral")
    path = write_test_csv(m.tests["lateral"], tmp_path / "lateral.csv")
    header = path.read_text().splitlines()[0].split(",")
    assert header[:3] == ["step", "branch", "force [N]"]
    assert "contact_y_right [mm]" in header and "toe_left [deg]" in header


# ------------------------------------------------------------------ fuzz
@settings(max_examples=60, deadline=None)
@given(data=st.binary(max_size=400), keep_header=st.booleans())
def test_garbage_csv_is_refused_with_a_named_error(
    tmp_path_factory, small_results, data, keep_header
):
    """Any bytes in a test's CSV (after the valid header or instead of it) give a
    RecordingError or ValidationError, never another exception."""
    folder = tmp_path_factory.mktemp("fuzz")
    write_measurement(from_results(small_results, "car"), folder)
    path = folder / "lateral.csv"
    header = path.read_bytes().splitlines()[0] + b"\n" if keep_header else b""
    path.write_bytes(header + data)
    with contextlib.suppress(ValidationError):  # RecordingError is a ValidationError
        load_measurement(folder)


# ------------------------------------------------------------------ opposed tests
OPPOSED = ("lateral_opposed", "aligning_opposed")


@pytest.fixture(scope="module")
def opposed_results():
    """The rig's opposed tests of the reference vehicle (10 steps, default loads)."""
    v = load_vehicle(REFERENCE_FILE)
    return run_tests(v.axle(), OPPOSED, 0.040, 10, v.effects)


def test_the_formats_opposed_tests_are_the_rigs(opposed_results):
    """measurements.knc.OPPOSED_TESTS names the rig's opposed tests, none of which is in
    the pinned ALL_TESTS; an opposed test loads each wheel in its own sense, so its
    recording (the residual screen's input) gives both wheels the drive itself, and a
    symmetric axle equal channels at every sample (reference: mirror symmetry of the
    reference axle; 1e-9 of each channel's size is far above the solver tolerance's
    effect on a symmetric pair, far below the channels' change with the load)."""
    from suspenv.measurements.knc import OPPOSED_TESTS, drive, drive_label, mirrored
    from suspenv.rigs.knc_recording import to_recording

    assert not set(OPPOSED_TESTS) & set(ALL_TESTS)
    assert set(opposed_results) == set(OPPOSED)
    for test, res in opposed_results.items():
        rec = to_recording(res)
        own = rec.inputs["force"] / res.grid[-1]
        assert np.array_equal(drive(rec, "left"), own)
        assert np.array_equal(drive(rec, "right"), own) and not mirrored(rec)
        want = {"lateral_opposed": "own outboard contact force", "aligning_opposed": "own toe-out"}
        assert drive_label(rec)[0].startswith(want[test])
        for ch in ("toe", "camber", "tyre_fz", "contact_lateral"):
            a, b = rec.outputs[f"{ch}_left"], rec.outputs[f"{ch}_right"]
            assert np.ptp(a) > 1e-6 * np.max(np.abs(a)), (test, ch)  # the load moves it
            np.testing.assert_allclose(b, a, rtol=0, atol=1e-9 * np.max(np.abs(a)))


def test_opposed_tests_written_to_a_folder_load_back_as_the_rigs_output(tmp_path, opposed_results):
    """Reference: the rig's own results. The file holds 15 significant digits of
    mm/deg/N/N*m values, so drive and channels agree to 1e-13 of their size; the
    drive column is the in-phase test's (force [N], moment [N*m])."""
    write_measurement(from_results(opposed_results, "car"), tmp_path)
    m = load_measurement(tmp_path)
    assert set(m.tests) == set(OPPOSED) and m.meta["warnings"] == []
    header = (tmp_path / "lateral_opposed.csv").read_text().splitlines()[0].split(",")
    assert header[2] == "force [N]"
    assert (tmp_path / "aligning_opposed.csv").read_text().split(",")[2] == "moment [N*m]"
    for test, res in opposed_results.items():
        mt = m.tests[test]
        np.testing.assert_array_equal(mt.branch, branch_index(10).astype(int))
        np.testing.assert_allclose(mt.drive, res.grid[res.path], rtol=1e-14, atol=0)
        assert mt.uniform_steps() == 10 and m.meta["steps"][test] == 10
        for name in m.channels:
            v = res.channels[name][0]
            scale = np.max(np.abs(v)) or 1.0
            np.testing.assert_allclose(mt.channels[name], v, rtol=0, atol=1e-13 * scale)
        back = on_grid(mt)
        assert back.unit == res.unit
        np.testing.assert_array_equal(back.path, res.path)


def test_opposed_tests_meet_the_in_phase_rules_wheel_by_wheel(tmp_path, opposed_results):
    """The in-phase lateral rule (each contact point moves along its own load) with each
    wheel's own sense: the right contact point of ``lateral_opposed`` moves along -y
    with +F, so reflecting it about its mean (track unchanged) is refused, and a force
    written in kN labelled N is refused as a force too small for any rig."""
    write_measurement(from_results(opposed_results, "car"), tmp_path)
    path = tmp_path / "lateral_opposed.csv"
    header = path.read_text().splitlines()[0].split(",")
    j = header.index("contact_y_right [mm]")

    def reflect(header: list[str], rows: list[list[str]]) -> None:
        y = np.array([float(r[j]) for r in rows])
        for r, v in zip(rows, 2 * y.mean() - y, strict=True):
            r[j] = repr(float(v))

    original = path.read_text()
    edit_csv(path, reflect)
    refused(tmp_path, r"lateral_opposed\.csv .*contact_y_right must move along the force")
    path.write_text(original)

    def in_kn(header: list[str], rows: list[list[str]]) -> None:
        for r in rows:
            r[2] = repr(float(r[2]) / 1e3)

    edit_csv(path, in_kn)
    refused(tmp_path, r"lateral_opposed\.csv .*the drive reaches only")


def test_the_sheets_opposed_compliances_come_from_a_loaded_folder(tmp_path, opposed_results):
    """Reference: the compliance report of the rig's own opposed results. The same
    report of the folder written and loaded back gives every opposed item (slopes over
    +-2500 N and +-250 N*m of values kept to 15 digits: 1e-9 relative is far above the
    rounding)."""
    from suspenv.metrics.knc_report import compliance_report
    from suspenv.rigs.knc_measured import measured_results

    write_measurement(from_results(opposed_results, "car"), tmp_path)
    sim = compliance_report(opposed_results)
    loaded = compliance_report(measured_results(load_measurement(tmp_path)))
    opposed = [k for k in sim if "opposed" in k]
    assert len(opposed) == 8
    for k in opposed:
        assert np.all(np.isfinite(sim[k])), k
        np.testing.assert_allclose(loaded[k], sim[k], rtol=1e-9, atol=0, err_msg=k)
