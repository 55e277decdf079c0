"""McPherson vehicle files (TOML): read and write.

Units and frame of the file are those of the source paper (ADAMS/Car convention:
millimetres, x rearward, y to the right, z up; hard points of the *left* side, so y
is negative). Format::

    name = "reference"
    description = "..."

    [design]                    # the 49 design parameters, names as in design_space()
    lower_ball_joint_x = -15.4  # mm
    ...
    lca_front_kx = 9483.4       # N/mm (rotational: N*mm/deg)
    arb_torsion = 930.6         # N*m/rad
    static_camber = -0.52       # deg, negative = top of wheel inboard
    static_toe = 0.0032         # deg, positive = toe-in

    [design_right]              # optional: right-side values that differ, given in the
    tie_rod_outer_y = -643.7    # same left-side convention (mirrored by the model)

    [constants]                 # optional: AxleConstants fields (wheel_centre, ...)
    spring_rate = 25.0

    [[effects]]                 # optional, one table per element (none by default):
    kind = "dahl_hysteresis"    # an effects-library kind the solver places
    location = "lower_arm"      # a bushing, a group of bushings or "strut"
    f_c = 80.0                  # the element's parameters (SI units)

Missing design entries take the reference vehicle's values; unknown names are errors.
Effects and their places: :mod:`suspenv.models.mcpherson.effects`.
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.core.tomlfile import read_toml
from suspenv.models.effects import Effect, get_kind
from suspenv.models.mcpherson.effects import LOCATIONS, PLACEMENTS, axle_effect
from suspenv.models.mcpherson.params import (
    PARAMETER_NAMES,
    Axle,
    AxleConstants,
    build_axle,
    design_space,
)

#: the reference vehicle shipped with suspenv
REFERENCE_FILE = (
    Path(__file__).resolve().parents[2] / "data" / "vehicles" / "mcpherson_reference.toml"
)
KNOWN_KEYS = {"name", "description", "design", "design_right", "constants", "effects"}
#: largest vehicle file read [bytes] (the reference file is about 3 KiB)
MAX_FILE_BYTES = 2**20


@dataclass
class VehicleFile:
    """Contents of a vehicle file: per-side designs (49,), constants, effects."""

    name: str
    left: np.ndarray
    right: np.ndarray
    constants: AxleConstants = field(default_factory=AxleConstants)
    effects: tuple[Effect, ...] = ()
    description: str = ""

    def axle(self) -> Axle:
        return build_axle(self.left[None, :], self.right[None, :], self.constants)


def load_vehicle(path: str | Path) -> VehicleFile:
    """Read a vehicle file; errors name the offending key, the rule and the value.

    Rules: the file is UTF-8 TOML of at most :data:`MAX_FILE_BYTES`; top-level keys are
    those of :data:`KNOWN_KEYS` (an unknown key, ``[design]`` name, constant, effect
    kind, location or parameter is refused with the nearest valid names); ``name`` and
    ``description`` are text; every number is finite (TOML's ``inf`` and ``nan`` are
    refused); design values lie in their ranges (:func:`design_space`); constants are
    numbers or ``[x, y, z]`` points as in :class:`AxleConstants`.
    """
    path = Path(path)
    if not path.is_file():
        raise ValidationError(f"vehicle file {str(path)!r} does not exist")
    data = read_toml(path, f"vehicle file {str(path)!r}", MAX_FILE_BYTES)
    return vehicle_from_dict(data, path.name, path.stem)


def vehicle_from_dict(data: dict[str, Any], where: str, default_name: str) -> VehicleFile:
    """A :class:`VehicleFile` from a parsed vehicle file (rules: :func:`load_vehicle`)."""
    _known(set(data), KNOWN_KEYS, f"vehicle file {where}: unknown key")
    for key in ("name", "description"):
        if key in data and not isinstance(data[key], str):
            raise ValidationError(
                f"vehicle file {where}: `{key}` must be text, but got {data[key]!r}"
            )
    space = design_space()
    tables = {}
    for key in ("design", "design_right"):
        table = _table(data, key, where)
        _known(set(table), space.names, f"vehicle file {where} [{key}]: unknown parameter")
        tables[key] = _floats(table, f"vehicle file {where} [{key}]")
    left = space.from_dict(tables["design"])
    right = left.copy()
    for k, v in tables["design_right"].items():
        right[space.index(k)] = v
    for side, x in (("design", left), ("design_right", right)):
        out = space.outside_bounds(x)
        if out:
            raise ValidationError(f"vehicle file {where} [{side}]: {'; '.join(out)}")
    constants = AxleConstants.from_dict(_constants(_table(data, "constants", where), where))
    return VehicleFile(
        str(data.get("name", default_name)),
        left,
        right,
        constants,
        _effects(data.get("effects", []), where),
        str(data.get("description", "")),
    )


def _known(keys: set[str], known: set[str] | tuple[str, ...], what: str) -> None:
    """Refuse the first unknown key with the nearest known names."""
    for k in sorted(keys - set(known)):
        near = difflib.get_close_matches(k, sorted(known), n=3)
        hint = f"; did you mean {near}?" if near else ""
        raise ValidationError(f"{what} {k!r}{hint} (allowed: {sorted(known)})")


def _table(data: dict[str, Any], key: str, where: str) -> dict[str, Any]:
    table = data.get(key, {})
    if not isinstance(table, dict):
        raise ValidationError(
            f"vehicle file {where}: `{key}` must be a table ([{key}]), but got {table!r}"
        )
    return table


def _constants(table: dict[str, Any], where: str) -> dict[str, Any]:
    """The ``[constants]`` values checked against :class:`AxleConstants`: a point is a
    list of three finite numbers [mm], any other constant one finite number."""
    defaults = AxleConstants().as_dict()
    _known(set(table), set(defaults), f"vehicle file {where} [constants]: unknown constant")
    out: dict[str, Any] = {}
    for k, v in table.items():
        if isinstance(defaults[k], tuple):
            if not isinstance(v, list) or len(v) != 3:
                raise ValidationError(
                    f"vehicle file {where} [constants] {k} must be a point [x, y, z] (mm), "
                    f"but got {v!r}"
                )
            out[k] = [_number(x, f"vehicle file {where} [constants] {k}") for x in v]
        else:
            out[k] = _number(v, f"vehicle file {where} [constants] {k}")
    return out


def _effects(tables: Any, where: str) -> tuple[Effect, ...]:
    """The ``[[effects]]`` tables as axle effects (kind, location, optional name, values)."""
    if not isinstance(tables, list):
        raise ValidationError(
            f"vehicle file {where}: `effects` must be [[effects]] tables (kind, location and "
            f"the element's parameters), but got {type(tables).__name__}"
        )
    out = []
    for i, table in enumerate(tables):
        if not isinstance(table, dict):
            raise ValidationError(
                f"vehicle file {where}: effect {i} must be an [[effects]] table, but got "
                f"{table!r}"
            )
        missing = [k for k in ("kind", "location") if k not in table]
        if missing:
            raise ValidationError(f"vehicle file {where}: effect {i} has no {missing}")
        for key in ("kind", "location", "name"):
            if key in table and not isinstance(table[key], str):
                raise ValidationError(
                    f"vehicle file {where}: effect {i} `{key}` must be text, but got "
                    f"{table[key]!r}"
                )
        kind, location = table["kind"], table["location"]
        at = f"vehicle file {where}: effect {i}"
        _known({kind}, tuple(PLACEMENTS), f"{at}: unknown axle effect kind")
        _known({location}, tuple(LOCATIONS), f"{at}: unknown location")
        params = {k: v for k, v in table.items() if k not in ("kind", "location", "name")}
        spec = get_kind(kind)
        unknown = {k for k in params if not spec.accepts(k)}
        _known(unknown, spec.parameter_names, f"{at} ({kind}): unknown parameter")
        values = _floats(params, f"{at} ({kind})")
        out.append(axle_effect(kind, location, table.get("name"), **values))
    return tuple(out)


def _number(v: Any, where: str) -> float:
    """``v`` as a finite float; text, booleans, tables, inf and nan are refused."""
    if not isinstance(v, int | float) or isinstance(v, bool):
        raise ValidationError(f"{where} must be a number, but got {v!r}")
    x = float(v)
    if not math.isfinite(x):
        raise ValidationError(f"{where} must be finite, but got {v!r}")
    return x


def _floats(table: dict, where: str) -> dict[str, float]:
    """Every value of ``table`` as a finite float (:func:`_number`), named ``where key``."""
    return {k: _number(v, f"{where} {k}") for k, v in table.items()}


def dump_vehicle(vehicle: VehicleFile) -> str:
    """TOML text of a vehicle (design with units as comments, right-side differences)."""
    space = design_space()
    lines = [f'name = "{vehicle.name}"']
    if vehicle.description:
        lines.append(f'description = "{vehicle.description}"')
    lines += ["", "[design]  # ADAMS/Car convention: mm, x rearward, y right, z up; left side"]
    for p, v in zip(space.parameters, vehicle.left, strict=True):
        lines.append(f"{p.name} = {v:.6g}  # {p.unit}")
    diff = [
        (n, b)
        for n, a, b in zip(PARAMETER_NAMES, vehicle.left, vehicle.right, strict=True)
        if a != b
    ]
    if diff:
        lines += ["", "[design_right]  # right side, same (left-side) convention"]
        lines += [f"{n} = {v:.6g}" for n, v in diff]
    return "\n".join(lines) + "\n"
