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

import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.models.effects import Effect
from suspenv.models.mcpherson.effects import axle_effect
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
    """Read a vehicle file; errors name the offending key."""
    path = Path(path)
    if not path.is_file():
        raise ValidationError(f"vehicle file {str(path)!r} does not exist")
    try:
        data = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise ValidationError(f"vehicle file {str(path)!r} is not valid TOML: {exc}") from None
    unknown = sorted(set(data) - KNOWN_KEYS)
    if unknown:
        raise ValidationError(
            f"vehicle file {path.name}: unknown key(s) {unknown}; allowed are {sorted(KNOWN_KEYS)}"
        )
    space = design_space()
    left = space.from_dict(_floats(data.get("design", {}), "design"))
    right = left.copy()
    for k, v in _floats(data.get("design_right", {}), "design_right").items():
        right[space.index(k)] = v
    for side, x in (("design", left), ("design_right", right)):
        out = space.outside_bounds(x)
        if out:
            raise ValidationError(f"vehicle file {path.name} [{side}]: {'; '.join(out)}")
    constants = AxleConstants.from_dict(data.get("constants", {}))
    return VehicleFile(
        str(data.get("name", path.stem)),
        left,
        right,
        constants,
        _effects(data.get("effects", []), path.name),
        str(data.get("description", "")),
    )


def _effects(tables: Any, where: str) -> tuple[Effect, ...]:
    """The ``[[effects]]`` tables as axle effects (kind, location, optional name, values)."""
    if not isinstance(tables, list):
        raise ValidationError(
            f"vehicle file {where}: `effects` must be [[effects]] tables (kind, location and "
            f"the element's parameters), but got {type(tables).__name__}"
        )
    out = []
    for i, table in enumerate(tables):
        missing = [k for k in ("kind", "location") if k not in table]
        if missing:
            raise ValidationError(f"vehicle file {where}: effect {i} has no {missing}")
        params = {k: v for k, v in table.items() if k not in ("kind", "location", "name")}
        values = _floats(params, f"effects {i}")
        out.append(
            axle_effect(str(table["kind"]), str(table["location"]), table.get("name"), **values)
        )
    return tuple(out)


def _floats(table: dict, where: str) -> dict[str, float]:
    out = {}
    for k, v in table.items():
        if not isinstance(v, int | float) or isinstance(v, bool):
            raise ValidationError(f"[{where}] {k} must be a number, but got {v!r}")
        out[k] = float(v)
    return out


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
