"""K&C rig loops as :class:`~suspenv.recordings.Recording` objects, and back.

One recording per rig test (travel: ``parallel``, ``opposite``, ``single``; compliance:
``lateral``, ``longitudinal``, see :mod:`suspenv.rigs.knc`) of one vehicle.
Every solved step of the loop design -> bump -> rebound -> design is one sample;
the rig is quasi-static, so ``time`` is the step index in seconds (1 s per step, a
bookkeeping axis only, stated in ``meta["time_axis"]``).

Frame ISO 8855 (x forward, y left, z up), SI units:

* inputs: ``pad_left`` / ``pad_right`` [m] pad travel from the static height (bump
  positive; zero in a compliance test), ``stroke`` [m] the left pad's stroke of a
  travel test or ``force`` [N] the contact-point force of a compliance test (along
  +y in ``lateral``, +x in ``longitudinal``, on both wheels), ``branch`` [-]
  (0 first leg design -> bump, 1 bump -> rebound, 2 rebound -> design; "bump" is the
  +amplitude end also in a compliance test) and ``grid`` [-] (grid index of the step);
* outputs, per side (suffix ``_left`` / ``_right``): ``toe`` [rad] (+ toe-in),
  ``camber`` [rad] (- top inboard), ``tyre_fz`` [N] (+ compression),
  ``contact_lateral`` [m] (contact-point y, *outboard* positive on each side, so a
  symmetric axle gives equal left and right values in parallel travel) and
  ``contact_x`` [m] (contact-point x, forward positive).

``recording.meta`` holds ``rig = "knc"``, the test, amplitude ([m] for a travel test,
[N] for a compliance test, named in ``meta["amplitude_unit"]``) and steps, which a
model needs to replay the same loop. ``recording.test`` is ``"knc_<test>"``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.recordings import Recording
from suspenv.rigs.knc import (
    ALL_TESTS,
    FORCE_AMPLITUDE,
    FORCE_TESTS,
    TESTS,
    KCResult,
    loop_path,
    pad_offsets,
    stroke_grid,
)

SIDES = ("left", "right")
#: recorded channels: name -> (rig channel, unit, outboard sign flip on the right)
CHANNELS: dict[str, tuple[str, str, bool]] = {
    "toe": ("toe", "rad", False),
    "camber": ("camber", "rad", False),
    "tyre_fz": ("tyre_fz", "N", False),
    "contact_lateral": ("contact_y", "m", True),
    "contact_x": ("contact_x", "m", False),
}
INPUTS = ("pad_left", "pad_right", "stroke", "branch", "grid")
#: inputs of a compliance test (``force`` in place of ``stroke``)
FORCE_INPUTS = ("pad_left", "pad_right", "force", "branch", "grid")
TEST_PREFIX = "knc_"


def output_names(channels: Sequence[str] = tuple(CHANNELS)) -> tuple[str, ...]:
    """Recorded output names, ``<channel>_<side>``."""
    return tuple(f"{c}_{s}" for c in channels for s in SIDES)


def branch_index(steps: int) -> np.ndarray:
    """Branch of every step of the loop: 0 design->bump, 1 bump->rebound, 2 rebound->design."""
    i0 = steps // 2
    n1 = steps - i0 + 1  # design .. bump, inclusive
    n2 = steps  # bump-1 .. rebound
    n3 = i0  # rebound+1 .. design
    return np.r_[np.zeros(n1), np.ones(n2), np.full(n3, 2.0)]


def is_knc(rec: object) -> bool:
    """True for a K&C rig recording (``meta["rig"] == "knc"`` or test ``knc_*``)."""
    meta = getattr(rec, "meta", {}) or {}
    return meta.get("rig") == "knc" or str(getattr(rec, "test", "")).startswith(TEST_PREFIX)


def rig_test(rec: Recording) -> str:
    """The rig test (``parallel`` ...) of a K&C recording."""
    test = str(rec.meta.get("knc_test", rec.test.removeprefix(TEST_PREFIX)))
    if test not in ALL_TESTS:
        raise ValidationError(
            f"recording {rec.name!r}: the K&C test must be one of {ALL_TESTS}, but got {test!r}"
        )
    return test


def is_force_test(rec: Recording) -> bool:
    """True for a compliance (contact-point force) recording."""
    return rig_test(rec) in FORCE_TESTS


def drive(rec: Recording, side: str) -> np.ndarray:
    """Each wheel's own excitation along the loop, over the test's amplitude [-].

    Travel test: the pad's travel (bump positive). Compliance test: the contact-point
    force in the wheel's own sense (outboard positive in ``lateral``, so the two
    wheels of a +y force see opposite signs; forward positive in ``longitudinal``).
    A symmetric axle gives equal left and right channels at equal drive.
    """
    amp = float(rec.meta["amplitude"])
    if not is_force_test(rec):
        return np.asarray(rec.inputs[f"pad_{side}"], float) / amp
    f = np.asarray(rec.inputs["force"], float) / amp
    return -f if (rig_test(rec) == "lateral" and side == "right") else f


def reading_drive(rec: Recording, side: str) -> np.ndarray:
    """The drive a wheel's channels are read against [-]: its own :func:`drive`, or,
    for the wheel that has none (the still wheel of single-wheel travel), the left
    wheel's."""
    own = drive(rec, side)
    return own if own.any() else drive(rec, "left")


def mirrored(rec: Recording) -> bool:
    """True when the right wheel's own drive is the left wheel's reversed (opposite
    travel, lateral force): equal own drive then sits at mirrored grid points."""
    return bool(np.allclose(drive(rec, "right"), -drive(rec, "left")) and drive(rec, "left").any())


def drive_label(rec: Recording) -> tuple[str, float]:
    """(axis label, factor from SI to the plotted unit) of a recording's drive."""
    if is_force_test(rec):
        what = "outboard" if rig_test(rec) == "lateral" else "forward"
        return f"own {what} contact force [kN]", 1e-3
    if rig_test(rec) == "single":
        return "left pad travel [mm] (the right pad stays)", 1e3
    return "own pad travel [mm]", 1e3


def channels_of(result: KCResult, row: int = 0) -> dict[str, np.ndarray]:
    """Recorded outputs of design ``row`` of a rig result: ``<channel>_<side>`` -> (P,)."""
    out = {}
    for name, (rig_name, _, flip) in CHANNELS.items():
        v = np.asarray(result.channels[rig_name][row], float)  # (P, 2)
        for j, side in enumerate(SIDES):
            out[f"{name}_{side}"] = -v[:, j] if (flip and j == 1) else v[:, j]
    return out


def to_recording(
    result: KCResult,
    row: int = 0,
    name: str | None = None,
    amplitude: float | None = None,
    meta: Mapping | None = None,
) -> Recording:
    """The loop of design ``row`` of ``result`` as a :class:`Recording`."""
    if not bool(np.asarray(result.ok)[row]):
        raise ValidationError(
            f"design row {row} failed the {result.test} test: {result.messages[row]}"
        )
    steps = result.grid.size - 1
    amp = float(amplitude if amplitude is not None else result.grid[-1])
    s = result.grid[result.path]
    force = result.test in FORCE_TESTS
    pads = pad_offsets(result.test, s)  # zero in a compliance test
    drive_key = "force" if force else "stroke"
    inputs = {
        "pad_left": pads[:, 0],
        "pad_right": pads[:, 1],
        drive_key: s,
        "branch": branch_index(steps),
        "grid": result.path.astype(float),
    }
    units = {"pad_left": "m", "pad_right": "m", drive_key: result.unit, "branch": "-", "grid": "-"}
    for c, (_, unit, _) in CHANNELS.items():
        for side in SIDES:
            units[f"{c}_{side}"] = unit
    info = {
        "rig": "knc",
        "knc_test": result.test,
        "amplitude": amp,
        "amplitude_unit": result.unit,
        "steps": int(steps),
        "time_axis": "step index (quasi-static rig; 1 s per step)",
        "frame": "ISO 8855; lateral channels outboard positive on each side",
    }
    info.update(dict(meta or {}))
    return Recording(
        name or f"knc_{result.test}",
        TEST_PREFIX + result.test,
        np.arange(s.size, dtype=float),
        inputs,
        channels_of(result, row),
        units,
        info,
    )


def to_recordings(
    results: Mapping[str, KCResult], row: int = 0, prefix: str = "", meta: Mapping | None = None
) -> dict[str, Recording]:
    """One recording per test: ``{test: Recording}``."""
    return {
        t: to_recording(r, row, f"{prefix}{t}" if prefix else None, meta=meta)
        for t, r in results.items()
    }


def from_recording(rec: Recording) -> KCResult:
    """The recording as a one-design :class:`KCResult` (only the recorded channels)."""
    test = rig_test(rec)
    steps = int(rec.meta["steps"])
    grid = stroke_grid(float(rec.meta["amplitude"]), steps)
    path = loop_path(steps)
    if rec.n_samples != path.size:
        raise ValidationError(
            f"recording {rec.name!r}: a loop of {steps} steps has {path.size} samples, "
            f"but the recording has {rec.n_samples}"
        )
    chans = {}
    for name, (rig_name, _, flip) in CHANNELS.items():
        key = [f"{name}_{s}" for s in SIDES]
        if not all(k in rec.outputs for k in key):
            continue
        left, right = (np.asarray(rec.outputs[k], float) for k in key)
        chans[rig_name] = np.stack([left, -right if flip else right], axis=-1)[None]
    return KCResult(test, grid, path, chans, np.ones(1, bool), [""])


def grid_of(rec: Recording) -> tuple[np.ndarray, np.ndarray]:
    """(grid index (P,) int, branch (P,) int) of a K&C recording."""
    return rec.inputs["grid"].astype(int), rec.inputs["branch"].astype(int)


def half_loops(rec: Recording, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A channel along the loop split into its two branches on the grid.

    Returns ``(down, up)``, each ``(steps + 1,)`` ordered by grid index: ``down`` is
    the bump -> rebound branch, ``up`` the rebound -> bump branch (rebound -> design,
    then the first leg design -> bump).
    """
    steps = int(rec.meta["steps"])
    gi, br = grid_of(rec)
    v = np.asarray(values, float)
    down = np.full(steps + 1, np.nan)
    up = np.full(steps + 1, np.nan)
    sel_d = br == 1
    down[gi[sel_d]] = v[sel_d]
    down[steps] = v[np.flatnonzero(gi == steps)[0]]  # the bump end starts the descent
    sel_u = br != 1
    up[gi[sel_u]] = v[sel_u]
    up[0] = v[np.flatnonzero(gi == 0)[0]]
    return down, up


# ------------------------------------------------------------------ measured K&C data
#: concealed effects a truth vehicle may carry, with their default magnitudes
TRUTH_EFFECTS: dict[str, dict] = {
    "hysteresis": {"f_c": 80.0, "bushings": ("lca_front", "lca_rear", "top_mount")},
    "friction": {"f_c": 120.0},
    "progressive": {"ratio": 0.2, "bushings": ("lca_front", "lca_rear", "arb_bush", "top_mount")},
    "asymmetry": {"hard_point_tol_mm": 1.0, "stiffness_tol": 0.10, "alignment_tol_deg": 0.05},
    "sensor_gain": {"gain": 1.04},
    "sensor_offset": {"offset": 10.0},
}
#: the diagnosis' effect kind that names each concealed effect
TRUTH_KIND = {
    "hysteresis": "dahl_hysteresis",
    "friction": "coulomb_friction",
    "progressive": "cubic_stiffness",
    "asymmetry": "lr_asymmetry",
    "sensor_gain": "sensor_gain",
    "sensor_offset": "sensor_offset",
}


def truth_axle_effects(effects: Mapping[str, Mapping]) -> object:
    """The solver's effects of a truth description (see :data:`TRUTH_EFFECTS`)."""
    from suspenv.models.mcpherson import AxleEffects

    unknown = sorted(set(effects) - set(TRUTH_EFFECTS))
    if unknown:
        raise ValidationError(
            f"truth effects must be among {sorted(TRUTH_EFFECTS)}, but got {unknown}"
        )
    kw: dict = {}
    if "hysteresis" in effects:
        h = {**TRUTH_EFFECTS["hysteresis"], **effects["hysteresis"]}
        kw.update(
            hysteresis_bushings=tuple(h["bushings"]),
            hysteresis_fc_force=float(h["f_c"]),
            hysteresis_fc_moment=0.05 * float(h["f_c"]),
        )
    if "friction" in effects:
        kw["strut_friction"] = float({**TRUTH_EFFECTS["friction"], **effects["friction"]}["f_c"])
    if "progressive" in effects:
        p = {**TRUTH_EFFECTS["progressive"], **effects["progressive"]}
        kw.update(cubic_bushings=tuple(p["bushings"]), cubic_ratio=float(p["ratio"]))
    return AxleEffects(**kw)


def measure_truth(
    effects: Mapping[str, Mapping] | None = None,
    seed: int = 0,
    amplitude: float = 0.040,
    steps: int = 8,
    noise_scale: float = 1.0,
    tests: Sequence[str] = TESTS,
    design: np.ndarray | None = None,
    force_amplitude: float = FORCE_AMPLITUDE,
) -> dict[str, Recording]:
    """ "Measured" K&C recordings of a truth vehicle with concealed ``effects`` (seeded).

    ``effects`` maps names of :data:`TRUTH_EFFECTS` to (partial) magnitudes, e.g.
    ``{"hysteresis": {"f_c": 100.0}}``; ``{}`` is the plain reference vehicle.
    ``noise_scale`` multiplies the rig's sensor noise (``0`` gives exact loops).
    ``amplitude`` [m] is the travel tests' stroke, ``force_amplitude`` [N] the
    compliance tests' force.
    """
    from suspenv.models.mcpherson.truth import CHANNEL_NOISE, truth_vehicle
    from suspenv.rigs.knc import run_tests

    effects = dict(effects or {})
    if noise_scale < 0:
        raise ValidationError(f"`noise_scale >= 0` must hold, but got {noise_scale}")
    tol = {**TRUTH_EFFECTS["asymmetry"], **effects.get("asymmetry", {})}
    truth = truth_vehicle(
        seed,
        base=design,
        tolerance="asymmetry" in effects,
        noise=False,
        hard_point_tol_mm=float(tol["hard_point_tol_mm"]),
        stiffness_tol=float(tol["stiffness_tol"]),
        alignment_tol_deg=float(tol["alignment_tol_deg"]),
        effects=truth_axle_effects(effects),
    )
    results = run_tests(
        truth.axle(),
        tuple(tests),
        amplitude=amplitude,
        steps=steps,
        effects=truth.effects,
        force_amplitude=force_amplitude,
    )
    gain = (
        float({**TRUTH_EFFECTS["sensor_gain"], **effects["sensor_gain"]}["gain"])
        if ("sensor_gain" in effects)
        else 1.0
    )
    offset = (
        float({**TRUTH_EFFECTS["sensor_offset"], **effects["sensor_offset"]}["offset"])
        if ("sensor_offset" in effects)
        else 0.0
    )
    rng = np.random.default_rng(20_000 + seed)
    for test in sorted(results):
        res = results[test]
        if not res.ok.all():
            raise ValidationError(f"the truth vehicle fails the {test} test: {res.messages[0]}")
        res.channels["tyre_fz"] = res.channels["tyre_fz"] * gain + offset
        for name in sorted(CHANNEL_NOISE):
            ch = res.channels[name]
            res.channels[name] = ch + rng.normal(0.0, noise_scale * CHANNEL_NOISE[name], ch.shape)
    info = {"source": "suspenv truth vehicle (concealed effects)", "seed": int(seed)}
    return to_recordings(results, meta=info)


# ------------------------------------------------------------------ blind cases
BLIND_KINDS = (
    "hysteresis",
    "friction",
    "progressive",
    "asymmetry",
    "sensor_gain",
    "sensor_offset",
)
#: hysteresis locations of the truth (bushings with Dahl elements), by short name
HYSTERESIS_LOCATIONS = {
    "all": ("lca_front", "lca_rear", "top_mount"),
    "lower_arm": ("lca_front", "lca_rear"),
    "top_mount": ("top_mount",),
}
#: single-effect case types: every truth kind, the hysteresis at each location
SINGLE_TYPES = (
    "hysteresis@all",
    "hysteresis@lower_arm",
    "hysteresis@top_mount",
    "friction",
    "progressive",
    "asymmetry",
    "sensor_gain",
    "sensor_offset",
)
#: two-effect case types (fixed pairs covering every kind)
PAIR_TYPES = (
    "hysteresis@lower_arm+sensor_gain",
    "friction+asymmetry",
    "progressive+sensor_offset",
    "hysteresis@all+asymmetry",
    "friction+sensor_gain",
    "hysteresis@top_mount+sensor_offset",
)
#: the fixed cycle of case types: seed -> ``BLIND_PLAN[seed % len(BLIND_PLAN)]``; any
#: ``len(BLIND_PLAN)`` consecutive seeds hold each single type 3 times, each pair once
#: and 6 no-effect controls (36 cases)
BLIND_PLAN: tuple[str, ...] = tuple(
    t
    for i in range(6)
    for t in (
        SINGLE_TYPES[(4 * i) % 8],
        "none",
        SINGLE_TYPES[(4 * i + 1) % 8],
        PAIR_TYPES[i],
        SINGLE_TYPES[(4 * i + 2) % 8],
        SINGLE_TYPES[(4 * i + 3) % 8],
    )
)


def case_type(seed: int) -> str:
    """The blind case type of ``seed``: ``"none"``, a kind (``"friction"``,
    ``"hysteresis@top_mount"`` ...) or two joined by ``+`` (see :data:`BLIND_PLAN`)."""
    return BLIND_PLAN[int(seed) % len(BLIND_PLAN)]


def _draw_effect(kind: str, rng: np.random.Generator) -> tuple[str, dict]:
    """One concealed effect of ``kind`` (``name[@location]``) with a random magnitude."""
    name, _, where = kind.partition("@")
    if name == "hysteresis":
        return name, {
            "f_c": float(rng.uniform(50.0, 150.0)),
            "bushings": list(HYSTERESIS_LOCATIONS[where or "all"]),
        }
    if name == "friction":
        return name, {"f_c": float(rng.uniform(60.0, 250.0))}
    if name == "progressive":
        return name, {"ratio": float(rng.uniform(0.1, 0.5))}
    if name == "asymmetry":
        s = float(rng.uniform(0.6, 1.5))
        return name, {
            "hard_point_tol_mm": 1.0 * s,
            "stiffness_tol": 0.10 * s,
            "alignment_tol_deg": 0.05 * s,
        }
    if name == "sensor_gain":
        return name, {"gain": float(1.0 + rng.choice([-1, 1]) * rng.uniform(0.02, 0.06))}
    if name == "sensor_offset":
        return name, {"offset": float(rng.choice([-1, 1]) * rng.uniform(3.0, 20.0))}
    raise ValidationError(f"blind effect kinds must be among {BLIND_KINDS}, but got {kind!r}")


def blind_truth(seed: int) -> dict:
    """Concealed effects of blind case ``seed``: the type from :func:`case_type`,
    magnitudes, hysteresis location and noise level drawn from the seed."""
    rng = np.random.default_rng(seed)
    ctype = case_type(seed)
    effects: dict[str, dict] = {}
    for kind in [] if ctype == "none" else ctype.split("+"):
        name, values = _draw_effect(kind, rng)
        effects[name] = values
    return {
        "seed": int(seed),
        "case_type": ctype,
        "effects": effects,
        "expected_kinds": sorted(TRUTH_KIND[k] for k in effects),
        "noise_scale": float(rng.uniform(0.5, 2.0)),
    }


#: rig tests of a blind case: the three travel tests and the two compliance tests
BLIND_TESTS = ALL_TESTS


def blind_case(
    seed: int, steps: int = 8, amplitude: float = 0.040, tests: Sequence[str] = BLIND_TESTS
) -> tuple[dict, dict]:
    """``(case, truth)``: the case holds only the recordings; the truth is kept apart."""
    truth = blind_truth(seed)
    recs = measure_truth(
        truth["effects"], seed, amplitude, steps, noise_scale=truth["noise_scale"], tests=tests
    )
    case = {
        "id": f"knc-blind-{seed}",
        "recordings": {t: r for t, r in recs.items()},
    }
    for r in case["recordings"].values():
        r.meta.pop("seed", None)
        r.name = f"knc-blind-{seed}:{rig_test(r)}"
    return case, truth


def write_blind_case(seed: int, case_dir: str, truth_dir: str, steps: int = 8) -> list[str]:
    """Write a blind case (``<test>.npz``) and, in another folder, its ``truth.json``."""
    import json
    from pathlib import Path

    from suspenv.recordings import save_recording

    case, truth = blind_case(seed, steps)
    cdir, tdir = Path(case_dir), Path(truth_dir)
    cdir.mkdir(parents=True, exist_ok=True)
    tdir.mkdir(parents=True, exist_ok=True)
    paths = []
    for test, rec in case["recordings"].items():
        p = cdir / f"{test}.npz"
        save_recording(rec, p)
        paths.append(str(p))
    tp = tdir / f"knc-blind-{seed}.truth.json"
    tp.write_text(json.dumps(truth, indent=2))
    paths.append(str(tp))
    return paths
