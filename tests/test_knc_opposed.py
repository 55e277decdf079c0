"""The opposed compliance tests end to end: ``suspenv knc --test`` runs them, the loaded
folder passes the input checks, and ``suspenv identify`` fits them and predicts one held
out.

Reference: a car whose front lower-arm bush is 1.5 times stiffer radially
(``lca_front_ky``) than the reference vehicle's; the opposed tests see it (0.04 deg of
toe at 2500 N). The folders are written by the rig without noise, so the least-squares
answer is the truth: the polish stops within about 1e-7 of it (its ``xtol`` of 1e-8 in
the unit cube, on a log scale over three decades); 1e-5 is far above that and far below
the 50 % the car differs by.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from suspenv.cli.main import main
from suspenv.measurements.knc import OPPOSED_TESTS
from suspenv.measurements.knc_file import from_results, load_measurement, write_measurement
from suspenv.models.mcpherson.vehicle_file import REFERENCE_FILE, dump_vehicle, load_vehicle
from suspenv.rigs.knc import run_tests

#: the changed parameter and its factor
PARAM, FACTOR = "lca_front_ky", 1.5


@pytest.fixture(scope="module")
def stiff():
    v = load_vehicle(REFERENCE_FILE)
    names = [p.name for p in v.space().parameters]
    x = v.left.copy()
    x[names.index(PARAM)] *= FACTOR
    return v.with_design(x, name="stiff")


def _identify(folder: Path, out: Path, held_out: str) -> dict:
    code = main(
        [
            "identify",
            str(folder),
            "--free",
            PARAM,
            "--global-evaluations",
            "0",
            "--workers",
            "1",
            "--no-loop",
            "--no-figures",
            "--quiet",
            "--held-out",
            held_out,
            "--out",
            str(out),
        ]
    )
    assert code == 0
    return json.loads((out / "identify.json").read_text())


def _check_answer(summary: dict, truth: float, held_out: str) -> None:
    (p,) = summary["identifiability"]["parameters"]
    assert p["name"] == PARAM
    np.testing.assert_allclose(p["value"], truth, rtol=1e-5)
    assert summary["held_out"]["test"] == held_out
    # predicted, never fitted: within a thousandth of the noise (noise-free data)
    assert summary["held_out"]["worst_after"] < 1e-3


def test_the_cli_runs_the_opposed_tests_and_identify_fits_them(tmp_path, stiff, capsys):
    """``suspenv knc CAR --test all`` writes the opposed tests with the others, each the
    rig's own loop; ``suspenv knc FOLDER`` checks them and analyses their compliance;
    ``suspenv identify`` fits the folder, ``aligning_opposed`` held out and predicted."""
    car = tmp_path / "stiff.toml"
    car.write_text(dump_vehicle(stiff))
    folder = tmp_path / "rig"
    assert main(["knc", str(car), "--test", "all", "--steps", "10", "--out", str(folder)]) == 0
    m = load_measurement(folder)
    assert set(OPPOSED_TESTS) <= set(m.tests) and m.meta["warnings"] == []
    rig = run_tests(stiff.axle(), tuple(OPPOSED_TESTS), 0.040, 10, stiff.effects)
    for test, res in rig.items():  # 15 significant digits in the files
        v = res.channels["toe"][0]
        np.testing.assert_allclose(m.tests[test].channels["toe"], v, atol=1e-13 * np.ptp(v))
    capsys.readouterr()
    assert main(["knc", str(folder)]) == 0
    text = capsys.readouterr().out
    for test in OPPOSED_TESTS:
        assert f"{test} test, toe of the right wheel against" in text
    truth = float(stiff.left[[p.name for p in stiff.space().parameters].index(PARAM)])
    summary = _identify(folder, tmp_path / "id", "aligning_opposed")
    fitted = {c["test"] for c in summary["curves"]}
    assert "lateral_opposed" in fitted and "aligning_opposed" not in fitted
    _check_answer(summary, truth, "aligning_opposed")


def test_the_opposed_tests_alone_identify_the_bush(tmp_path, stiff):
    """A folder of the opposed tests only: ``lateral_opposed`` fitted (its curves start
    far off, more than a noise unit), ``aligning_opposed`` held out."""
    res = run_tests(stiff.axle(), tuple(OPPOSED_TESTS), 0.040, 10, stiff.effects)
    write_measurement(from_results(res, "stiff"), tmp_path / "rig")
    summary = _identify(tmp_path / "rig", tmp_path / "id", "aligning_opposed")
    assert {c["test"] for c in summary["curves"]} == {"lateral_opposed"}
    assert max(c["initial_rms_over_noise"] for c in summary["curves"]) > 1.0
    truth = float(stiff.left[[p.name for p in stiff.space().parameters].index(PARAM)])
    _check_answer(summary, truth, "aligning_opposed")
