"""K&C rig curves of one design as a PNG, in edge units (mm, deg, N; ISO 8855 signs with
lateral positions mirrored outboard positive): toe, camber, caster, tyre force, hub and
contact-patch lateral position against the test's drive (:func:`x_axis`). The CSV of a
test is the measured-K&C format (:mod:`suspenv.measurements.knc_file`). Used by
``suspenv knc``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from suspenv.measurements.knc import DISPLAY, LOADED_TESTS, SIDES, TESTS
from suspenv.models.mcpherson.params import SIDE_SIGN
from suspenv.reports._mpl import pyplot, save_figure
from suspenv.rigs.knc import KCResult

#: panels: label -> (rig channel, scale to edge units, outboard-mirrored)
PANELS = {
    **{
        DISPLAY[c].label(): (c, DISPLAY[c].scale, False)
        for c in ("toe", "camber", "caster", "tyre_fz")
    },
    **{
        DISPLAY[c]._replace(sign="outboard").label(): (c, DISPLAY[c].scale, True)
        for c in ("wheel_centre_y", "contact_y")
    },
}


def x_axis(res: KCResult) -> tuple[str, dict[str, np.ndarray]]:
    """(axis label, x per wheel ``left``/``right``) of design 0's loop: each wheel's
    travel from the static position [mm] (bump +) in a travel test, else the rig's drive
    (``res.grid`` along the loop, the same on both wheels): the load [``res.unit``] of a
    compliance test or the rack travel [mm] (+y, to the left) of the steering test."""
    if res.test in TESTS:
        z = res.channels["wheel_centre_z"][0]
        x = {s: (z[:, w] - z[0, w]) * 1e3 for w, s in enumerate(SIDES)}
        return "wheel travel [mm] (bump +)", x
    if res.test in LOADED_TESTS:
        label, scale = f"{res.test} load [{res.unit}]", 1.0
    else:
        label, scale = "rack travel [mm] (+y, to the left)", 1e3
    drive = res.grid[res.path] * scale
    return label, dict.fromkeys(SIDES, drive)


def plot_rig_curves(res: KCResult, path: Path, title: str) -> None:
    """:data:`PANELS` of design 0 against the test's drive (:func:`x_axis`), both wheels."""
    xlabel, x = x_axis(res)
    fig, axes = pyplot().subplots(2, 3, figsize=(12, 7), constrained_layout=True)
    for ax, (label, (ch, scale, mirrored)) in zip(axes.ravel(), PANELS.items(), strict=True):
        for w, (side, style) in enumerate(zip(SIDES, ("-", "--"), strict=True)):
            y = res.channels[ch][0, :, w] * scale * (SIDE_SIGN[w] if mirrored else 1.0)
            ax.plot(x[side], y, style, lw=1.2, label=side)
        ax.set_xlabel(xlabel)
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[0, 0].legend()
    fig.suptitle(title)
    save_figure(fig, path, dpi=110)
