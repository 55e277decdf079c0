"""The measured-K&C format: one folder, a ``knc.toml`` manifest and one CSV per rig test.

Simulated (``suspenv knc``) and measured K&C data share this format, so they load into
the same objects (:class:`KncMeasurement` of :class:`MeasuredTest`) and round-trip.
The full description, with an example, is ``docs/knc.md`` "Measured K&C format".

Folder layout::

    knc.toml          format = "suspenv-knc", version = 1, name, source,
                      sign_convention = "ISO 8855", travel_drive, wheels, channels,
                      [tests.<test>] file = "<file>.csv", optional [noise], notes
    <file>.csv        one row per settled rig step: step, branch, the drive column,
                      wheel_travel_<side> [unit], <channel>_<side> [unit] ...

Frames, units and signs:

* every value in the files is ISO 8855 (x forward, y left, z up) *raw*: lateral
  positions (``wheel_centre_y``, ``contact_y``) are the y coordinate, left positive on
  both wheels, never mirrored outboard; toe positive = toe-in, camber negative = top
  inboard, caster positive = steering axis top rearward (the channels of
  :class:`suspenv.rigs.knc.KCResult`, same names, same signs);
* every column but ``step`` and ``branch`` names its unit in brackets
  (``toe_left [deg]``); the loader converts to SI (m, rad, N, N*m) with
  :data:`UNITS` (mm/cm/m/in, deg/rad/mrad, N/kN/lbf/kgf, N*m/kN*m/lbf*ft/lbf*in/kgf*m:
  those of :data:`suspenv.measurements.units.FACTORS`);
* the drive column of a test is :data:`DRIVE_COLUMN` [its unit]: the left pad's stroke
  from the static height (travel tests, bump positive; ``travel_drive = "wheel_centre"``
  when the rig drives the wheel centre instead), the force at both contact points
  (``lateral`` +y, ``longitudinal`` +x) or wheel centres (``traction`` +x), the moment
  about +z at both contact points (``aligning``) or the rack travel along +y
  (``steering``); an opposed test's force outboard at both contact points
  (``lateral_opposed``: +y left, -y right) or toe-out moment at both
  (``aligning_opposed``: +z left, -z right), the columns of its in-phase test;
* ``branch`` is 0 on the first leg design -> +end, 1 on +end -> -end, 2 on -end -> design
  (:func:`suspenv.measurements.knc.branch_index`); the drive must be strictly monotonic
  within a branch (increasing on 0 and 2, decreasing on 1).

Internally (:class:`MeasuredTest`) every channel is SI, raw ISO 8855, shape (P, 2)
(left, right), named as in ``KCResult.channels``. A one-wheel bench measurement
declares ``wheels = ["left"]`` (or ``["right"]``); the missing wheel's columns are NaN,
and :func:`load_measurement` refuses it unless ``both_wheels=False`` (compliance
analysis; identification needs both wheels).

Noise: ``[noise] toe = { sigma = 0.01, unit = "deg" }`` declares a channel's
measurement noise (one standard deviation); every channel without one gets the
estimate of :func:`estimate_noise` (``noise_source = "estimated"``).
"""

from __future__ import annotations

import csv
import io
import math
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from suspenv.core.atomic import write_file
from suspenv.core.errors import ValidationError
from suspenv.core.tomlfile import read_toml, toml_value
from suspenv.measurements import knc as _knc
from suspenv.measurements.errors import RecordingError
from suspenv.measurements.knc_checks import (
    RigSamples,
    check_manifest_keys,
    check_tests,
    check_wheel_travel,
)
from suspenv.measurements.limits import check_text, read_limit
from suspenv.measurements.recording import nonfinite_run
from suspenv.measurements.units import FACTORS, unit_key

if TYPE_CHECKING:  # a type only: measurements sit below rigs (tests/test_architecture.py)
    from suspenv.rigs.knc import KCResult

FORMAT = "suspenv-knc"
VERSION = 1
#: the manifest's file name inside a measurement folder
MANIFEST = "knc.toml"
SIGN_CONVENTION = "ISO 8855"
SIDES = _knc.SIDES

#: SI unit -> quantity
QUANTITY = {"m": "length", "rad": "angle", "N": "force", "N*m": "moment"}
#: test -> (drive column name, quantity of its unit), by the test's drive unit
#: (:data:`suspenv.measurements.knc.DRIVE_UNIT`; an opposed test as its in-phase one)
_COLUMN = {"m": "stroke", "N": "force", "N*m": "moment"}
DRIVE_COLUMN = {t: (_COLUMN[u], QUANTITY[u]) for t, u in _knc.DRIVE_UNIT.items()}
DRIVE_COLUMN["steering"] = ("rack_travel", "length")
#: quantity -> the unit ``suspenv knc`` writes (the project's edge units)
EDGE_UNIT = {"length": "mm", "angle": "deg", "force": "N", "moment": "N*m"}

#: units the loader converts: unit -> (factor to SI, SI unit), the lengths, angles, forces
#: and moments of :data:`suspenv.measurements.units.FACTORS`
UNITS: dict[str, tuple[float, str]] = {u: f for u, f in FACTORS.items() if f[1] in QUANTITY}

#: channels of the format (``KCResult.channels`` names) -> quantity
CHANNELS: dict[str, str] = {
    "toe": "angle",
    "camber": "angle",
    "caster": "angle",
    "kpi": "angle",
    "wheel_centre_x": "length",
    "wheel_centre_y": "length",
    "wheel_centre_z": "length",
    "contact_x": "length",
    "contact_y": "length",
    "contact_z": "length",
    "pad_z": "length",
    "tyre_fz": "force",
    "handwheel_torque": "moment",
    "spring_force": "force",
    "spring_length": "length",
    "scrub_radius": "length",
    "trail": "length",
    "arb_twist": "angle",
    "knuckle_pitch": "angle",
    "strut_length": "length",
}
#: the wheel-centre travel column (from the static position, bump positive)
TRAVEL_COLUMN = "wheel_travel"
#: fewest rows of a test
MIN_SAMPLES = 5
#: significant digits ``write_measurement`` writes (``%.15g``: 5e-16 relative, and a
#: value read in deg is written back as it was read). Fewer are not enough for the
#: objectives that are curvatures (10 digits move ``opp_roll_rate`` by 6e-4 relative).
DIGITS = 15
#: an estimated noise below this fraction of the channel's peak-to-peak is raised to it
NOISE_FLOOR_REL = 1e-9
#: ``travel_drive`` values: what the rig drives in a travel test
TRAVEL_DRIVES = ("pad", "wheel_centre")

_HEADER = re.compile(r"^\s*([A-Za-z_][A-Za-z0-9_]*)\s*\[([^\[\]]+)\]\s*$")


# ------------------------------------------------------------------ data
@dataclass
class MeasuredTest(RigSamples):
    """One rig test's samples (SI, raw ISO 8855).

    Attributes:
        test: the test name (:data:`suspenv.measurements.knc.RIG_TESTS`).
        drive: (P,) the test's input: left pad stroke [m] (travel tests), force [N]
            (lateral, longitudinal, traction), moment about +z [N*m] (aligning), rack
            travel along +y [m] (steering).
        branch: (P,) int, 0 first leg design -> +end, 1 +end -> -end, 2 -end -> design.
        channels: name -> (P, 2) [SI], columns (left, right), the names and signs of
            ``KCResult.channels``; a wheel that was not measured holds NaN.
        wheels: the measured wheels (``("left", "right")`` or one of them).
        units: column -> the unit the file declared (empty for data made in memory).
    """

    wheels: tuple[str, ...] = SIDES
    units: dict[str, str] = field(default_factory=dict)

    @property
    def samples(self) -> int:
        return int(self.drive.size)

    def uniform_steps(self) -> int | None:
        """``steps`` when the samples are exactly a rig loop of
        :func:`~suspenv.measurements.knc.loop_path` (P = 2 steps + 1, branches of
        :func:`branch_index`, drive on the uniform grid to 1e-6 of the amplitude), else
        None."""
        p = self.samples
        if p < 5 or p % 2 == 0 or ((p - 1) // 2) % 2:
            return None
        steps = (p - 1) // 2
        if not np.array_equal(self.branch, _knc.branch_index(steps).astype(int)):
            return None
        amp = float(np.max(np.abs(self.drive)))
        if not amp > 0:
            return None
        grid = np.linspace(-amp, amp, steps + 1)
        ok = np.allclose(self.drive, grid[_knc.loop_path(steps)], rtol=0.0, atol=1e-6 * amp)
        return steps if ok else None

    def loop(
        self, steps: int | None = None
    ) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
        """The test on a symmetric uniform grid as the rig's loop: ``(grid (steps + 1,),
        path (2 steps + 1,) grid indices, channels name -> (1, 2 steps + 1, 2))``, the
        fields of a :class:`~suspenv.rigs.knc.KCResult` of one design
        (:func:`suspenv.rigs.knc_measured.on_grid` makes it one).

        When the samples already are a uniform loop (as ``suspenv knc`` writes) and
        ``steps`` is None or the same, the channels are taken as they are (exact).
        Otherwise each branch (ascending: branches 2 and 0; descending: branch 1; each
        joined by the other's turning point) is linearly interpolated at the grid
        ``linspace(-A, A, steps + 1)``, ``A`` the smaller of the largest positive and
        negative drive (so nothing is extrapolated beyond the other end); a branch with
        fewer than two samples is taken equal to the other (a one-way sweep).
        ``steps`` defaults to the even number nearest the larger branch's sample count
        less one (at least 6, the objectives' fit window).
        """
        own = self.uniform_steps()
        if own is not None and steps in (None, own):
            amp = float(np.max(np.abs(self.drive)))
            grid = np.linspace(-amp, amp, own + 1)
            chans = {k: v[None].copy() for k, v in self.channels.items()}
            return grid, _knc.loop_path(own), chans
        up_sel = self.branch != 1
        down_sel = self.branch == 1
        if steps is None:
            n = max(int(up_sel.sum()), int(down_sel.sum()))
            steps = max(6, 2 * round((n - 1) / 2))
        if steps < 2 or steps % 2:
            raise ValidationError(f"`steps` must be even and >= 2, but got steps={steps}")
        hi, lo = float(self.drive.max()), float(self.drive.min())
        amp = min(hi, -lo)
        if not amp > 0:
            raise ValidationError(
                f"test {self.test!r}: the drive must span both signs to be put on a grid "
                f"symmetric about the static position, but it spans [{lo:g}, {hi:g}]"
            )
        grid = np.linspace(-amp, amp, steps + 1)
        up_idx = _with_turning_point(self.drive, up_sel, down_sel)
        down_idx = _with_turning_point(self.drive, down_sel, up_sel)
        if up_idx.size < 2:
            up_idx = down_idx
        if down_idx.size < 2:
            down_idx = up_idx
        i0 = steps // 2
        chans = {}
        for name, v in self.channels.items():
            up = _interp(self.drive[up_idx], v[up_idx], grid)
            down = _interp(self.drive[down_idx], v[down_idx], grid)
            # the loop: up at grid i0..steps, down at steps-1..0, up at 1..i0
            loop = np.concatenate([up[i0:], down[:-1][::-1], up[1 : i0 + 1]])
            chans[name] = loop[None]
        return grid, _knc.loop_path(steps), chans


def _with_turning_point(drive: np.ndarray, sel: np.ndarray, other: np.ndarray) -> np.ndarray:
    """Indices of ``sel`` plus the other branch's extreme samples that extend its range
    (the turning points both branches share)."""
    idx = np.flatnonzero(sel)
    oth = np.flatnonzero(other)
    if idx.size == 0 or oth.size == 0:
        return idx
    extra = []
    j_hi = oth[np.argmax(drive[oth])]
    if drive[j_hi] > drive[idx].max():
        extra.append(j_hi)
    j_lo = oth[np.argmin(drive[oth])]
    if drive[j_lo] < drive[idx].min():
        extra.append(j_lo)
    return np.r_[idx, np.array(extra, int)]


def _interp(x: np.ndarray, y: np.ndarray, at: np.ndarray) -> np.ndarray:
    """Linear interpolation of (x, y (k, 2)) at ``at``, per wheel (NaN wheels stay NaN)."""
    order = np.argsort(x, kind="stable")
    xs, ys = x[order], y[order]
    return np.stack([np.interp(at, xs, ys[:, w]) for w in range(ys.shape[1])], axis=-1)


@dataclass
class KncMeasurement:
    """A measured (or simulated) K&C data set of one axle.

    Attributes:
        name: the vehicle's or measurement's name.
        tests: test -> :class:`MeasuredTest`.
        noise: channel -> one standard deviation of its measurement noise [SI].
        noise_source: channel -> ``"declared"`` (from ``[noise]``) or ``"estimated"``
            (:func:`estimate_noise`).
        meta: ``source``, ``sign_convention``, ``travel_drive``, ``wheels``,
            ``channels``, ``files`` (test -> file name), ``amplitude`` (test -> SI),
            ``steps`` (test -> int, rig loops only), ``notes`` ...
    """

    name: str
    tests: dict[str, MeasuredTest]
    noise: dict[str, float]
    noise_source: dict[str, str]
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def wheels(self) -> tuple[str, ...]:
        """The measured wheels: ``meta["wheels"]``, else the first test's."""
        if "wheels" in self.meta:
            return tuple(self.meta["wheels"])
        return next(iter(self.tests.values())).wheels if self.tests else SIDES

    @property
    def channels(self) -> list[str]:
        """The channels of the tests (sorted), which every test holds."""
        return sorted({c for t in self.tests.values() for c in t.channels})


# ------------------------------------------------------------------ noise
def _local_residuals(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Residuals of sample ``i + 1`` from the parabola through its neighbours ``i``,
    ``i + 2`` and ``i + 3`` (Lagrange weights ``L`` in the drive ``x``), scaled to unit
    variance for white noise: ``(y_{i+1} - sum L_j y_j) / sqrt(1 + sum L_j^2)``. On a
    uniform grid this is the third difference over sqrt(20): a straight line and a
    parabola leave nothing, a smooth curve only its third derivative x spacing^3."""
    if x.size < 4:
        return np.empty(0)
    x0, x1, x2, x3 = x[:-3], x[1:-2], x[2:-1], x[3:]
    with np.errstate(divide="ignore", invalid="ignore"):
        L0 = (x1 - x2) * (x1 - x3) / ((x0 - x2) * (x0 - x3))
        L2 = (x1 - x0) * (x1 - x3) / ((x2 - x0) * (x2 - x3))
        L3 = (x1 - x0) * (x1 - x2) / ((x3 - x0) * (x3 - x2))
        r = (y[1:-2] - L0 * y[:-3] - L2 * y[2:-1] - L3 * y[3:]) / np.sqrt(
            1.0 + L0 * L0 + L2 * L2 + L3 * L3
        )
    return r[np.isfinite(r)]


def estimate_noise(tests: Iterable[MeasuredTest]) -> dict[str, float]:
    """Noise sigma [SI] per channel from the data alone.

    Estimator: along every branch of every test and wheel (samples in file order), the
    residuals of :func:`_local_residuals` (each sample from the parabola through its
    neighbours, unit variance for white noise; a branch needs 4 samples); sigma = 1.4826
    x the median of their absolute values pooled over tests, wheels and branches (the
    median absolute deviation: consistent for Gaussian noise, robust to a few outliers).
    Noise-free smooth data give a small positive value rather than zero; an estimate
    below :data:`NOISE_FLOOR_REL` x the channel's peak-to-peak (or 1e-15 when it is
    constant) is raised to it, so a weight is finite.
    """
    pooled: dict[str, list[np.ndarray]] = {}
    spread: dict[str, float] = {}
    for m in tests:
        for name, v in m.channels.items():
            for w in range(v.shape[1]):
                col = v[:, w]
                if not np.isfinite(col).all():
                    continue
                spread[name] = max(spread.get(name, 0.0), float(np.ptp(col)))
                for b in (0, 1, 2):
                    sel = m.branch == b
                    pooled.setdefault(name, []).append(_local_residuals(m.drive[sel], col[sel]))
    out = {}
    for name, parts in pooled.items():
        r = np.concatenate(parts) if parts else np.empty(0)
        sigma = 1.4826 * float(np.median(np.abs(r))) if r.size else 0.0
        floor = NOISE_FLOOR_REL * spread.get(name, 0.0) or 1e-15
        out[name] = max(sigma, floor)
    return out


# ------------------------------------------------------------------ from rig results
def from_results(
    results: Mapping[str, KCResult],
    name: str,
    noise: Mapping[str, float] | None = None,
    row: int = 0,
    *,
    source: str = "suspenv virtual K&C rig",
    travel_drive: str = "pad",
) -> KncMeasurement:
    """Rig results (:func:`suspenv.rigs.knc.run_tests`) as a measurement.

    ``travel_drive``: what the travel tests drove (:data:`TRAVEL_DRIVES`, the
    ``run_tests`` keyword of the results), kept in the manifest.

    Design ``row`` of every result; the channels of :data:`CHANNELS` the result holds
    (SI, raw ISO 8855, unchanged); drive = ``grid[path]``; branch =
    :func:`~suspenv.measurements.knc.branch_index`. ``noise`` [SI]: declared sigma per
    channel; the other channels get :func:`estimate_noise` (for noise-free simulated
    data, its small floor). A design whose rig test failed is refused.
    """
    if travel_drive not in TRAVEL_DRIVES:
        raise ValidationError(
            f"`travel_drive` must be one of {TRAVEL_DRIVES}, but got {travel_drive!r}"
        )
    tests: dict[str, MeasuredTest] = {}
    amplitude: dict[str, float] = {}
    steps_of: dict[str, int] = {}
    _knc.check_rig_tests(tuple(results))
    for test, res in results.items():
        if not 0 <= row < res.ok.size:
            raise ValidationError(
                f"`0 <= row < {res.ok.size}` must hold (designs in the result), but got row={row}"
            )
        if not res.ok[row]:
            raise ValidationError(
                f"test {test!r}: design {row} failed on the rig ({res.messages[row]}); "
                "a failed test is not a measurement"
            )
        steps = res.grid.size - 1
        chans = {k: np.array(v[row], float) for k, v in res.channels.items() if k in CHANNELS}
        tests[test] = MeasuredTest(
            test,
            np.array(res.grid[res.path], float),
            _knc.branch_index(steps).astype(int),
            chans,
        )
        amplitude[test] = float(res.grid[-1])
        steps_of[test] = steps
    return _assemble(
        name,
        tests,
        dict(noise or {}),
        {
            "source": source,
            "sign_convention": SIGN_CONVENTION,
            "travel_drive": travel_drive,
            "wheels": list(SIDES),
            "amplitude": amplitude,
            "steps": steps_of,
        },
    )


def _assemble(
    name: str, tests: dict[str, MeasuredTest], declared: dict[str, float], meta: dict[str, Any]
) -> KncMeasurement:
    channels = sorted({c for m in tests.values() for c in m.channels})
    for ch, sigma in declared.items():
        if ch not in CHANNELS:
            raise ValidationError(
                f"noise: unknown channel {ch!r}; known channels are {list(CHANNELS)}"
            )
        if not (math.isfinite(sigma) and sigma > 0):
            raise ValidationError(f"noise {ch}: `sigma > 0` (finite) must hold, but got {sigma!r}")
    missing = [c for c in channels if c not in declared]
    estimated = estimate_noise(tests.values()) if missing else {}
    noise = {c: float(declared[c]) if c in declared else estimated[c] for c in channels}
    source = {c: "declared" if c in declared else "estimated" for c in channels}
    meta = {"channels": channels, **meta}
    return KncMeasurement(name, tests, noise, source, meta)


# ------------------------------------------------------------------ writing
def _fmt(v: float) -> str:
    return "" if not math.isfinite(v) else f"{v:.{DIGITS}g}"


def test_columns(m: MeasuredTest, wheels: tuple[str, ...] = SIDES) -> tuple[list[str], np.ndarray]:
    """Column headers and rows (P, columns) of one test in edge units (mm, deg, N, N*m)."""
    col, quantity = DRIVE_COLUMN[m.test]
    unit, size = edge_unit(quantity)
    cols = ["step", "branch", f"{col} [{unit}]"]
    data = [np.arange(m.samples, dtype=float), m.branch.astype(float), m.drive / size]
    wi = [SIDES.index(s) for s in wheels]
    if "wheel_centre_z" in m.channels:
        z = m.channels["wheel_centre_z"]
        static = int(np.argmin(np.abs(m.drive)))  # the first with the smallest |drive|
        for w in wi:
            cols.append(f"{TRAVEL_COLUMN}_{SIDES[w]} [mm]")
            data.append((z[:, w] - z[static, w]) / 1e-3)
    for name in CHANNELS:
        if name not in m.channels:
            continue
        unit, size = edge_unit(CHANNELS[name])
        for w in wi:
            cols.append(f"{name}_{SIDES[w]} [{unit}]")
            data.append(m.channels[name][:, w] / size)
    return cols, np.column_stack(data)


def edge_unit(quantity: str) -> tuple[str, float]:
    """(unit, its size [SI]) of a quantity in the units ``suspenv knc`` writes and prints
    (:data:`EDGE_UNIT`): a value [SI] divided by the size is in that unit."""
    unit = EDGE_UNIT[quantity]
    return unit, UNITS[unit][0]


def write_test_csv(m: MeasuredTest, path: Path, wheels: tuple[str, ...] = SIDES) -> Path:
    """One test's CSV (:func:`test_columns`, :data:`DIGITS` significant digits)."""
    cols, rows = test_columns(m, wheels)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(cols)
    for r in rows:
        w.writerow([str(int(r[0])), str(int(r[1])), *(_fmt(v) for v in r[2:])])
    return write_file(path, buf.getvalue())


def manifest_text(m: KncMeasurement, files: Mapping[str, str]) -> str:
    """The ``knc.toml`` text of ``m`` with test -> CSV file name ``files``."""
    lines = [
        '# measured-K&C data, see docs/knc.md "Measured K&C format"',
        f"format = {toml_value(FORMAT)}",
        f"version = {VERSION}",
        f"name = {toml_value(m.name)}",
        f"source = {toml_value(m.meta.get('source', ''))}",
        f"sign_convention = {toml_value(SIGN_CONVENTION)}  # x forward, y left, z up; "
        "lateral values raw y (not outboard)",
        f"travel_drive = {toml_value(m.meta.get('travel_drive', 'pad'))}  # what a travel "
        "test's 'stroke' column is: the left pad or the left wheel centre",
        f"wheels = {toml_value(list(m.wheels))}",
        f"channels = {toml_value(m.channels)}",
    ]
    if m.meta.get("notes"):
        lines.append(f"notes = {toml_value(m.meta['notes'])}")
    declared = {c: s for c, s in m.noise.items() if m.noise_source.get(c) == "declared"}
    if declared:
        lines += ["", "[noise]  # one standard deviation of the measurement noise"]
        for c, s in declared.items():
            unit, size = edge_unit(CHANNELS[c])
            lines.append(f'{c} = {{ sigma = {_fmt(s / size)}, unit = "{unit}" }}')
    for test in m.tests:
        lines += ["", f"[tests.{test}]", f"file = {toml_value(files[test])}"]
        amp = m.meta.get("amplitude", {}).get(test)
        if amp is not None:
            col, quantity = DRIVE_COLUMN[test]
            unit, size = edge_unit(quantity)
            lines.append(f"amplitude = {_fmt(amp / size)}  # [{unit}] of '{col}'")
        steps = m.meta.get("steps", {}).get(test)
        if steps is not None:
            lines.append(f"steps = {int(steps)}")
    return "\n".join(lines) + "\n"


def write_measurement(
    m: KncMeasurement, folder: Path, file_names: Mapping[str, str] | None = None
) -> list[Path]:
    """Write ``folder/knc.toml`` and one CSV per test (default ``<test>.csv``; the
    names are made plain file names inside ``folder``). Returns the paths written,
    the manifest first. Declared noise is written to ``[noise]``; estimated noise is
    not (the loader estimates it again)."""
    from suspenv.measurements.paths import output_file

    for test, mt in m.tests.items():
        if sorted(mt.channels) != m.channels:
            raise ValidationError(
                f"write_measurement: every test must hold the same channels {m.channels}, but "
                f"{test!r} holds {sorted(mt.channels)}"
            )
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    files = {t: output_file(folder, (file_names or {}).get(t, f"{t}.csv")).name for t in m.tests}
    paths = [write_file(folder / MANIFEST, manifest_text(m, files))]
    return paths + [write_test_csv(mt, folder / files[t], m.wheels) for t, mt in m.tests.items()]


# ------------------------------------------------------------------ loading
def _unit(unit: str, where: str) -> tuple[float, str]:
    """(factor to SI, SI unit) of ``unit`` (read by :func:`~suspenv.measurements.units.unit_key`);
    unknown -> refused naming ``where``."""
    key = unit_key(unit)
    if key is None or key not in UNITS:
        raise RecordingError(
            f"{where}: unknown unit {unit!r}; the format's units are {sorted(UNITS)}"
        )
    return UNITS[key]


def _refuse(where: str, rule: str) -> RecordingError:
    return RecordingError(f"{where}: {rule}")


def _check_quantity(where: str, unit: str, si: str, quantity: str) -> None:
    if QUANTITY.get(si) != quantity:
        raise _refuse(
            where,
            f"the unit must be a {quantity} ({EDGE_UNIT[quantity]}, ...), but got {unit!r} "
            f"(a {QUANTITY.get(si, si)})",
        )


def _manifest(path: Path) -> tuple[Path, dict[str, Any]]:
    """(folder, manifest table) of a measurement folder or its ``knc.toml``, every key
    of the manifest checked (:func:`_check_manifest`)."""
    path = Path(path)
    folder = path if path.is_dir() else path.parent
    toml = folder / MANIFEST if path.is_dir() else path
    if not toml.is_file():
        raise RecordingError(
            f"measured-K&C data {str(path)!r}: no {MANIFEST} found (a measurement is a folder "
            f"holding {MANIFEST} and one CSV per test)"
        )
    data = read_toml(toml, f"measured-K&C manifest {str(toml)!r}")
    _check_manifest(data, toml.name)
    return folder, data


def _check_manifest(data: dict[str, Any], where: str) -> None:
    """The manifest's rules, in the order a reader meets its keys."""
    check_manifest_keys(data, where)
    _check_identity(data, where)
    _check_wheels(data.get("wheels", list(SIDES)), where)
    chans = _check_channel_list(data.get("channels"), where)
    _check_test_table(data.get("tests"), where)
    _check_noise_table(data.get("noise", {}), chans, where)


def _check_identity(data: dict[str, Any], where: str) -> None:
    """Format, version, sign convention, the text keys and ``travel_drive``."""
    for key, value, note in (
        ("format", FORMAT, ""),
        ("version", VERSION, ""),
        ("sign_convention", SIGN_CONVENTION, " (x forward, y left, z up)"),
    ):
        if data.get(key) != value:
            raise _refuse(where, f"{key} must be {value!r}{note}, but got {data.get(key)!r}")
    for key in ("name", "source", "notes"):
        if key in data and not isinstance(data[key], str):
            raise _refuse(where, f"{key!r} must be text, but got {data[key]!r}")
    if not isinstance(data.get("name"), str) or not data["name"]:
        raise _refuse(where, f"'name' must be non-empty text, but got {data.get('name')!r}")
    drive = data.get("travel_drive", "pad")
    if drive not in TRAVEL_DRIVES:
        raise _refuse(where, f"travel_drive must be one of {TRAVEL_DRIVES}, but got {drive!r}")


def _check_wheels(wheels: Any, where: str) -> None:
    """``wheels``: a non-empty list of distinct :data:`SIDES`."""
    if (
        not isinstance(wheels, list)
        or not wheels
        or any(w not in SIDES for w in wheels)
        or len(set(wheels)) < len(wheels)
    ):
        raise _refuse(
            where,
            f"wheels must be a list of distinct wheels from {list(SIDES)}, but got {wheels!r}",
        )


def _check_channel_list(chans: Any, where: str) -> list[str]:
    """``channels``: a non-empty list of :data:`CHANNELS` names; returned."""
    if not isinstance(chans, list) or not chans or not all(isinstance(c, str) for c in chans):
        raise _refuse(
            where, f"channels must be a non-empty list of channel names, but got {chans!r}"
        )
    unknown = [c for c in chans if c not in CHANNELS]
    if unknown:
        raise _refuse(
            where, f"unknown channel(s) {unknown}; the format's channels are {list(CHANNELS)}"
        )
    return chans


def _check_test_table(tests: Any, where: str) -> None:
    """``[tests]``: at least one known test, each with a plain file name."""
    if not isinstance(tests, dict) or not tests:
        raise _refuse(
            where, "[tests] must name at least one test, e.g. [tests.parallel] file = ..."
        )
    for t, spec in tests.items():
        if t not in _knc.RIG_TESTS:
            raise _refuse(where, f"unknown test {t!r}; the format's tests are {_knc.RIG_TESTS}")
        if not isinstance(spec, dict) or not isinstance(spec.get("file"), str):
            raise _refuse(where, f'[tests.{t}] must give file = "<name>.csv", but got {spec!r}')
        f = Path(spec["file"])
        if f.name != spec["file"] or f.name in ("", ".", ".."):
            raise _refuse(
                where,
                f"[tests.{t}] file must be a plain file name in the folder, but got "
                f"{spec['file']!r}",
            )


def _check_noise_table(noise: Any, chans: list[str], where: str) -> None:
    """``[noise]``: a table of declared channels -> ``{ sigma > 0, unit }``, the unit
    of the channel's quantity."""
    if not isinstance(noise, dict):
        raise _refuse(where, f"[noise] must be a table, but got {noise!r}")
    for c, spec in noise.items():
        if c not in chans:
            raise _refuse(
                where, f"[noise] names the channel {c!r}, which is not in channels {chans}"
            )
        if not isinstance(spec, dict) or set(spec) != {"sigma", "unit"}:
            raise _refuse(
                where,
                f'[noise] {c} must be {{ sigma = <number>, unit = "<unit>" }}, but got {spec!r}',
            )
        s = spec["sigma"]
        if (
            isinstance(s, bool)
            or not isinstance(s, int | float)
            or not (math.isfinite(s) and s > 0)
        ):
            raise _refuse(
                where, f"[noise] {c}: `sigma > 0` (finite) must hold, but got sigma={s!r}"
            )
        if not isinstance(spec["unit"], str):
            raise _refuse(where, f"[noise] {c}: unit must be text, but got {spec['unit']!r}")
        _, si = _unit(spec["unit"], f"{where} [noise] {c}")
        _check_quantity(f"{where} [noise] {c}", spec["unit"], si, CHANNELS[c])


def _read_csv(path: Path, limit: int) -> tuple[list[str], list[list[str]]]:
    """(header cells, data rows) of a test's CSV; blank rows are dropped."""
    if not path.is_file():
        raise RecordingError(f"{path.name}: the test's file does not exist in {str(path.parent)!r}")
    check_text(path, limit)
    try:
        text = path.read_text(encoding="utf-8-sig")  # a BOM (Excel's "CSV UTF-8") is dropped
    except UnicodeDecodeError as exc:
        raise RecordingError(f"{path.name}: not UTF-8 text ({exc})") from None
    try:
        rows = [r for r in csv.reader(io.StringIO(text)) if r and any(c.strip() for c in r)]
    except csv.Error as exc:
        raise RecordingError(f"{path.name}: not a readable CSV file ({exc})") from None
    if not rows:
        raise RecordingError(
            f"{path.name}: empty file (a header row and one row per step are needed)"
        )
    return [c.strip() for c in rows[0]], rows[1:]


@dataclass(frozen=True)
class _Layout:
    """What a test's CSV must hold: the test, its drive column and the manifest's
    channels and wheels."""

    where: str
    test: str
    chans: list[str]
    wheels: list[str]

    @property
    def drive(self) -> str:
        return DRIVE_COLUMN[self.test][0]


#: a parsed column: (index in the row, factor to SI, the unit its header declared)
_Column = tuple[int, float, str]


def _load_test(
    folder: Path, test: str, spec: dict, chans: list[str], wheels: list[str], limit: int
) -> MeasuredTest:
    """One test's CSV as a :class:`MeasuredTest` (SI): read the table, map its columns,
    convert and check the numbers, build the channels."""
    path = folder / spec["file"]
    header, rows = _read_csv(path, limit)
    lay = _Layout(f"{path.name} (test {test!r})", test, chans, wheels)
    cols = _map_columns(lay, header)
    _check_complete(lay, cols, len(rows))
    values = _to_numbers(lay.where, header, rows, cols)
    branch, drive = _check_rows(lay, header, values, cols)
    channels = _channels(lay, values, cols)
    units = {header[i]: u for i, _, u in cols.values() if u}
    return MeasuredTest(test, drive, branch, channels, tuple(wheels), units)


def _map_columns(lay: _Layout, header: list[str]) -> dict[str, _Column]:
    """The header's columns: name -> (index, factor to SI, unit), each header checked
    (``<name> [<unit>]``, a column of this test, a unit of its quantity)."""
    dup = sorted({h for h in header if header.count(h) > 1})
    if dup:
        raise _refuse(lay.where, f"the header repeats the column(s) {dup}")
    cols: dict[str, _Column] = {}
    for i, h in enumerate(header):
        if h in ("step", "branch"):
            cols[h] = (i, 1.0, "")
            continue
        mt = _HEADER.match(h)
        if not mt:
            raise _refuse(
                lay.where,
                f"column {h!r} must be written '<name> [<unit>]' (e.g. 'toe_left [deg]'), "
                "or be 'step' / 'branch'",
            )
        name, unit = mt.group(1), mt.group(2)
        factor, si = _unit(unit, f"{lay.where} column {h!r}")
        _check_quantity(f"{lay.where} column {h!r}", unit, si, _quantity(lay, h, name))
        cols[name] = (i, factor, unit)
    return cols


def _quantity(lay: _Layout, h: str, name: str) -> str:
    """The quantity of column ``name`` (header ``h``): the drive's, the wheel travel's
    (length) or its channel's; a column not of this test is refused."""
    if name == lay.drive:
        return DRIVE_COLUMN[lay.test][1]
    stem, _, side = name.rpartition("_")
    if side not in SIDES or (stem not in lay.chans and stem != TRAVEL_COLUMN):
        raise _refuse(
            lay.where,
            f"column {h!r} is not one of this test's columns: 'step', 'branch', "
            f"'{lay.drive} [unit]', '{TRAVEL_COLUMN}_<side> [unit]' or "
            f"'<channel>_<side> [unit]' with a channel of knc.toml {lay.chans} and a "
            f"side of {list(lay.wheels)}",
        )
    if side not in lay.wheels:
        raise _refuse(
            lay.where,
            f"column {h!r} is of the {side} wheel, which knc.toml's wheels {lay.wheels} omit",
        )
    return "length" if stem == TRAVEL_COLUMN else CHANNELS[stem]


def _check_complete(lay: _Layout, cols: Mapping[str, _Column], rows: int) -> None:
    """Every column the test needs is present and there are :data:`MIN_SAMPLES` rows."""
    need = ["step", "branch", lay.drive] + [f"{c}_{s}" for c in lay.chans for s in lay.wheels]
    if lay.test in _knc.TESTS:
        need += [f"{TRAVEL_COLUMN}_{s}" for s in lay.wheels]
    missing = [n for n in need if n not in cols]
    if missing:
        lacks_wheel = [s for s in lay.wheels if any(n.endswith("_" + s) for n in missing)]
        hint = (
            '; a test needs both wheels\' columns (declare wheels = ["left"] in knc.toml '
            "for a one-wheel bench measurement)"
            if lacks_wheel and len(lay.wheels) == 2
            else ""
        )
        raise _refuse(lay.where, f"missing column(s) {missing} (units in brackets){hint}")
    if rows < MIN_SAMPLES:
        raise _refuse(lay.where, f"`samples >= {MIN_SAMPLES}` must hold, but got {rows} rows")


def _to_numbers(
    where: str, header: list[str], rows: list[list[str]], cols: Mapping[str, _Column]
) -> np.ndarray:
    """The rows as numbers (rows, columns), as written (not yet SI); a row of the
    wrong width, a cell that is not a number or a missing/NaN/inf value of a mapped
    column is refused."""
    width = len(header)
    values = np.full((len(rows), width), np.nan)
    for r, row in enumerate(rows):
        if len(row) != width:
            raise _refuse(where, f"row {r + 2} has {len(row)} fields, but the header has {width}")
        for c, cell in enumerate(row):
            s = cell.strip()
            if s == "":
                continue  # NaN: refused below with its run
            try:
                values[r, c] = float(s)
            except ValueError:
                raise _refuse(
                    where, f"row {r + 2} column {header[c]!r} must be a number, but got {s!r}"
                ) from None
    for i, _, _ in cols.values():
        found = nonfinite_run(values[:, i])
        if found is not None:
            first, run = found
            bad = int(np.count_nonzero(~np.isfinite(values[:, i])))
            raise _refuse(
                where,
                f"column {header[i]!r} must be finite, but holds {bad} missing/NaN/inf "
                f"value(s), the first run of {run} from data row {first + 1} (file line "
                f"{first + 2}); drop or fill those rows",
            )
    return values


def _check_rows(
    lay: _Layout, header: list[str], values: np.ndarray, cols: Mapping[str, _Column]
) -> tuple[np.ndarray, np.ndarray]:
    """(branch (P,) int, drive (P,) [SI]): ``step`` increases strictly, ``branch`` is 0,
    1 or 2, the drive is strictly monotonic within each branch and varies."""
    where = lay.where
    step = values[:, cols["step"][0]]
    if not np.all(np.diff(step) > 0):
        k = int(np.argmax(np.diff(step) <= 0))
        raise _refuse(
            where,
            f"'step' must increase strictly, but rows {k + 1} and {k + 2} hold {step[k]:g} "
            f"and {step[k + 1]:g}",
        )
    branch_f = values[:, cols["branch"][0]]
    if not np.all(np.isin(branch_f, (0.0, 1.0, 2.0))):
        k = int(np.argmax(~np.isin(branch_f, (0.0, 1.0, 2.0))))
        raise _refuse(where, f"'branch' must be 0, 1 or 2, but row {k + 1} holds {branch_f[k]:g}")
    branch = branch_f.astype(int)
    di, dfac, _ = cols[lay.drive]
    for b, sense in ((0, 1.0), (1, -1.0), (2, 1.0)):
        idx = np.flatnonzero(branch == b)
        d = np.diff(values[idx, di] * dfac) * sense
        if d.size and not np.all(d > 0):
            k = int(np.argmax(d <= 0))
            word = "decrease" if sense < 0 else "increase"
            raise _refuse(
                where,
                f"the drive '{header[di]}' must {word} strictly within branch {b}, but rows "
                f"{idx[k] + 1} and {idx[k + 1] + 1} hold {values[idx[k], di]:g} and "
                f"{values[idx[k + 1], di]:g}",
            )
    drive = values[:, di] * dfac
    if not np.ptp(drive) > 0:
        raise _refuse(where, f"the drive '{header[di]}' must vary, but is constant")
    return branch, drive


def _per_wheel(
    values: np.ndarray, cols: Mapping[str, _Column], stem: str, wheels: list[str]
) -> np.ndarray:
    """Columns ``<stem>_<side>`` in SI as (P, 2) (left, right); a wheel not in
    ``wheels`` is NaN."""
    arr = np.full((values.shape[0], 2), np.nan)
    for s in wheels:
        i, fac, _ = cols[f"{stem}_{s}"]
        arr[:, SIDES.index(s)] = values[:, i] * fac
    return arr


def _channels(
    lay: _Layout, values: np.ndarray, cols: Mapping[str, _Column]
) -> dict[str, np.ndarray]:
    """The declared channels (SI, (P, 2)); ``wheel_centre_z`` from the wheel-travel
    columns when the file has them but not the channel (origin at the static height),
    else the two checked to agree (:func:`check_wheel_travel`)."""
    channels = {ch: _per_wheel(values, cols, ch, lay.wheels) for ch in lay.chans}
    if all(f"{TRAVEL_COLUMN}_{s}" in cols for s in lay.wheels):
        travel = _per_wheel(values, cols, TRAVEL_COLUMN, lay.wheels)
        if "wheel_centre_z" in channels:
            check_wheel_travel(lay.where, travel, channels["wheel_centre_z"])
        else:
            channels["wheel_centre_z"] = travel
    return channels


def load_measurement(
    path: str | Path,
    *,
    require: Iterable[str] = (),
    tests: Iterable[str] | None = None,
    both_wheels: bool = True,
    max_bytes: int | None = None,
) -> KncMeasurement:
    """Read a measured-K&C folder (or its ``knc.toml``); bad files raise
    :class:`~suspenv.measurements.RecordingError` naming the file, the rule and the value.

    Every file is checked before anything is computed: the manifest (format, version,
    sign convention, wheels, channels, tests, noise), then each test's CSV (header
    ``<name> [<unit>]`` with a known unit of the right quantity, every declared channel
    for every declared wheel, at least :data:`MIN_SAMPLES` rows, finite numbers,
    ``step`` increasing, ``branch`` in {0, 1, 2}, the drive strictly monotonic within
    each branch). Values are converted to SI.

    Args:
        require: channels the caller needs (missing -> refused).
        tests: tests the caller needs (missing -> refused); None: whatever the file has.
        both_wheels: refuse a one-wheel measurement (``wheels = ["left"]``); False for a
            compliance analysis of a one-wheel bench test.
        max_bytes: read limit (:mod:`suspenv.measurements.limits`).
    """
    folder, data = _manifest(Path(path))
    where = MANIFEST
    wheels = list(data.get("wheels", list(SIDES)))
    if both_wheels and len(wheels) < 2:
        raise _refuse(
            where,
            f"a test needs both wheels, but wheels = {wheels}: a one-wheel measurement serves "
            "compliance analysis (both_wheels=False), not identification",
        )
    chans = list(data["channels"])
    missing = [c for c in require if c not in chans]
    if missing:
        raise _refuse(where, f"missing channel(s) {missing}; the file's channels are {chans}")
    want = list(tests) if tests is not None else []
    absent = [t for t in want if t not in data["tests"]]
    if absent:
        raise _refuse(
            where, f"missing test(s) {absent}; the file's tests are {list(data['tests'])}"
        )
    limit = read_limit(max_bytes)
    loaded = {
        t: _load_test(folder, t, spec, chans, wheels, limit) for t, spec in data["tests"].items()
    }
    declared = {}
    for c, spec in data.get("noise", {}).items():
        factor, _ = _unit(spec["unit"], f"{where} [noise] {c}")
        declared[c] = float(spec["sigma"]) * factor
    files = {t: spec["file"] for t, spec in data["tests"].items()}
    meta: dict[str, Any] = {
        "source": data.get("source", ""),
        "sign_convention": SIGN_CONVENTION,
        "travel_drive": data.get("travel_drive", "pad"),
        "wheels": wheels,
        "files": files,
        "amplitude": {t: float(np.max(np.abs(m.drive))) for t, m in loaded.items()},
        "steps": {t: s for t, m in loaded.items() if (s := m.uniform_steps()) is not None},
        "units": {t: m.units for t, m in loaded.items()},
        "path": str(folder),
        "warnings": check_tests(loaded, files, CHANNELS),
    }
    if "notes" in data:
        meta["notes"] = data["notes"]
    return _assemble(data["name"], loaded, declared, meta)
