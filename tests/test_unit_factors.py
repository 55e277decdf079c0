"""Every unit factor of the code against an independent definition (scipy.constants).

One table row per factor: where the code keeps it, its value there, and the same factor
built from ``scipy.constants`` (CODATA and the exact SI/NIST SP 811 definitions:
1 in = 0.0254 m, 1 ft = 0.3048 m, 1 lbf = 4.4482216152605 N, 1 kgf = g0 = 9.80665 N,
1 deg = pi/180 rad, 1 km/h = 1/3.6 m/s). A wrong conversion (deg/s taken as rad/s,
kN as N, km/h divided by 3.5) fails its row.

Tolerance: both sides are products or quotients of at most three correctly rounded
doubles, so they agree to a few units in the last place; ``RTOL = 8 eps`` (1.8e-15)
bounds that and is nine orders below the smallest plausible wrong factor. Rounded
constants (the minibus' g = 9.81) carry their own stated tolerance.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import constants as sc

from suspenv.measurements import knc, knc_file, units
from suspenv.metrics import knc as knc_metrics
from suspenv.metrics import knc_kernel
from suspenv.models.mcpherson import params as mcpherson_params
from suspenv.models.minibus import vehicle as minibus_vehicle
from suspenv.models.planar import geometry as planar_geometry
from suspenv.models.road import RandomRoad
from suspenv.rigs.handling import SlalomConfig
from suspenv.rigs.ride import PulseBump

#: a few ulps of double precision (see the module docstring)
RTOL = 8 * np.finfo(float).eps

#: unit -> (factor to SI, SI unit), built from scipy.constants only
INDEPENDENT: dict[str, tuple[float, str]] = {
    "m": (1.0, "m"),
    "cm": (sc.centi, "m"),
    "mm": (sc.milli, "m"),
    "in": (sc.inch, "m"),
    "m/s": (1.0, "m/s"),
    "mm/s": (sc.milli, "m/s"),
    "in/s": (sc.inch, "m/s"),
    "km/h": (sc.kmh, "m/s"),
    "m/s^2": (1.0, "m/s^2"),
    "N": (1.0, "N"),
    "kN": (sc.kilo, "N"),
    "lbf": (sc.pound_force, "N"),
    "N*m": (1.0, "N*m"),
    "Nm": (1.0, "N*m"),
    "N m": (1.0, "N*m"),
    "N.m": (1.0, "N*m"),
    "N*mm": (sc.milli, "N*m"),
    "Nmm": (sc.milli, "N*m"),
    "kN*m": (sc.kilo, "N*m"),
    "kNm": (sc.kilo, "N*m"),
    "lbf*ft": (sc.pound_force * sc.foot, "N*m"),
    "ft*lbf": (sc.pound_force * sc.foot, "N*m"),
    "lbf*in": (sc.pound_force * sc.inch, "N*m"),
    "in*lbf": (sc.pound_force * sc.inch, "N*m"),
    "kgf": (sc.g, "N"),
    "kgf*m": (sc.g, "N*m"),
    "s": (1.0, "s"),
    "sec": (1.0, "s"),
    "ms": (sc.milli, "s"),
    "V": (1.0, "V"),
    "mV": (sc.milli, "V"),
    "A": (1.0, "A"),
    "mA": (sc.milli, "A"),
    "rad": (1.0, "rad"),
    "mrad": (sc.milli, "rad"),
    "deg": (sc.degree, "rad"),
    "rad/s": (1.0, "rad/s"),
    "deg/s": (sc.degree, "rad/s"),
    "1": (1.0, "1"),
    "-": (1.0, "-"),
}


def _table_rows() -> list[tuple[str, str, tuple[float, str]]]:
    rows = [("units.FACTORS", u, f) for u, f in units.FACTORS.items()]
    rows += [("knc_file.UNITS", u, f) for u, f in knc_file.UNITS.items()]
    return rows


@pytest.mark.parametrize(("table", "unit", "factor"), _table_rows())
def test_reader_unit_factor(table: str, unit: str, factor: tuple[float, str]) -> None:
    assert unit in INDEPENDENT, f"{table}: no independent definition of {unit!r} in this test"
    want, si = INDEPENDENT[unit]
    assert factor[1] == si, f"{table}[{unit!r}] converts to {factor[1]!r}, not {si!r}"
    assert factor[0] == pytest.approx(want, rel=RTOL, abs=0), f"{table}[{unit!r}]"


#: named constants: (where, value in the code, independent value, rtol and why)
NAMED = [
    ("measurements.knc.RAD2DEG", knc.RAD2DEG, 1.0 / sc.degree, RTOL),
    ("metrics.knc.RAD2DEG", knc_metrics.RAD2DEG, 1.0 / sc.degree, RTOL),
    ("metrics.knc_kernel.RAD2DEG", knc_kernel.RAD2DEG, 1.0 / sc.degree, RTOL),
    ("mcpherson.params.DEG", mcpherson_params.DEG, sc.degree, RTOL),
    ("units._KGF", units._KGF, sc.g, RTOL),
    ("planar.geometry._MM", planar_geometry._MM, sc.milli, RTOL),
    ("minibus.N_PER_MM_TO_N_PER_M", minibus_vehicle.N_PER_MM_TO_N_PER_M, 1.0 / sc.milli, RTOL),
    (
        "minibus.NMM_PER_DEG_TO_NM_PER_RAD",
        minibus_vehicle.NMM_PER_DEG_TO_NM_PER_RAD,
        sc.milli / sc.degree,
        RTOL,
    ),
    # the minibus model's g is rounded to three digits (9.81 m/s^2, the study's value):
    # |9.81 / 9.80665 - 1| = 3.4e-4 < 5e-4, half a unit of the third digit
    ("minibus.G (rounded)", minibus_vehicle.G, sc.g, 5e-4),
    ("RandomRoad.speed per km/h", RandomRoad(speed_kmh=1.0).speed, sc.kmh, RTOL),
    ("PulseBump.speed per km/h", PulseBump(speed_kmh=1.0).speed, sc.kmh, RTOL),
    ("SlalomConfig.speed per km/h", SlalomConfig(speed_kmh=1.0).speed, sc.kmh, RTOL),
]


@pytest.mark.parametrize(("where", "value", "want", "rtol"), NAMED, ids=[n[0] for n in NAMED])
def test_named_unit_constant(where: str, value: float, want: float, rtol: float) -> None:
    assert value == pytest.approx(want, rel=rtol, abs=0), where


#: SI unit of each K&C channel kind (the rig's and the recordings' channels)
_CHANNEL_SI = {"deg": "rad", "mm": "m", "N": "N"}


@pytest.mark.parametrize("channel", sorted(knc.DISPLAY))
def test_knc_channel_display_scale(channel: str) -> None:
    """Each K&C channel's display scale is the reciprocal of its display unit's SI factor
    (deg from rad, mm from m), and a recorded channel's SI unit is the one it is kept in."""
    shown = knc.DISPLAY[channel]
    want, si = INDEPENDENT[shown.unit]
    assert si == _CHANNEL_SI[shown.unit]
    assert shown.scale == pytest.approx(1.0 / want, rel=RTOL, abs=0), channel
    if channel in knc.CHANNELS:
        assert knc.CHANNELS[channel][1] == si


def test_to_si_applies_the_table() -> None:
    """``to_si`` multiplies by its table's factor (a unit read as deg/s becomes rad/s)."""
    values, si = units.to_si(np.array([180.0]), "deg/s")
    assert si == "rad/s"
    assert values[0] == pytest.approx(180.0 * sc.degree, rel=RTOL)


@pytest.mark.parametrize(
    ("text", "key"),
    [
        (" mm ", "mm"),
        ("N·m", "N*m"),
        ("kN . m", "kN*m"),
        ("KN·M", "kN*m"),
        ("DEG", "deg"),
        ("Nm", "Nm"),
        ("grad", None),
        ("", None),
        (3, None),
    ],
)
def test_one_unit_name_reader(text: object, key: str | None) -> None:
    """Recordings and the K&C format read unit names alike: stripped, any product sign
    (``*``, ``.``, ``·``) as ``*``, then case-folded; anything else is unknown."""
    assert units.unit_key(text) == key
    if key in knc_file.UNITS:
        assert knc_file._unit(str(text), "here") == units.FACTORS[str(key)]
