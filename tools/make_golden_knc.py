"""Write ``tests/golden/knc_reference.json``: a snapshot of the 40 K&C objectives.

Run by hand from the repository root (the tests only read the file, they never run
this script)::

    . .venv/bin/activate && python tools/make_golden_knc.py

What it records (every number rounded to :data:`SIG_FIGS` significant figures):

* ``reference``: the reference vehicle of suspenv (the identified values of Tey et al.
  2014, Table 1, ``suspenv.models.mcpherson.reference_design()``), a mirrored axle
  without concealed effects: the 40 objectives by name, and the main channels of all
  five rig tests (parallel, opposite and single wheel travel; lateral and longitudinal
  compliance) on both branches of the loop, both wheels, at a handful of grid points;
* ``test_car``: the concealed-effect test car of the identification problem
  (``truth_vehicle(seed=0, noise=False)``: left/right manufacturing tolerances and
  rubber hysteresis, no sensor noise): the 40 objectives by name.

The rig runs with the identification problem's settings (+-40 mm pad stroke in 30
intervals, +-2500 N in the compliance tests). Regenerate only after a deliberate
change of a definition, and say why in the commit: the golden test guards against
unintended changes (a snapshot), it does not show that the numbers are right.

Tolerances (written beside the values, read by ``tests/test_knc_golden.py``), so that
the snapshot holds on any BLAS kernel, thread count or machine:

* a channel: the solver's tolerance on the state (:data:`SOLVER_TOLERANCE`: Newton stops
  when its correction is below 1e-6 m, 1e-5 rad, 0.1 N, and a row whose steps shrink by
  less than half gets a fresh Jacobian, so what is left is below the last correction;
  another machine's rounding can move the stopping point anywhere inside it; tyre
  forces through the tyre rate, 252 N/mm x 1e-6 m, and the multipliers: 1 N), plus the
  rounding of the stored number (:data:`SIG_FIGS`: 5e-7 relative);
* an objective: those channel tolerances carried through its definition (each channel
  sample the objective reads moved by its tolerance, one at a time, and the changes of
  the objective added in absolute value: the linear bound), plus float precision
  (:data:`FLOAT_MARGIN` times the same sum with each sample moved by its own rounding,
  ``eps |y|``), plus the stored rounding.
"""

from __future__ import annotations

import json
import re
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from suspenv.metrics.knc import OBJECTIVE_NAMES, objectives
from suspenv.models.mcpherson import build_axle, reference_design
from suspenv.models.mcpherson.truth import truth_vehicle
from suspenv.rigs.knc import ALL_TESTS, FORCE_AMPLITUDE, TESTS, run_tests

OUT = Path(__file__).resolve().parents[1] / "tests" / "golden" / "knc_reference.json"
SIG_FIGS = 7  # relative rounding error <= 5e-7, inside the test's rtol of 1e-6
AMPLITUDE_MM = 40.0
STEPS = 30
GRID_INDEX = (0, 9, 15, 21, 30)  # -40, -16, 0, +16, +40 mm (or -2500 .. +2500 N)
#: the solver's tolerance on a converged state (AxleSolver's xtol, rtol; forces: the
#: multipliers' 0.1 N with a margin for the stiff links, as tests/knc_checks.py), SI
SOLVER_TOLERANCE = {"m": 1e-6, "rad": 1e-5, "N": 1.0, "N*m": 0.01}
#: the SI unit of each channel the objectives read (metrics.knc.OBJECTIVE_CHANNELS)
CHANNEL_SI = {
    "toe": "rad",
    "camber": "rad",
    "caster": "rad",
    "wheel_centre_x": "m",
    "wheel_centre_y": "m",
    "wheel_centre_z": "m",
    "contact_x": "m",
    "contact_y": "m",
    "tyre_fz": "N",
    "pad_z": "m",
}
#: round-off of the arithmetic from channels to an objective, in units of eps |y| per
#: sample (a few operations per sample: fits, differences, ratios)
FLOAT_MARGIN = 64.0
#: relative rounding of a stored number (SIG_FIGS significant figures: half a unit of the
#: last figure)
STORED = 0.5 * 10.0 ** (1 - SIG_FIGS)
#: channel -> (scale from SI, unit) of the recorded channels (raw rig channels, ISO 8855)
CHANNELS = {
    "toe": (180.0 / np.pi, "deg"),
    "camber": (180.0 / np.pi, "deg"),
    "caster": (180.0 / np.pi, "deg"),
    "tyre_fz": (1.0, "N"),
    "wheel_centre_x": (1e3, "mm"),
    "wheel_centre_y": (1e3, "mm"),
    "wheel_centre_z": (1e3, "mm"),
    "contact_y": (1e3, "mm"),
}


def rounded(a) -> float | list:
    """``a`` (scalar or array) as nested lists of floats rounded to SIG_FIGS figures."""
    arr = np.asarray(a, dtype=float)
    if not np.isfinite(arr).all():
        raise SystemExit("non-finite value in the golden data; refusing to write it")
    if arr.ndim == 0:
        return float(f"{float(arr):.{SIG_FIGS}g}")
    return [rounded(x) for x in arr]


def _rounded1(v: float) -> float:
    """One number rounded to SIG_FIGS significant figures."""
    return float(f"{float(v):.{SIG_FIGS}g}")


def objective_dict(results) -> dict[str, float]:
    F = objectives(results)[0]
    return {name: rounded(v) for name, v in zip(OBJECTIVE_NAMES, F, strict=True)}


def _moved(results, test: str, name: str, step: np.ndarray) -> dict:
    """``results`` with one more design row per sample of channel ``name`` of ``test``:
    row ``k`` has that sample (path step, wheel) moved by ``step`` (P, 2)."""
    base = results[test]
    P = base.path.size
    rows = 2 * P
    out = dict(results)
    chans = {}
    for ch, v in base.channels.items():
        v = np.repeat(v[:1], rows, axis=0)
        if ch == name:
            k = np.arange(rows)
            v[k, k // 2, k % 2] += step[k // 2, k % 2]
        chans[ch] = v
    out[test] = replace(base, channels=chans, ok=np.ones(rows, bool), messages=[""] * rows)
    for t in results:
        if t != test:
            r = results[t]
            reps = {ch: np.repeat(v[:1], rows, axis=0) for ch, v in r.channels.items()}
            out[t] = replace(r, channels=reps, ok=np.ones(rows, bool), messages=[""] * rows)
    return out


def objective_tolerances(results) -> dict[str, float]:
    """Each objective's tolerance (module docstring): the channel tolerances and the
    float precision carried through its definition, plus the stored rounding."""
    F0 = objectives(results)[0]
    solver = np.zeros_like(F0)
    precision = np.zeros_like(F0)
    for test in TESTS:
        for name, si in CHANNEL_SI.items():
            y = results[test].channels[name][0]
            tol = np.full(y.shape, SOLVER_TOLERANCE[si])
            solver += np.abs(objectives(_moved(results, test, name, tol)) - F0).sum(axis=0)
            ulp = np.maximum(np.abs(y), 1e-300) * np.finfo(float).eps
            # the change per ulp, scaled up from a step of 1e6 ulp (above round-off)
            d = objectives(_moved(results, test, name, 1e6 * ulp)) - F0
            precision += np.abs(d).sum(axis=0) / 1e6 * FLOAT_MARGIN
    total = solver + precision + STORED * np.abs(F0)
    return {name: _rounded1(v) for name, v in zip(OBJECTIVE_NAMES, total, strict=True)}


def channel_tolerances() -> dict[str, float]:
    """Each snapshot channel's tolerance in its stored unit: the solver's tolerance
    (the stored rounding is added per value by the test)."""
    si = {"deg": "rad", "mm": "m", "N": "N"}
    return {
        name: _rounded1(SOLVER_TOLERANCE[si[unit]] * scale)
        for name, (scale, unit) in CHANNELS.items()
    }


def channel_dict(results) -> dict:
    idx = list(GRID_INDEX)
    out = {}
    for test in ALL_TESTS:
        res = results[test]
        if not res.ok.all():
            raise SystemExit(f"the {test} test failed: {res.messages}")
        grid_scale = 1e3 if res.unit == "m" else 1.0
        entry = {
            "grid": rounded(res.grid[idx] * grid_scale),
            "grid_unit": "mm" if res.unit == "m" else res.unit,
        }
        for branch in ("down", "up"):
            entry[branch] = {
                name: rounded(res.branch(name, branch)[0][idx] * scale)
                for name, (scale, _) in CHANNELS.items()
            }
        out[test] = entry
    return out


def main() -> int:
    ref = run_tests(
        build_axle(reference_design()[None, :]),
        ALL_TESTS,
        amplitude=AMPLITUDE_MM / 1e3,
        steps=STEPS,
        force_amplitude=FORCE_AMPLITUDE,
    )
    car = truth_vehicle(seed=0, noise=False)
    car_res = run_tests(car.axle(), TESTS, AMPLITUDE_MM / 1e3, STEPS, effects=car.effects)
    for res in car_res.values():
        if not res.ok.all():
            raise SystemExit(f"the test car failed: {res.messages}")
    data = {
        "header": {
            "what": "snapshot of the 40 K&C objectives (Tey et al. 2014) of the McPherson "
            "front axle and of the main rig channels; guards against regressions only",
            "generated_by": ". .venv/bin/activate && python tools/make_golden_knc.py",
            "read_by": "tests/test_knc_definitions.py",
            "rig": {
                "amplitude_mm": AMPLITUDE_MM,
                "steps": STEPS,
                "force_amplitude_N": FORCE_AMPLITUDE,
                "channels_at_grid_index": list(GRID_INDEX),
                "branches": "down = bump to rebound, up = rebound to design to bump",
            },
            "rounding": f"{SIG_FIGS} significant figures",
            "tolerance": "channel_tolerance: the solver's tolerance on a converged state "
            "(1e-6 m, 1e-5 rad, 1 N) in the stored unit; objective_tolerance (per vehicle): "
            "those carried through each objective's definition (linear bound over the "
            "samples it reads) plus 64 eps |y| per sample of float round-off; both plus "
            "5e-7 relative for the stored rounding (tools/make_golden_knc.py docstring)",
            "channel_tolerance": channel_tolerances(),
            "channel_units": {name: unit for name, (_, unit) in CHANNELS.items()},
            "channel_layout": "[grid point][wheel]; wheel 0 = left, 1 = right; raw ISO 8855 "
            "channels (x forward, y left, z up), not mapped outboard",
            "objective_units": "those of suspenv.metrics.knc.OBJECTIVE_UNITS",
        },
        "vehicles": {
            "reference": {
                "recipe": "reference",
                "description": "build_axle(reference_design()[None, :]): the reference "
                "vehicle (Tey et al. 2014 Table 1 values), mirrored, no concealed effects",
                "objectives": objective_dict(ref),
                "objective_tolerance": objective_tolerances(ref),
                "channels": channel_dict(ref),
            },
            "test_car": {
                "recipe": "truth_vehicle_seed0_no_noise",
                "description": "truth_vehicle(seed=0, noise=False): the reference plus "
                "left/right tolerances and rubber hysteresis (Dahl), run with its effects",
                "objectives": objective_dict(car_res),
                "objective_tolerance": objective_tolerances(car_res),
            },
        },
    }
    OUT.parent.mkdir(parents=True, exist_ok=True)
    text = json.dumps(data, indent=1)
    # one line per innermost list of numbers ([left, right] pairs, grids)
    text = re.sub(
        r"\[\s*([-0-9.eE+,\s]+?)\s*\]",
        lambda m: "[" + ", ".join(x.strip() for x in m.group(1).split(",")) + "]",
        text,
    )
    OUT.write_text(text + "\n")
    print(f"wrote {OUT}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
