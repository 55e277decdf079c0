"""K&C rig curves of one design in edge units: a CSV table and a PNG of the usual curves.

:func:`curve_table` (the plot's data): one row per rig step, both wheels; units mm,
deg, N; ISO 8855 signs with lateral positions mirrored outboard positive.
:func:`write_csv` writes one test in the measured-K&C format instead
(:mod:`suspenv.measurements.knc_file`, raw ISO 8855). The figure draws toe, camber,
caster, tyre force, hub and contact-patch lateral position against the test's drive
(:func:`x_axis`). Used by ``suspenv knc``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from suspenv.measurements.knc import LOADED_TESTS, TESTS
from suspenv.models.mcpherson.params import SIDE_SIGN
from suspenv.reports._mpl import pyplot, save_figure
from suspenv.rigs.knc import KCResult

#: CSV/plot channels: column stem -> (rig channel, scale to edge units, outboard-mirrored)
CHANNELS = {
    "wheel_travel_mm": ("wheel_centre_z", 1e3, False),
    "pad_mm": ("pad_z", 1e3, False),
    "toe_deg": ("toe", np.rad2deg(1.0), False),
    "camber_deg": ("camber", np.rad2deg(1.0), False),
    "caster_deg": ("caster", np.rad2deg(1.0), False),
    "kpi_deg": ("kpi", np.rad2deg(1.0), False),
    "hub_x_mm": ("wheel_centre_x", 1e3, False),
    "hub_y_out_mm": ("wheel_centre_y", 1e3, True),
    "contact_x_mm": ("contact_x", 1e3, False),
    "contact_y_out_mm": ("contact_y", 1e3, True),
    "tyre_fz_N": ("tyre_fz", 1.0, False),
    "spring_force_N": ("spring_force", 1.0, False),
    "scrub_radius_mm": ("scrub_radius", 1e3, False),
    "trail_mm": ("trail", 1e3, False),
}


def curve_table(res: KCResult) -> tuple[list[str], np.ndarray]:
    """Column names and rows (P, columns) of one design's loop (row 0 of the batch)."""
    force = res.test in LOADED_TESTS
    cols = ["step", "force_N" if force else "stroke_mm", "direction"]
    data = [np.arange(res.path.size), res.grid[res.path] * (1.0 if force else 1e3)]
    d = np.sign(np.diff(res.grid[res.path], prepend=res.grid[res.path][0]))
    data.append(d)
    for stem, (ch, scale, mirrored) in CHANNELS.items():
        for w, side in enumerate(("left", "right")):
            v = res.channels[ch][0, :, w] * scale
            if ch in ("wheel_centre_z", "pad_z"):  # travel from the static position
                v = (res.channels[ch][0, :, w] - res.channels[ch][0, 0, w]) * scale
            if mirrored:
                v = v * SIDE_SIGN[w]
            cols.append(f"{stem}_{side}")
            data.append(v)
    return cols, np.column_stack(data)


def write_csv(res: KCResult, path: Path, row: int = 0) -> Path:
    """Design ``row``'s loop as one test's CSV of the measured-K&C format
    (:func:`suspenv.measurements.knc_file.write_test_csv`: raw ISO 8855, units in the
    column names, mm, deg, N, N*m). ``suspenv knc`` writes the whole folder (with its
    ``knc.toml``) through :func:`~suspenv.measurements.knc_file.write_measurement`."""
    from suspenv.measurements.knc_file import from_results, write_test_csv

    m = from_results({res.test: res}, res.test, row=row)
    return write_test_csv(m.tests[res.test], Path(path))


def x_axis(res: KCResult) -> tuple[str, dict[str, np.ndarray]]:
    """(axis label, x per wheel ``left``/``right``) of the figure: each wheel's travel
    [mm] (bump +) in a travel test, else the rig's drive (``res.grid`` along the loop):
    the load [``res.unit``] of a compliance test or the rack travel [mm] (+y, to the
    left) of the steering test, the same on both wheels."""
    cols, rows = curve_table(res)
    if res.test in TESTS:
        x = {s: rows[:, cols.index(f"wheel_travel_mm_{s}")] for s in ("left", "right")}
        return "wheel travel [mm] (bump +)", x
    if res.test in LOADED_TESTS:
        label = f"{res.test} load [{res.unit}]"
    else:
        label = "rack travel [mm] (+y, to the left)"
    return label, {"left": rows[:, 1], "right": rows[:, 1]}


def plot_rig_curves(res: KCResult, path: Path, title: str) -> None:
    """Toe, camber, caster, tyre force, hub and contact-patch lateral against the test's
    drive (:func:`x_axis`)."""
    plt = pyplot()
    cols, rows = curve_table(res)
    col = {c: i for i, c in enumerate(cols)}
    panels = [
        "toe_deg",
        "camber_deg",
        "caster_deg",
        "tyre_fz_N",
        "hub_y_out_mm",
        "contact_y_out_mm",
    ]
    xlabel, x = x_axis(res)
    fig, axes = plt.subplots(2, 3, figsize=(12, 7), constrained_layout=True)
    for ax, stem in zip(axes.ravel(), panels, strict=True):
        for side, style in (("left", "-"), ("right", "--")):
            ax.plot(x[side], rows[:, col[f"{stem}_{side}"]], style, lw=1.2, label=side)
        ax.set_xlabel(xlabel)
        ax.set_ylabel(stem.replace("_", " "))
        ax.grid(alpha=0.3)
    axes[0, 0].legend()
    fig.suptitle(title)
    save_figure(fig, path, dpi=110)
    plt.close(fig)
