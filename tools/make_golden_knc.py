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
"""

from __future__ import annotations

import json
import re
import sys
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


def objective_dict(results) -> dict[str, float]:
    F = objectives(results)[0]
    return {name: rounded(v) for name, v in zip(OBJECTIVE_NAMES, F, strict=True)}


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
                "channels": channel_dict(ref),
            },
            "test_car": {
                "recipe": "truth_vehicle_seed0_no_noise",
                "description": "truth_vehicle(seed=0, noise=False): the reference plus "
                "left/right tolerances and rubber hysteresis (Dahl), run with its effects",
                "objectives": objective_dict(car_res),
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
