"""Routine suspension figures of the minibus (the study's checks) and a Markdown report.

Frame and units: ISO 8855 (x forward, y left, z up); SI inside, report in engineering
units (Hz, %, kN*m/rad, mm, deg/g). All figures are closed forms of the vehicle data
and the design, vectorised over a batch of designs:

- natural ("offset") frequency per axle: f = sqrt(k_ride / m) / (2 pi) with the ride
  rate k_ride = k_s k_t / (k_s + k_t) per side and m the sprung mass on that side; the
  rear spring rate is the leaf's local rate at rest (K1 before helper contact, K2
  after); the front/rear frequency ratio;
- damping ratio per axle: zeta = c / (2 sqrt(k_ride m)), c the damper's mean
  low-speed bump/rebound coefficient times the design scale (C1, C2); rear dampers act
  at ``rear_damper_spacing``, which does not change the heave figure;
- roll stiffness (suspension only, tyres rigid): front k_f t_f^2 / 2 + T2, rear
  k_r s^2 / 2 + T3 (s the leaf spacing); its front share; the roll gradient
  m_s g h / (K_phi - m_s g h) with h the CoM height above the roll axis;
- roll-centre heights (:func:`suspenv.models.minibus.handling_model.roll_centre_heights`):
  front from the wishbones' instant centre (line from the contact patch through the
  instant centre, ``front_ic_inboard`` inboard and ``front_ic_height`` high, crossing the
  centreline); rear: the leaf-seat line height ``rear_roll_centre_height`` of the rigid
  axle;
- static deflections under full load: spring compression from free at full load, the
  extra travel from no load to full load, and the CoM shift between load cases.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from suspenv.core.atomic import write_file
from suspenv.core.markdown import table_lines
from suspenv.models.minibus.handling_model import roll_centre_heights
from suspenv.models.minibus.suspension import (
    damper_force,
    damper_mean_coefficient,
    leaf_force,
)
from suspenv.models.minibus.vehicle import (
    DESIGN_NAMES,
    REFERENCE_MINIBUS,
    G,
    Minibus,
    VehicleParams,
    check_designs,
    design_to_si,
    vehicle_parameters,
)
from suspenv.reports._mpl import pyplot, save_figure


def _axle_figures(p: VehicleParams) -> dict[str, np.ndarray]:
    v, d = p.vehicle, p.design
    kt = v.tyre_vertical_stiffness
    ms_f, ms_r = p.front_static_load / G, p.rear_static_load / G
    kr_f = d.front_wheel_rate * kt / (d.front_wheel_rate + kt)
    kr_r = p.rear_static_rate * kt / (p.rear_static_rate + kt)
    f_f = np.sqrt(kr_f / ms_f) / (2 * np.pi)
    f_r = np.sqrt(kr_r / ms_r) / (2 * np.pi)
    c_f = damper_mean_coefficient(v.damper_front) * d.front_damper_scale
    c_r = damper_mean_coefficient(v.damper_rear) * d.rear_damper_scale
    roll_f = d.front_wheel_rate * v.track_front**2 / 2 + d.front_roll_arb
    roll_r = p.rear_static_rate * v.leaf_spacing**2 / 2 + d.rear_roll_arb
    h_rf, h_rr = roll_centre_heights(v)
    h_axis = h_rf + (h_rr - h_rf) * p.a / v.wheelbase
    arm = p.load.cg_z - h_axis
    w = p.load.sprung_mass * G
    gradient = w * arm / (roll_f + roll_r - w * arm)  # rad per g
    return {
        "freq_front": f_f,
        "freq_rear": f_r,
        "freq_ratio": f_f / f_r,
        "zeta_front": c_f / (2 * np.sqrt(kr_f * ms_f)),
        "zeta_rear": c_r / (2 * np.sqrt(kr_r * ms_r)),
        "roll_stiffness_front": roll_f,
        "roll_stiffness_rear": roll_r,
        "roll_stiffness_total": roll_f + roll_r,
        "roll_share_front": roll_f / (roll_f + roll_r),
        "roll_gradient": gradient,
        "static_defl_front": p.front_static_deflection,
        "static_defl_rear": p.rear_static_deflection,
    }


def suspension_figures(
    X: np.ndarray, vehicle: Minibus = REFERENCE_MINIBUS
) -> dict[str, dict[str, np.ndarray]]:
    """Routine figures of designs X (n, 8; study units): ``{load_case: {figure: (n,)}}``.

    Also ``"loading"``: front/rear extra spring travel from no load to full load (m) and
    the CoM shift (m, x rearward and z up).
    """
    X = check_designs(X)
    no = vehicle_parameters(X, "no_load", vehicle)
    full = vehicle_parameters(X, "full_load", vehicle)
    out = {"no_load": _axle_figures(no), "full_load": _axle_figures(full)}
    out["loading"] = {
        "travel_front": full.front_static_deflection - no.front_static_deflection,
        "travel_rear": full.rear_static_deflection - no.rear_static_deflection,
        "cg_shift_x": np.full(X.shape[0], full.load.cg_x - no.load.cg_x),
        "cg_shift_z": np.full(X.shape[0], full.load.cg_z - no.load.cg_z),
    }
    return out


#: (key, label, factor, format) of the Markdown table
_ROWS = (
    ("freq_front", "front natural frequency (Hz)", 1.0, "{:.2f}"),
    ("freq_rear", "rear natural frequency (Hz)", 1.0, "{:.2f}"),
    ("freq_ratio", "front/rear frequency ratio (-)", 1.0, "{:.3f}"),
    ("zeta_front", "front damping ratio (-)", 1.0, "{:.3f}"),
    ("zeta_rear", "rear damping ratio (-)", 1.0, "{:.3f}"),
    ("roll_stiffness_front", "front roll stiffness (kN*m/rad)", 1e-3, "{:.1f}"),
    ("roll_stiffness_rear", "rear roll stiffness (kN*m/rad)", 1e-3, "{:.1f}"),
    ("roll_stiffness_total", "total roll stiffness (kN*m/rad)", 1e-3, "{:.1f}"),
    ("roll_share_front", "front share of roll stiffness (%)", 100.0, "{:.1f}"),
    ("roll_gradient", "roll gradient (deg/g)", 180 / np.pi, "{:.2f}"),
    ("static_defl_front", "front spring static deflection (mm)", 1e3, "{:.1f}"),
    ("static_defl_rear", "rear leaf static deflection (mm)", 1e3, "{:.1f}"),
)


def report_markdown(designs: Mapping[str, np.ndarray], vehicle: Minibus = REFERENCE_MINIBUS) -> str:
    """Markdown tables of the routine figures for named designs (study units, 8 values each)."""
    names = list(designs)
    X = np.vstack([np.asarray(designs[k], dtype=float).reshape(1, -1) for k in names])
    figs = suspension_figures(X, vehicle)
    h_rf, h_rr = roll_centre_heights(vehicle)
    lines = ["# Suspension report", "", "## Designs", ""]
    lines += table_lines(
        ["variable", *names],
        ([var, *(f"{v:.4g}" for v in X[:, j])] for j, var in enumerate(DESIGN_NAMES)),
    )
    for lc in ("no_load", "full_load"):
        lines += ["", f"## {lc.replace('_', ' ')}", ""]
        lines += table_lines(
            ["figure", *names],
            (
                [label, *(fmt.format(v) for v in figs[lc][key] * factor)]
                for key, label, factor, fmt in _ROWS
            ),
        )
    ld = figs["loading"]
    lines += ["", "## Loading (no load -> full load)", ""]
    lines += table_lines(
        ["figure", *names],
        (
            [label, *(f"{v * 1e3:.1f}" for v in ld[key])]
            for key, label in (
                ("travel_front", "front wheel travel (mm)"),
                ("travel_rear", "rear wheel travel (mm)"),
            )
        ),
    )
    lines += [
        "",
        f"CoM shift under load: {ld['cg_shift_x'][0] * 1e3:.0f} mm rearward, "
        f"{ld['cg_shift_z'][0] * 1e3:.0f} mm up.",
        "",
        f"Roll-centre heights (stated geometry): front {h_rf * 1e3:.0f} mm (wishbone instant "
        f"centre {vehicle.front_ic_inboard:.2f} m inboard of the contact patch, "
        f"{vehicle.front_ic_height * 1e3:.0f} mm high), rear {h_rr * 1e3:.0f} mm (leaf-seat line "
        "of the rigid axle).",
        "",
        "Natural frequencies use the ride rate (spring and tyre in series) and the sprung mass "
        "per side; damping ratios the mean low-speed bump/rebound coefficient; roll stiffness "
        "is the suspension's (tyres rigid); stabilisers are axle roll stiffness (T2, T3).",
        "",
    ]
    return "\n".join(lines)


def plot_elements(
    designs: Mapping[str, np.ndarray], path: Path, vehicle: Minibus = REFERENCE_MINIBUS
) -> Path:
    """PNG of each design's rear leaf force-deflection and front/rear damper curves."""
    d = np.linspace(0.0, 0.14, 200)
    v = np.linspace(-1.0, 1.0, 201)
    fig, axes = pyplot().subplots(1, 3, figsize=(13, 4))
    for name, x in designs.items():
        si = design_to_si(np.asarray(x, dtype=float), vehicle)
        axes[0].plot(d * 1e3, leaf_force(d, si.rear_primary_rate[0], si.rear_composite_rate[0],
                                         vehicle.helper_engagement) / 1e3, label=name)  # fmt: skip
        axes[1].plot(
            v, damper_force(v, vehicle.damper_front, si.front_damper_scale[0]) / 1e3, label=name
        )
        axes[2].plot(
            v, damper_force(v, vehicle.damper_rear, si.rear_damper_scale[0]) / 1e3, label=name
        )
    axes[0].set(
        xlabel="leaf deflection from free (mm)", ylabel="force (kN)", title="rear leaf, per side"
    )
    axes[1].set(xlabel="velocity (m/s, + bump)", ylabel="force (kN)", title="front damper at wheel")
    axes[2].set(xlabel="velocity (m/s, + bump)", ylabel="force (kN)", title="rear damper")
    for ax in axes:
        ax.grid(True, alpha=0.3)
        ax.legend()
    return save_figure(fig, path, dpi=110, tight=True)


def write_suspension_report(
    designs: Mapping[str, np.ndarray],
    out_dir: Path | str,
    vehicle: Minibus = REFERENCE_MINIBUS,
    plots: bool = True,
) -> list[Path]:
    """Write ``suspension_report.md`` and, with ``plots``, ``suspension_elements.png``
    into out_dir."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    md = out / "suspension_report.md"
    if not plots:
        write_file(md, report_markdown(designs, vehicle))
        return [md]
    png = plot_elements(designs, out / "suspension_elements.png", vehicle)
    write_file(md, report_markdown(designs, vehicle) + f"\n![suspension elements]({png.name})\n")
    return [md, png]
