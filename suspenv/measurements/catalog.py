"""The real recordings the diagnosis is shown on, by name, with their published physics.

Each entry loads one case from the folder of the real recordings (``root``, default
:func:`real_data_dir`): the recordings to fit, the held-out data (recordings, or a
hold-out rule such as ``"cycles"``), the component family that models them, and what
the literature says (``named``, ``families``, ``published``, and ``check``: parameter ->
published value). Used by ``suspenv diagnose NAME`` and the diagnosis benchmark.
Sources and licences: ``../shared/data/README.md``.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from suspenv.measurements.paths import data_dir
from suspenv.measurements.sources import load_damper_dyno, load_emps, load_mr_damper

#: (fit recordings, held-out data, component family, expectation)
RealCase = tuple[Any, Any, str, dict[str, Any]]


def real_data_dir() -> Path:
    """The folder of the real recordings: ``real/`` in :func:`~suspenv.measurements.data_dir`."""
    return data_dir() / "real"


def _real_emps(root: Path) -> RealCase:
    fit = load_emps(root / "emps" / "DATA_EMPS.mat").decimate(5)
    hold = load_emps(root / "emps" / "DATA_EMPS_PULSES.mat").decimate(5)
    expect = {
        "named": "friction (Coulomb)",
        "families": ["friction"],
        "published": "Coulomb about 20 N, viscous about 204 N s/m, offset about -3.2 N",
        "check": {"coulomb_friction.f_c": 20.0, "c": 204.0, "force_offset.offset": -3.2},
    }
    return fit, hold, "friction_guide", expect


def _real_mr(root: Path) -> RealCase:
    d = root / "mr_damper_shaking_table"
    fit = [load_mr_damper(d / f"ensaio.A.{i}.mat") for i in (1, 5, 9)]
    hold = [load_mr_damper(d / "ensaio.vali.A.1.mat")]
    expect = {
        "named": "hysteresis",
        "families": ["hysteresis"],
        "published": "strong Bouc-Wen/Dahl hysteresis plus viscous",
    }
    return fit, hold, "mr_damper", expect


def _real_dyno(root: Path) -> RealCase:
    rec = load_damper_dyno(root / "damper_dyno_fsae" / "TR22-FC0739-1-4-1-4.dat").decimate(8)
    expect = {
        "named": "digressive and asymmetric force-velocity",
        "families": ["digressive", "damper_asymmetry"],
        "published": "digressive, asymmetric bump/rebound; friction/compliance lag in loops",
    }
    # the run steps its peak velocity up (3 cycles per level): one cycle in four is held
    # out, so fit and held-out data span the same velocities (the last 30 % of the run
    # would be the fastest levels only, an extrapolation)
    return rec, "cycles", "damper", expect


#: name -> loader(root) of (fit recordings, held-out data, component family, expectation)
REAL_CASES: dict[str, Callable[[Path], RealCase]] = {
    "emps": _real_emps,
    "mr_damper": _real_mr,
    "damper_dyno": _real_dyno,
}
