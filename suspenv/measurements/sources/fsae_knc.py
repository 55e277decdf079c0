"""A Formula Student car's measured toe compliance as measured-K&C data.

Source: ``real/knc_compliance_fsae/`` of the shared data folder
(:func:`suspenv.measurements.data_dir`: ``$SUSPENV_DATA`` or ``../shared/data``; read in
place, never copied into the repository), a Formula Student team's public
vehicle-dynamics repository, MIT licence (its LICENSE is kept beside the files). Its
README: ``mz_steer_compliance_test_data.csv`` holds 21 points, aligning moment Mz [N m]
from -100 to +100 against the toe deflection [deg] of one wheel, credited in the team's
code to another team and probably digitised from a plot.

Import (:func:`fsae_aligning`): one ``aligning`` test of the measured-K&C format
(:mod:`suspenv.measurements.knc_file`), channel ``toe``, one wheel:

* the file has no header and states no frame. Its positive moment gives positive
  toe (the wheel turns the way it is pushed). In ISO 8855 with toe-in positive, a
  moment about +z turns a *right* wheel's front to the left, towards the centre line:
  toe-in. The bench wheel is therefore declared ``wheels = ["right"]`` and every
  number is kept as it is (moment = Mz about +z [N*m], toe [deg] toe-in positive). On
  a left wheel both signs would flip; the compliance is the same;
* the sweep runs once from -100 to +100 N*m (one ascending branch): the samples with
  a negative moment are branch 2 (-end -> design), the others branch 0 (design ->
  +end); :meth:`~suspenv.measurements.knc_file.MeasuredTest.loop` takes the
  missing descending branch equal to it;
* a one-wheel measurement serves the compliance analysis
  (:func:`~suspenv.measurements.knc_compliance.compliance_analysis`), not the identification
  (``load_measurement`` refuses it unless ``both_wheels=False``).

The workbook ``Compliance Testing ZR25.xlsx`` beside it (hanging masses and dial
readings of the team's own car) is not imported: it does not hold the lever-arm length
(the team's script reads it from another workbook), so its moments cannot be formed
from the file alone.
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from suspenv.measurements.errors import RecordingError
from suspenv.measurements.knc_file import KncMeasurement, MeasuredTest, _assemble
from suspenv.measurements.limits import check_text, read_limit
from suspenv.measurements.paths import data_dir

#: the data set's folder inside the shared data folder
FOLDER = Path("real") / "knc_compliance_fsae"
#: the aligning-moment file
MZ_FILE = "mz_steer_compliance_test_data.csv"
NAME = "fsae_mz_steer_compliance"
#: the README's known physics: front toe compliance [deg per 100 N*m] (the team's own
#: car, from the workbook; the moment file is another team's)
README_FRONT_COMPLIANCE = 0.5


def fsae_folder() -> Path:
    """``<shared data>/real/knc_compliance_fsae`` (whether or not it exists)."""
    return data_dir() / FOLDER


def read_mz_csv(path: Path, max_bytes: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(moment [N*m], toe [deg]) of the headerless two-column file; bad rows refused."""
    path = Path(path)
    if not path.is_file():
        raise RecordingError(f"FSAE compliance file {str(path)!r} does not exist")
    check_text(path, read_limit(max_bytes))
    rows = [r for r in csv.reader(io.StringIO(path.read_text(encoding="utf-8"))) if r]
    values = []
    for i, r in enumerate(rows):
        if len(r) != 2:
            raise RecordingError(
                f"{path.name}: line {i + 1} must hold 2 numbers (Mz [N m], toe [deg]), but "
                f"holds {len(r)} fields"
            )
        try:
            values.append((float(r[0]), float(r[1])))
        except ValueError:
            raise RecordingError(f"{path.name}: line {i + 1} is not two numbers: {r!r}") from None
    arr = np.array(values, float).reshape(-1, 2)
    if not np.isfinite(arr).all():
        raise RecordingError(f"{path.name}: every value must be finite")
    return arr[:, 0], arr[:, 1]


def fsae_aligning(path: Path | None = None, max_bytes: int | None = None) -> KncMeasurement:
    """The moment file as a one-wheel ``aligning`` measurement (see the module doc).
    The toe noise is estimated (:func:`~suspenv.measurements.knc_file.estimate_noise`)."""
    path = Path(path) if path is not None else fsae_folder() / MZ_FILE
    mz, toe_deg = read_mz_csv(path, max_bytes)
    order = np.argsort(mz, kind="stable")
    if not np.array_equal(order, np.arange(mz.size)):
        raise RecordingError(f"{path.name}: the moment must increase from line to line")
    branch = np.where(mz < 0, 2, 0).astype(int)
    toe = np.full((mz.size, 2), np.nan)
    toe[:, 1] = np.radians(toe_deg)
    test = MeasuredTest("aligning", mz, branch, {"toe": toe}, ("right",))
    meta = {
        "source": f"{FOLDER / MZ_FILE} (Formula Student team repository, MIT; credited "
        "there to another team; probably digitised from a plot)",
        "sign_convention": "ISO 8855",
        "travel_drive": "pad",
        "wheels": ["right"],
        "notes": "one wheel on a bench: Mz about +z at the contact patch [N m] against its "
        "toe [deg], toe-in positive; positive moment gives toe-in, as on a right wheel in "
        "ISO 8855, so the file's numbers are kept as they are. One ascending sweep "
        "-100 -> +100 N m: branch 2 below zero moment, branch 0 above.",
    }
    return _assemble(NAME, {"aligning": test}, {}, meta)
