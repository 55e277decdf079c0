"""Ride report of named minibus designs: random road (ISO 8608) and pulse bump runs.

``ride_report.md``: per design and load case the ISO 2631-1 Wk-weighted RMS vertical
acceleration above the front and rear suspension (m/s^2; the problem's default method,
the spectral integral of :func:`suspenv.metrics.ride.ride_spectral`, free of road-seed
noise), the comfort reaction, and the
peak |acceleration| (m/s^2) of each pulse run; ``ride_psd.png`` (acceleration PSDs on the
random road) and ``ride_pulse.png`` (pulse time histories, no load). Not the ride
*diagnosis* report (:mod:`suspenv.reports.diagnosis.ride`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from suspenv.core.atomic import write_file
from suspenv.core.markdown import table_lines
from suspenv.metrics.iso2631 import comfort_reaction
from suspenv.metrics.ride import acceleration_psd, ride_spectral
from suspenv.models.minibus.ride_model import RideRecord
from suspenv.models.minibus.vehicle import LOAD_CASES, REFERENCE_MINIBUS, Minibus
from suspenv.models.road import RandomRoad
from suspenv.reports._mpl import pyplot, save_figure
from suspenv.rigs.ride import PulseBump, PulseResult, pulse_run, random_road_run


def write_minibus_ride_report(
    designs: Mapping[str, np.ndarray],
    out_dir: Path | str,
    road: RandomRoad | None = None,
    pulse_speeds_kmh: Sequence[float] = (20.0, 50.0),
    vehicle: Minibus = REFERENCE_MINIBUS,
    pulse_duration_s: float = 3.0,
) -> list[Path]:
    """Ride report of named designs (study units): table, acceleration PSDs, pulse histories.

    Writes ``ride_report.md``, ``ride_psd.png`` and ``ride_pulse.png`` into out_dir.
    """
    road = road or RandomRoad()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    names = list(designs)
    X = np.vstack([np.asarray(designs[k], dtype=float).reshape(1, -1) for k in names])
    rec = random_road_run(X, LOAD_CASES, road, vehicle)  # for the PSD figure
    sp = ride_spectral(X, LOAD_CASES, road, vehicle)
    pulses = {
        v: pulse_run(X, LOAD_CASES, PulseBump(speed_kmh=v, duration_s=pulse_duration_s), vehicle)
        for v in pulse_speeds_kmh
    }

    lines = [
        "# Ride report",
        "",
        f"Random road: ISO 8608 class {road.road_class} at {road.speed_kmh:g} km/h; ISO 2631-1 "
        "Wk weighted RMS vertical acceleration above the front and rear suspension (m/s^2), "
        "the spectral integral of the equivalent-linear model over the road PSD (the "
        "problem's default; no road seed). The PSD figure shows one "
        f"{road.duration_s:g} s record (seed {road.seed}) of the nonlinear model. "
        "Pulse: triangular bump "
        f"{PulseBump().base * 1e3:.0f} x {PulseBump().height * 1e3:.0f} mm, peak |acceleration| "
        "(m/s^2).",
        "",
    ]
    lines += _ride_table(names, sp, pulses, pulse_speeds_kmh)
    psd_png = _plot_psd(names, rec, road.sample_rate, out / "ride_psd.png")
    pulse_png = _plot_pulses(names, pulses, pulse_speeds_kmh, out / "ride_pulse.png")
    lines += ["", f"![acceleration PSD]({psd_png.name})", "", f"![pulse]({pulse_png.name})", ""]
    md = write_file(out / "ride_report.md", "\n".join(lines))
    return [md, psd_png, pulse_png]


def _ride_table(
    names: list[str],
    sp: dict[str, np.ndarray],
    pulses: dict[float, PulseResult],
    speeds: Sequence[float],
) -> list[str]:
    """One row per design and load case: aw front and rear (``sp``: :func:`ride_spectral`),
    the comfort reaction and the pulses' peak accelerations (rows: load case major)."""
    n = len(names)
    aw_f, aw_r = sp["aw_front"], sp["aw_rear"]
    head = ["design", "load", "aw front", "aw rear", "comfort (front)"]
    for v in speeds:
        head += [f"pulse {v:g} km/h front", f"pulse {v:g} km/h rear"]
    rows = []
    for i, name in enumerate(names):
        for j, lc in enumerate(LOAD_CASES):
            r = j * n + i
            cells = [name, lc.replace("_", " "), f"{aw_f[r]:.3f}", f"{aw_r[r]:.3f}"]
            cells.append(comfort_reaction(float(aw_f[r])))
            for v in speeds:
                cells += [f"{pulses[v].peak_front[r]:.2f}", f"{pulses[v].peak_rear[r]:.2f}"]
            rows.append(cells)
    return table_lines(head, rows)


def _plot_psd(names: list[str], rec: RideRecord, fs: float, path: Path) -> Path:
    """Acceleration PSDs of the random-road record ``rec`` (sampled at ``fs`` Hz) above
    the front and rear suspension, one panel per load case and end."""
    n = len(names)
    fig, axes = pyplot().subplots(2, 2, figsize=(11, 7), sharex=True)
    for j, lc in enumerate(LOAD_CASES):
        for k, (label, acc) in enumerate((("front", rec.acc_front), ("rear", rec.acc_rear))):
            ax = axes[j, k]
            for i, name in enumerate(names):
                f, p = acceleration_psd(acc[j * n + i], fs)
                ax.semilogy(f, p, label=name)
            ax.set(title=f"{lc.replace('_', ' ')}, above {label} suspension", xlim=(0, 25))
            ax.set_ylabel("PSD ((m/s^2)^2/Hz)")
            ax.grid(True, alpha=0.3)
    for ax in axes[-1]:
        ax.set_xlabel("frequency (Hz)")
    axes[0, 0].legend()
    return save_figure(fig, path, dpi=110, tight=True)


def _plot_pulses(
    names: list[str], pulses: dict[float, PulseResult], speeds: Sequence[float], path: Path
) -> Path:
    """Acceleration histories over the pulse of each speed (no load), front and rear."""
    fig, axes = pyplot().subplots(len(speeds), 2, figsize=(11, 3.2 * len(speeds)), squeeze=False)
    for m, v in enumerate(speeds):
        res = pulses[v]
        for k, (label, acc) in enumerate(
            (("front", res.record.acc_front), ("rear", res.record.acc_rear))
        ):
            ax = axes[m, k]
            for i, name in enumerate(names):
                ax.plot(res.t, acc[i], label=f"{name}, no load")
            ax.set(title=f"pulse {v:g} km/h, above {label} suspension", xlabel="time (s)")
            ax.set_ylabel("acceleration (m/s^2)")
            ax.grid(True, alpha=0.3)
    axes[0, 0].legend()
    return save_figure(fig, path, dpi=110, tight=True)
