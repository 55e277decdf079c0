"""What ``suspenv diagnose TARGET`` diagnoses: the family, the recordings, the held-out data.

A target is one of:

* ``knc-blind:SEED``: a generated blind K&C case (its truth is not shown); a folder of
  K&C recordings (``*.npz`` with ``meta["rig"] == "knc"``) or one of them (its folder's
  other K&C recordings come with it): the K&C family; ``--holdout`` names rig test(s)
  (default ``single``) or another ``.npz``;
* ``road_profile`` / ``road_profile_1`` / ``road_profile_2`` (the shared measured
  profiles, fitted on one and validated on the other) or a ``*.txt`` profile (distance
  [m], elevation [m]): the road spectral test; ``--holdout`` another profile (default:
  the second half of the same one);
* a ride recording (``.npz`` whose test is ``pulse`` or ``random_road``) or a folder of
  them (recordings named ``*run1`` are fitted, the others held out): the ride family;
* a real-data name (``emps``, ``mr_damper``, ``damper_dyno``; :mod:`suspenv.measurements.catalog`)
  or any recording file :func:`suspenv.measurements.read_recording` reads: the component
  family of ``--model`` (default: the recording's suggested model).

Only the chosen family's modules are imported.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from suspenv.core.errors import ValidationError

if TYPE_CHECKING:
    from suspenv.measurements import Recording

BLIND_PREFIX = "knc-blind:"
RIDE_TESTS = ("pulse", "random_road")
ROAD_NAMES = ("road_profile", "road_profile_1", "road_profile_2")


@dataclass
class Target:
    """A resolved target: ``family`` is ``"knc"``, ``"ride"``, ``"road"`` or a component
    model family; ``holdout`` is in that family's terms; ``stem`` names the output."""

    family: str
    recordings: Any
    holdout: Any
    stem: str


def resolve_target(
    target: str,
    holdout: str | None = None,
    model: str | None = None,
    data_dir: str | Path | None = None,
) -> Target:
    """The family, recordings and held-out data of ``target`` (see the module docstring)."""
    read = _Reader()
    knc = _knc_target(target, holdout, read)
    if knc is not None:
        return knc
    road = _road_target(target, holdout, data_dir)
    if road is not None:
        return road
    ride = _ride_target(target, holdout, read)
    if ride is not None:
        return ride
    return _component_target(target, holdout, model, data_dir, read)


class _Reader:
    """Reads each recording file once per resolution: the routing looks at a file as a
    K&C, a ride and a component recording in turn (:func:`suspenv.measurements.read_recording`)."""

    def __init__(self) -> None:
        self._read: dict[Path, Recording] = {}

    def __call__(self, path: str | Path) -> Recording:
        from suspenv.measurements import read_recording

        key = Path(path).resolve()
        if key not in self._read:
            self._read[key] = read_recording(key)
        return self._read[key]


def _npz_files(target: str) -> list[Path]:
    p = Path(target)
    if p.is_dir():
        return sorted(p.glob("*.npz"))
    return [p] if p.suffix == ".npz" and p.is_file() else []


def _knc_holdout(holdout: str | None, read: _Reader) -> list[Any]:
    """Rig test name(s) (comma-separated; default ``single``) or another ``.npz``."""
    held = holdout or "single"
    if held.endswith(".npz"):
        return [read(held)]
    return [h.strip() for h in held.split(",") if h.strip()]


def _knc_target(target: str, holdout: str | None, read: _Reader) -> Target | None:
    from suspenv.measurements.knc import is_knc, rig_test

    if target.startswith(BLIND_PREFIX):
        text = target[len(BLIND_PREFIX) :]
        if not text.isdigit():
            raise ValidationError(f"`knc-blind:SEED` needs an integer seed, but got {text!r}")
        from suspenv.rigs.knc_truth import blind_case

        case, _ = blind_case(int(text))
        return Target("knc", case["recordings"], _knc_holdout(holdout, read), f"knc_blind_{text}")
    files = _npz_files(target)
    if not files or not is_knc(read(files[0])):
        return None
    folder = Path(target) if Path(target).is_dir() else Path(target).parent
    recs = [r for r in (read(f) for f in sorted(folder.glob("*.npz"))) if is_knc(r)]
    held = _knc_holdout(holdout, read)
    return Target("knc", {rig_test(r): r for r in recs}, held, folder.name or "knc")


def _road_target(target: str, holdout: str | None, data_dir: str | Path | None) -> Target | None:
    if target not in ROAD_NAMES and not target.endswith(".txt"):
        return None
    from suspenv.measurements.sources.road_profile import load_profile_txt

    if target in ROAD_NAMES:
        from suspenv.measurements.catalog import real_data_dir

        root = Path(data_dir) if data_dir else real_data_dir()
        root = root / "road_profiles" if (root / "road_profiles").is_dir() else root
        first = "profile_2.txt" if target.endswith("_2") else "profile_1.txt"
        second = "profile_1.txt" if first == "profile_2.txt" else "profile_2.txt"
        if not (root / first).is_file():
            raise ValidationError(f"road profiles not found in {str(root)!r} (need {first})")
        rec = load_profile_txt(root / first)
        return Target("road", rec, load_profile_txt(root / second), rec.name)
    rec = load_profile_txt(target)
    held = load_profile_txt(holdout) if holdout and str(holdout).endswith(".txt") else None
    return Target("road", rec, held, rec.name)


def _ride_recordings(path: Path, read: _Reader) -> list[Any] | None:
    files = _npz_files(str(path))
    if not files:
        return None
    recs = [read(f) for f in files]
    return recs if all(r.test in RIDE_TESTS for r in recs) else None


def _ride_target(target: str, holdout: str | None, read: _Reader) -> Target | None:
    path = Path(target)
    recs = _ride_recordings(path, read) if path.exists() else None
    if recs is None:
        return None
    if holdout is not None and str(holdout).endswith(".npz"):
        return Target("ride", recs, _ride_recordings(Path(holdout), read) or [], path.stem)
    return Target("ride", recs, None, path.stem)


def _component_target(
    target: str,
    holdout: str | None,
    model: str | None,
    data_dir: str | Path | None,
    read: _Reader,
) -> Target:
    from suspenv.measurements.catalog import REAL_CASES, real_data_dir

    held: Any
    family: str | None
    if target in REAL_CASES:
        root = Path(data_dir) if data_dir else real_data_dir()
        if not root.is_dir():
            raise ValidationError(f"real recordings folder {str(root)!r} does not exist")
        rec, held, family, _ = REAL_CASES[target](root)
        stem = target
    else:
        path = Path(target)
        if not path.is_file():
            raise ValidationError(
                "TARGET must be a recording file, a folder of K&C or ride recordings, "
                f"knc-blind:SEED, a road profile or one of {sorted(REAL_CASES)}, "
                f"but got {target!r}"
            )
        rec = read(path)
        rig_meta = rec.meta.get("rig")
        rig: dict[str, Any] = rig_meta if isinstance(rig_meta, dict) else {}
        suggested = rec.meta.get("suggested_model") or rig.get("device") or rig.get("family")
        # held-out data: the family's default (interleaved motion cycles)
        held, family, stem = None, str(suggested) if suggested else None, path.stem
    if holdout is not None:
        try:
            held = float(holdout)
        except ValueError:
            held = holdout if holdout.startswith("cycles") else read(holdout)
    chosen = model or family or _guess_family(rec)
    return Target(str(chosen), rec, held, stem)


def _guess_family(rec: Any) -> str:
    names = set(rec.inputs)
    if "acceleration" in names and "position" in names:
        return "friction_guide"
    raise ValidationError(
        f"cannot tell the component family of recording {rec.name!r} (inputs {sorted(names)}); "
        "pass --model damper | mr_damper | friction_guide | quarter_car_rig"
    )
