"""Geometry rules of vehicle files (suspenv/models/mcpherson/vehicle_checks.py): each
degenerate file of the kinds a user writes by mistake is refused on loading with its
rule and values, before any rig work; the shipped vehicles pass; the ride rate the rule
reads is the rig's own (an independent path: the virtual rig's parallel-travel loop)."""

from __future__ import annotations

import numpy as np
import pytest

from suspenv.core.errors import ValidationError
from suspenv.models.mcpherson import vehicle_checks
from suspenv.models.mcpherson.params import PARAMETER_NAMES
from suspenv.models.mcpherson.vehicle_checks import MIN_LENGTH, ride_rate
from suspenv.models.mcpherson.vehicle_file import (
    FAR_GEOMETRY_FILE,
    REFERENCE_FILE,
    load_vehicle,
)
from suspenv.rigs.knc import run_tests

IDX = {n: i for i, n in enumerate(PARAMETER_NAMES)}


def refused(tmp_path, text: str, pattern: str) -> str:
    path = tmp_path / "v.toml"
    path.write_text(text)
    with pytest.raises(ValidationError, match=pattern) as exc:
        load_vehicle(path)
    return str(exc.value)


def test_shipped_vehicles_pass():
    for path in (REFERENCE_FILE, FAR_GEOMETRY_FILE):
        load_vehicle(path)


def test_strut_top_below_the_ball_joint_is_refused(tmp_path):
    msg = refused(tmp_path, "[design]\nstrut_top_z = -100.0\n", r"v.toml \(left\): `strut_top_z")
    assert "strut_top_z=-100.0 mm" in msg and "lower_ball_joint_z=-39.1 mm" in msg


def test_a_wheel_centre_on_the_wrong_side_is_refused(tmp_path):
    msg = refused(
        tmp_path,
        "[constants]\nwheel_centre = [0.0, 745.0, 20.0]\n",
        "every point of the left corner must lie on its own side",
    )
    assert "wheel_centre is at (0.0, 745.0, 20.0) mm" in msg


def test_a_right_side_point_given_with_the_wrong_sign_is_refused(tmp_path):
    refused(
        tmp_path,
        "[design_right]\ntie_rod_outer_y = 642.7\n",
        "point of the right corner .* tie_rod_outer is at .*642.7",
    )


@pytest.mark.parametrize(
    ("a", "b"),
    [("tie_rod_inner", "tie_rod_outer"), ("lca_front_bush", "lower_ball_joint")],
)
def test_a_zero_length_link_is_refused(tmp_path, a, b):
    ref = load_vehicle(REFERENCE_FILE)
    lines = [f"{a}_{c} = {ref.left[IDX[f'{b}_{c}']]}" for c in "xyz"]
    text = "[design]\n" + "\n".join(lines) + "\n"
    refused(tmp_path, text, rf"`\|{a} - {b}\| >= {MIN_LENGTH * 1e3:g} mm` must hold")


def test_a_negative_ride_rate_is_refused(tmp_path, monkeypatch):
    """The rule's wiring and message (no shipped-range geometry gives a negative rate:
    the lower arm's bushings alone carry about 35 N/mm, so the rate is substituted)."""
    monkeypatch.setattr(vehicle_checks, "ride_rate", lambda axle, effects: np.array([-4e3, 5e4]))
    (tmp_path / "v.toml").write_text("")
    with pytest.raises(ValidationError, match=r"\(left\): the ride rate at design must be > 0"):
        load_vehicle(tmp_path / "v.toml")


def test_ride_rate_is_the_rigs_parallel_travel_slope():
    """The rig's loop at pad +-1 mm (run_tests, parallel, amplitude 2 mm, 4 steps): its
    central difference equals the check's ride rate to the solver's force tolerance
    (0.1 N over 2 mm: 50 N/m, 0.1 % of the rate)."""
    v = load_vehicle(REFERENCE_FILE)
    res = run_tests(v.axle(), ("parallel",), 0.002, 4, v.effects)["parallel"]
    fz = res.branch("tyre_fz", "down")[0]  # (5, 2) on the grid -2, -1, 0, 1, 2 mm
    np.testing.assert_allclose(res.grid[[1, 3]], [-1e-3, 1e-3], rtol=1e-12)
    rig = (fz[3] - fz[1]) / 2e-3
    np.testing.assert_allclose(ride_rate(v.axle(), v.effects), rig, rtol=0, atol=50.0)
