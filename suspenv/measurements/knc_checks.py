"""Plausibility of a measured K&C data set, checked on loading and before any fit.

:func:`suspenv.measurements.knc_file.load_measurement` checks the format column by
column (units of the right quantity, finite numbers, monotonic drive); this module adds
the rules that need the physics of the rig, so that a wrong unit, a swapped pair of
columns or a sign against the documented convention is named here and not, much later,
as a rig that "did not converge". Errors are :class:`~suspenv.measurements.RecordingError`
(the recordings' error: it names the file, the rule and the value); warnings are
returned as text and stored in ``KncMeasurement.meta["warnings"]``, which the identify
report prints on its first screen.

Rules (frame and signs of ``docs/knc.md`` "Measured K&C format": ISO 8855, raw y):

1. **Keys** (:func:`check_manifest_keys`): every key of ``knc.toml`` and of each
   ``[tests.<test>]`` table is one the format knows; an unknown one is refused with the
   nearest known key ("did you mean 'travel_drive'?").
2. **Magnitudes** (error): every value of a channel or drive lies within
   :data:`LIMITS` of its quantity (SI, after the declared unit's conversion); a value
   beyond it means the declared unit is wrong (mm labelled m, deg labelled rad) or the
   file holds a spike (1e308). A drive whose reach is below :data:`MIN_DRIVE` is a unit
   error the other way (m labelled mm).
3. **Sides** (error): the left wheel lies at larger y than the right, by at least
   :data:`MIN_TRACK` (``wheel_centre_y``, ``contact_y``; raw y, left positive: columns
   swapped or y negated give a negative track, right values mirrored outboard a track
   near zero). In a travel test the left wheel rises with the stroke (the left pad
   drives, bump positive) and the right one rises (``parallel``), falls
   (``opposite``) or moves less than the left (``single``). In a force test the loaded
   point moves along the force (a compliance matrix is positive definite):
   ``contact_y`` along +y in ``lateral``, ``contact_x`` along +x in ``longitudinal``,
   ``wheel_centre_x`` along +x in ``traction``; an opposed test wheel by wheel as its
   in-phase test under that wheel's own load. A direction counts when the
   correlation with the drive passes :data:`MIN_CORRELATION` (noise alone does not).
4. **Wheel travel** (error, :func:`check_wheel_travel`): a file that gives both
   ``wheel_travel_<side>`` and the ``wheel_centre_z`` channel gives the same motion
   twice; the travel must be the wheel-centre height up to its origin (the static
   height), within :data:`TRAVEL_AGREEMENT` of the wheel's travel span or
   :data:`TRAVEL_FLOOR`, whichever is larger (a pad's travel, the other wheel's, the
   other sign or another unit than declared is refused).
5. **Spikes** (warning): a sample away from the line through its two neighbours (in
   the drive, within a branch) by more than :data:`SPIKE_SIGMA` robust standard
   deviations of those deviations, :data:`SPIKE_SPAN` of the channel's span and
   :data:`RESOLUTION`, with its neighbours pulled the other way (the signature of one
   bad sample, not of a kink of the curve).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.core.options import check_keywords
from suspenv.measurements.errors import RecordingError
from suspenv.measurements.knc import DRIVE_UNIT, OPPOSED_TESTS, SIDES

#: keys of ``knc.toml`` (docs/knc.md "Measured K&C format")
MANIFEST_KEYS = (
    "format",
    "version",
    "name",
    "source",
    "sign_convention",
    "travel_drive",
    "wheels",
    "channels",
    "notes",
    "noise",
    "tests",
)
#: keys of a ``[tests.<test>]`` table (``amplitude`` and ``steps`` informative)
TEST_KEYS = ("file", "amplitude", "steps")

#: quantity -> (largest plausible |value| [SI], why). Each about ten times the largest
#: real value of a road vehicle's K&C test (Milliken & Milliken, "Race Car Vehicle
#: Dynamics", ch. 17-19; Gillespie, "Fundamentals of Vehicle Dynamics", ch. 7).
LIMITS: dict[str, tuple[float, str]] = {
    "travel": (0.5, "a wheel travels at most about 0.3 m bump to rebound, a rack 0.1 m"),
    "length": (10.0, "wheel, contact-point and strut positions lie within 5 m of the origin"),
    "angle": (
        math.pi / 2,
        "road-wheel toe, camber, caster and KPI stay within 60 deg even at full lock",
    ),
    "force": (1e5, "a K&C rig loads a wheel with at most a few tens of kN"),
    "moment": (1e4, "aligning moments at a contact patch stay below about 1e3 N*m"),
}
#: quantity -> the smallest plausible reach of a test's drive [SI]: below it the declared
#: unit is too small (a stroke of 0.04 labelled mm is 40 mm written in metres)
MIN_DRIVE: dict[str, float] = {"travel": 1e-3, "force": 10.0, "moment": 1.0}
#: unit the messages quote a quantity in: (unit, its size in SI)
SHOWN: dict[str, tuple[str, float]] = {
    "travel": ("mm", 1e-3),
    "length": ("mm", 1e-3),
    "angle": ("deg", math.pi / 180),
    "force": ("N", 1.0),
    "moment": ("N*m", 1.0),
}
#: narrowest plausible track (left minus right y) [m]: karts and formula student cars
#: run about 1 m
MIN_TRACK = 0.2
#: |correlation| of a channel with the drive that counts as a direction
MIN_CORRELATION = 0.5
#: travel tests: sign of the right wheel's motion with the left pad's stroke (0: less
#: than the left wheel's, the ``single`` test)
RIGHT_WHEEL_SENSE = {"parallel": 1, "opposite": -1, "single": 0}
#: force tests: the channel the load moves along its own direction
LOADED_POINT = {"lateral": "contact_y", "longitudinal": "contact_x", "traction": "wheel_centre_x"}
#: wheel travel against wheel_centre_z: largest disagreement as a fraction of the wheel's
#: travel span (a pad's stroke written as wheel travel, about 1.25 times the wheel
#: centre's on a road car, is off by about 12 % of the span at the ends) ...
TRAVEL_AGREEMENT = 0.05
#: ... or this many metres (50 times a K&C rig's 0.01 mm resolution: a small span, as
#: the still wheel of single travel or any wheel of a force test, is noise)
TRAVEL_FLOOR = 0.5e-3
#: a spike: this many robust standard deviations of the neighbour-line deviations ...
SPIKE_SIGMA = 20.0
#: ... and this fraction of the channel's span ...
SPIKE_SPAN = 0.02
#: ... and a tenth of a K&C rig's resolution (0.01 mm, 0.001 deg, 1 N, 0.1 N*m), so that
#: round-off of a channel that stays put (an anti-roll bar's twist under a longitudinal
#: load) is never a spike [SI]
RESOLUTION = {"travel": 1e-6, "length": 1e-6, "angle": 1.7e-6, "force": 0.1, "moment": 0.01}


@dataclass
class RigSamples:
    """One rig test's samples as the checks read them: the fields (SI, raw ISO 8855) of
    :class:`~suspenv.measurements.knc_file.MeasuredTest`, which adds the wheels and units."""

    test: str
    drive: np.ndarray
    branch: np.ndarray
    channels: dict[str, np.ndarray]


def check_manifest_keys(data: Mapping[str, Any], where: str) -> None:
    """Refuse an unknown key of ``knc.toml`` or of a ``[tests.<test>]`` table (rule 1)."""
    tables: list[tuple[str, Mapping[str, Any], tuple[str, ...]]] = [(where, data, MANIFEST_KEYS)]
    tests = data.get("tests")
    if isinstance(tests, dict):
        tables += [
            (f"{where} [tests.{t}]", spec, TEST_KEYS)
            for t, spec in tests.items()
            if isinstance(spec, dict)
        ]
    for owner, table, keys in tables:
        try:
            check_keywords(owner, table, keys, "key")
        except ValidationError as exc:
            raise RecordingError(str(exc)) from None


def check_tests(
    tests: Mapping[str, RigSamples], files: Mapping[str, str], quantity: Mapping[str, str]
) -> list[str]:
    """Rules 2 to 4 on the loaded tests (SI, raw ISO 8855); raises on the first error and
    returns the warnings. ``files``: test -> its CSV's name; ``quantity``: channel ->
    ``"length"``, ``"angle"``, ``"force"`` or ``"moment"``."""
    warnings: list[str] = []
    for name, t in tests.items():
        where = f"{files.get(name, name)} (test {name!r})"
        _check_magnitudes(where, t, quantity)
        _check_track(where, t)
        for view in _wheel_views(t):
            _check_directions(where, view)
        warnings += _spikes(where, t, quantity)
    return warnings


def _wheel_views(t: RigSamples) -> list[RigSamples]:
    """The test itself; an opposed test (:data:`OPPOSED_TESTS`) is its in-phase test
    one wheel at a time, each wheel driven by its own load (the right wheel's is the
    in-phase load negated), so that every wheel meets the in-phase test's direction
    rules (the other wheel's channels NaN, which the rules skip)."""
    in_phase = OPPOSED_TESTS.get(t.test)
    if in_phase is None:
        return [t]
    return [
        RigSamples(
            in_phase,
            -np.asarray(t.drive) if side == "right" else np.asarray(t.drive),
            t.branch,
            {c: np.where(np.arange(2) == w, v, np.nan) for c, v in t.channels.items()},
        )
        for w, side in enumerate(SIDES)
    ]


# ------------------------------------------------------------------ magnitudes
def _drive_quantity(test: str) -> str:
    unit = DRIVE_UNIT.get(test, "m")
    return {"m": "travel", "N": "force", "N*m": "moment"}[unit]


def _shown(value: float, quantity: str) -> str:
    unit, size = SHOWN[quantity]
    return f"{value / size:.6g} {unit}"


def _columns(t: RigSamples, quantity: Mapping[str, str]) -> Iterable[tuple[str, np.ndarray, str]]:
    """(column words, values (P,) [SI], quantity) of the drive and every channel's wheel."""
    yield "the drive", np.asarray(t.drive, float), _drive_quantity(t.test)
    for ch, v in t.channels.items():
        q = quantity.get(ch, "length")
        for w, side in enumerate(SIDES):
            yield f"{ch}_{side}", np.asarray(v[:, w], float), q


def _check_magnitudes(where: str, t: RigSamples, quantity: Mapping[str, str]) -> None:
    for what, v, q in _columns(t, quantity):
        ok = v[np.isfinite(v)]
        if not ok.size:
            continue
        limit, why = LIMITS[q]
        i = int(np.argmax(np.where(np.isfinite(v), np.abs(v), -1.0)))
        if abs(v[i]) > limit:
            raise RecordingError(
                f"{where}: {what} reaches {_shown(float(v[i]), q)} at data row {i + 1}, an "
                f"implausible {q}: the limit is {_shown(limit, q)} ({why}); check the "
                "declared unit (mm labelled m, deg labelled rad) or drop the row"
            )
    q = _drive_quantity(t.test)
    reach = float(np.max(np.abs(t.drive)))
    if q in MIN_DRIVE and reach < MIN_DRIVE[q]:
        raise RecordingError(
            f"{where}: the drive reaches only {_shown(reach, q)}, less than the "
            f"{_shown(MIN_DRIVE[q], q)} any K&C test moves; check the declared unit (m "
            "labelled mm, N labelled kN)"
        )


# ------------------------------------------------------------------ sides
def _check_track(where: str, t: RigSamples) -> None:
    for ch in ("wheel_centre_y", "contact_y"):
        v = t.channels.get(ch)
        if v is None or not np.isfinite(v).all():
            continue  # one wheel measured: no track
        track = float(np.median(v[:, 0] - v[:, 1]))
        if track >= MIN_TRACK:
            continue
        cause = (
            "the left and right columns are swapped, or y is negated (ISO 8855: y left positive)"
            if track < -MIN_TRACK  # a mirrored right wheel gives about 0, of either sign
            else "the right wheel's values are mirrored outboard (the format holds raw y: "
            "left +745 mm, right -745 mm)"
        )
        raise RecordingError(
            f"{where}: {ch}_left - {ch}_right (the track) must be at least "
            f"{MIN_TRACK * 1e3:g} mm, but is {track * 1e3:.6g} mm: {cause}"
        )


def _correlation(x: np.ndarray, y: np.ndarray) -> float:
    """Pearson correlation of y with x (0 for a constant or non-finite y)."""
    if not np.isfinite(y).all() or np.ptp(y) == 0 or np.ptp(x) == 0:
        return 0.0
    with np.errstate(all="ignore"):
        c = float(np.corrcoef(x, y)[0, 1])
    return c if math.isfinite(c) else 0.0


def _slope(x: np.ndarray, y: np.ndarray) -> float:
    xc = x - x.mean()
    return float(np.dot(xc, y - y.mean()) / np.dot(xc, xc))


def _check_directions(where: str, t: RigSamples) -> None:
    d = np.asarray(t.drive, float)
    if t.test in RIGHT_WHEEL_SENSE and "wheel_centre_z" in t.channels:
        _check_travel(where, t.test, d, t.channels["wheel_centre_z"])
    ch = LOADED_POINT.get(t.test)
    if ch is None or ch not in t.channels:
        return
    for w, side in enumerate(SIDES):
        c = _correlation(d, t.channels[ch][:, w])
        if c < -MIN_CORRELATION:
            raise RecordingError(
                f"{where}: {ch}_{side} must move along the force (+ with the drive; a "
                f"compliance is positive definite), but moves against it (correlation "
                f"{c:+.2f}): the sign of the force or of {ch} is against ISO 8855, or the "
                "left and right columns are swapped"
            )


def _check_travel(where: str, test: str, d: np.ndarray, z: np.ndarray) -> None:
    left, right = z[:, 0], z[:, 1]
    c_left, c_right = _correlation(d, left), _correlation(d, right)
    sense = RIGHT_WHEEL_SENSE[test]
    wrong = []
    if np.isfinite(left).all() and c_left < MIN_CORRELATION:
        wrong.append(f"the left wheel must rise with the stroke (correlation {c_left:+.2f})")
    if np.isfinite(right).all() and sense and sense * c_right < MIN_CORRELATION:
        word = "rise" if sense > 0 else "fall"
        wrong.append(f"the right wheel must {word} with it (correlation {c_right:+.2f})")
    if not sense and np.isfinite(z).all() and abs(_slope(d, right)) > abs(_slope(d, left)):
        wrong.append(
            f"the right wheel must move less than the driven left one (slopes "
            f"{_slope(d, right):+.3g} and {_slope(d, left):+.3g})"
        )
    if wrong:
        raise RecordingError(
            f"{where}: the left pad drives the {test} test (bump +), so {'; '.join(wrong)}: "
            "the left and right columns are swapped, or the stroke or wheel travel sign is "
            "against ISO 8855 (z up, bump positive)"
        )


def check_wheel_travel(where: str, travel: np.ndarray, z: np.ndarray) -> None:
    """Rule 4: the ``wheel_travel_<side>`` columns ``travel`` (P, 2) [m] against the
    ``wheel_centre_z`` channel ``z`` (P, 2) [m] (ISO 8855, up positive) of one test; a
    wheel not measured (NaN) is skipped. Raises :class:`RecordingError` naming the
    column, the data row and the disagreement."""
    for w, side in enumerate(SIDES):
        t, h = np.asarray(travel[:, w], float), np.asarray(z[:, w], float)
        if not (np.isfinite(t).all() and np.isfinite(h).all()):
            continue
        dev = (t - h) - float(np.median(t - h))  # the origins may differ
        limit = max(TRAVEL_AGREEMENT * float(np.ptp(h)), TRAVEL_FLOOR)
        i = int(np.argmax(np.abs(dev)))
        if abs(dev[i]) > limit:
            raise RecordingError(
                f"{where}: wheel_travel_{side} must be wheel_centre_z_{side} from its static "
                f"height (the same motion up to an offset), but differs from it by "
                f"{_shown(float(dev[i]), 'travel')} at data row {i + 1} (the limit is "
                f"{_shown(limit, 'travel')}: {TRAVEL_AGREEMENT:.0%} of the wheel's travel span "
                f"or {_shown(TRAVEL_FLOOR, 'travel')}): the travel is the pad's, the other "
                "wheel's, of the other sign, or in another unit than declared"
            )


# ------------------------------------------------------------------ spikes
def _deviations(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Deviation of each interior sample from the line through its neighbours (NaN at
    the ends)."""
    dev = np.full(y.shape, np.nan)
    if y.size >= 3:
        with np.errstate(all="ignore"):
            a = (x[1:-1] - x[:-2]) / (x[2:] - x[:-2])
            dev[1:-1] = y[1:-1] - (y[:-2] + a * (y[2:] - y[:-2]))
    return dev


def _spikes(where: str, t: RigSamples, quantity: Mapping[str, str]) -> list[str]:
    out = []
    d = np.asarray(t.drive, float)
    for what, y, q in list(_columns(t, quantity))[1:]:  # every channel's wheel, not the drive
        if not np.isfinite(y).all() or np.ptp(y) == 0:
            continue
        dev = np.full(y.shape, np.nan)
        for b in (0, 1, 2):
            sel = np.flatnonzero(t.branch == b)
            dev[sel] = _deviations(d[sel], y[sel])
        out += _spike_rows(where, what, y, dev, q)
    return out


def _spike_rows(where: str, what: str, y: np.ndarray, dev: np.ndarray, q: str) -> list[str]:
    finite = dev[np.isfinite(dev)]
    if finite.size < 3:
        return []
    sigma = 1.4826 * float(np.median(np.abs(finite)))
    out = []
    for i in np.flatnonzero(np.isfinite(dev)):
        rest = np.delete(y, i)
        floor = max(SPIKE_SIGMA * sigma, SPIKE_SPAN * float(np.ptp(rest)), RESOLUTION[q])
        big = abs(dev[i]) > floor
        if not big or i == 0 or i + 1 >= y.size:
            continue
        nb = dev[[i - 1, i + 1]]
        nb = nb[np.isfinite(nb)]  # a neighbour at a branch's end has no deviation
        if nb.size and np.all(nb * dev[i] < -0.25 * dev[i] ** 2):
            ratio = abs(dev[i]) / sigma if sigma else math.inf
            out.append(
                f"{where}: {what} at data row {i + 1} stands {_shown(float(dev[i]), q)} off "
                f"the line through its neighbours ({ratio:.3g} robust standard deviations): "
                "a spike; check the row"
            )
    return out
