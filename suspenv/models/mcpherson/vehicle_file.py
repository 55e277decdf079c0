"""McPherson vehicle files (TOML): read, validate and write.

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

    [bounds]                    # optional: identification bounds [low, high] (file units),
    strut_top_z = [550.0, 580.0]        # linear; a third element "log" maps the
    top_mount_kx = [500.0, 50000.0, "log"]  # unit interval logarithmically

    [orientation]               # optional: bushing frame, ADAMS 3-1-3 Euler angles [deg]
    lca_front = [0.0, 0.0, 0.0]

    [constants]                 # optional: AxleConstants fields (wheel_centre, ...)
    spring_rate = 25.0

    [[effects]]                 # optional, one table per element (none by default):
    kind = "dahl_hysteresis"    # an effects-library kind the solver places
    location = "lower_arm"      # a bushing, a group of bushings or "strut"
    f_c = 80.0                  # the element's parameters (SI units)

Missing design entries take the reference vehicle's values; unknown names are errors.
Design values are limited by physics only (:func:`~suspenv.models.mcpherson.params.
physics_errors`: finite, stiffnesses > 0, |camber|, |toe| < 10 deg; a linkage that
assembles: :func:`check_assembles`). A parameter without a ``[bounds]`` entry gets
:func:`~suspenv.models.mcpherson.params.default_bounds` around its nominal values.
Effects and their places: :mod:`suspenv.models.mcpherson.effects`.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, cast

import numpy as np

from suspenv.core.errors import EvaluationError, ValidationError
from suspenv.core.options import check_keywords, choice, number, optional, text
from suspenv.core.space import DesignSpace, Parameter
from suspenv.core.tomlfile import read_toml, toml_value
from suspenv.models.effects import Effect, get_kind
from suspenv.models.mcpherson.effects import LOCATIONS, PLACEMENTS, axle_effect
from suspenv.models.mcpherson.params import (
    BUSHINGS,
    N_PARAMETERS,
    PARAMETER_NAMES,
    Axle,
    AxleConstants,
    bounds_errors,
    build_axle,
    bushing_frames,
    default_bounds,
    design_parameters,
    design_physics_errors,
    design_space,
)
from suspenv.models.mcpherson.vehicle_checks import check_geometry, check_links

#: the reference vehicle shipped with suspenv (the paper's car with the paper's bounds)
VEHICLE_DIR = Path(__file__).resolve().parents[2] / "data" / "vehicles"
REFERENCE_FILE = VEHICLE_DIR / "mcpherson_reference.toml"
#: a shipped McPherson axle far from the paper's geometry (Project Chrono's generic
#: MacPherson strut hard points; see the file's description)
FAR_GEOMETRY_FILE = VEHICLE_DIR / "mcpherson_chrono_generic.toml"
KNOWN_KEYS = {
    "name",
    "description",
    "design",
    "design_right",
    "bounds",
    "orientation",
    "constants",
    "effects",
}
#: largest vehicle file read [bytes] (the reference file is about 5 KiB)
MAX_FILE_BYTES = 2**20


def check_vehicle_values(
    left: np.ndarray,
    right: np.ndarray,
    bounds: dict[str, tuple[float, float, bool]],
    orientation: dict[str, tuple[float, float, float]],
    where: str,
) -> None:
    """Refuse a vehicle's values that break a physical rule, each error naming ``where``,
    the parameter, the rule and the value: designs of shape (49,) on both sides with
    :func:`~suspenv.models.mcpherson.params.design_physics_errors`; every bounds entry a
    known parameter with :func:`~suspenv.models.mcpherson.params.bounds_errors` and both
    sides' nominal values inside it; orientations of known bushings, three finite angles."""
    for side, x in (("design", left), ("design_right", right)):
        if np.shape(x) != (N_PARAMETERS,):
            raise ValidationError(
                f"{where} [{side}] must hold {N_PARAMETERS} values, but got shape {np.shape(x)}"
            )
        errs = design_physics_errors(x)
        if errs:
            raise ValidationError(f"{where} [{side}]: {'; '.join(errs)}")
    check_keywords(f"{where} [bounds]", bounds, PARAMETER_NAMES, "parameter")
    for name, (lo, hi, log) in bounds.items():
        errs = bounds_errors(name, lo, hi, log)
        if errs:
            raise ValidationError(f"{where} [bounds]: {'; '.join(errs)}")
        i = PARAMETER_NAMES.index(name)
        for side, x in (("design", left), ("design_right", right)):
            if not lo <= x[i] <= hi:
                raise ValidationError(
                    f"{where} [bounds]: `low <= {name} <= high` must hold for the nominal "
                    f"value of [{side}], but got {name}={x[i]:g} outside [{lo:g}, {hi:g}]"
                )
    try:
        bushing_frames(orientation)
    except ValidationError as exc:
        raise ValidationError(f"{where} [orientation]: {exc}") from None


@dataclass
class VehicleFile:
    """Contents of a vehicle file: per-side designs (49,), constants, effects, bounds and
    bushing orientations (validated on construction: :func:`check_vehicle_values`).

    Attributes:
        left, right: design vectors (49,) in file units (ADAMS/Car, left-side convention).
        bounds: the file's explicit identification bounds, parameter -> (low, high, log)
            in file units; every other parameter gets ``default_bounds`` (see :meth:`space`).
        orientation: bushing -> ADAMS 3-1-3 Euler angles [deg] of its frame (left side;
            the right side mirrors it); a bushing not listed is parallel to the vehicle axes.
    """

    name: str
    left: np.ndarray
    right: np.ndarray
    constants: AxleConstants = field(default_factory=AxleConstants)
    effects: tuple[Effect, ...] = ()
    description: str = ""
    bounds: dict[str, tuple[float, float, bool]] = field(default_factory=dict)
    orientation: dict[str, tuple[float, float, float]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.left = np.asarray(self.left, dtype=float)
        self.right = np.asarray(self.right, dtype=float)
        self.bounds = {
            k: (float(lo), float(hi), bool(log)) for k, (lo, hi, log) in self.bounds.items()
        }
        # three angles per bushing (the shape is checked by check_vehicle_values)
        self.orientation = {
            k: cast(tuple[float, float, float], tuple(float(a) for a in np.ravel(v)))
            for k, v in self.orientation.items()
        }
        check_vehicle_values(
            self.left, self.right, self.bounds, self.orientation, f"vehicle {self.name!r}"
        )

    def axle(self) -> Axle:
        """The vehicle as a one-design :class:`Axle` (SI, ISO 8855)."""
        return build_axle(self.left[None, :], self.right[None, :], self.constants, self.orientation)

    def bounds_of(self, name: str) -> tuple[float, float, bool]:
        """(low, high, log) of parameter ``name``: the file's entry, else the default
        around the nominal values of both sides (:func:`default_bounds`)."""
        if name in self.bounds:
            return self.bounds[name]
        i = PARAMETER_NAMES.index(name)
        return default_bounds(name, (self.left[i], self.right[i]))

    def with_design(
        self, left: np.ndarray, right: np.ndarray | None = None, name: str | None = None
    ) -> VehicleFile:
        """This vehicle with new designs (49,) (``right`` defaults to ``left``), keeping
        its identification space: every bound of :meth:`space` becomes an explicit entry
        (default bounds would otherwise move with the new nominal values). E.g. an
        identified vehicle, written with :func:`dump_vehicle`."""
        space = self.space()
        bounds = {p.name: (p.low, p.high, p.log) for p in space.parameters}
        x = np.asarray(left, dtype=float)
        return dataclasses.replace(
            self,
            name=self.name if name is None else name,
            left=x,
            right=x.copy() if right is None else np.asarray(right, dtype=float),
            bounds=bounds,
        )

    def space(self) -> DesignSpace:
        """This vehicle's 49-parameter :class:`DesignSpace` (file units, left-side
        convention): bounds from :meth:`bounds_of`, default = the left design."""
        params = []
        for p, v in zip(design_parameters(), self.left, strict=True):
            lo, hi, log = self.bounds_of(p.name)
            desc = p.description.split(" (paper range")[0]
            params.append(Parameter(p.name, lo, hi, p.unit, log, float(v), desc))
        return DesignSpace(params)


def load_vehicle(path: str | Path, assemble: bool = False) -> VehicleFile:
    """Read a vehicle file; errors name the offending key, the rule and the value.

    Rules: the file is UTF-8 TOML of at most :data:`MAX_FILE_BYTES`; top-level keys are
    those of :data:`KNOWN_KEYS` (an unknown key, ``[design]`` name, constant, bound,
    bushing, effect kind, location or parameter is refused with the nearest valid
    names); ``name`` and ``description`` are text; every number is finite (TOML's
    ``inf`` and ``nan`` are refused); design values obey physics
    (:func:`check_vehicle_values`), not the paper's box; ``[bounds]`` entries are
    ``[low, high]`` or ``[low, high, "log"]`` holding both sides' nominal values;
    ``[orientation]`` entries are three angles [deg]; constants are numbers or
    ``[x, y, z]`` points obeying :class:`AxleConstants`'s rules. ``assemble=True`` also
    runs :func:`check_assembles` (a static solve).
    """
    path = Path(path)
    if not path.is_file():
        raise ValidationError(f"vehicle file {str(path)!r} does not exist")
    data = read_toml(path, f"vehicle file {str(path)!r}", MAX_FILE_BYTES)
    vehicle = vehicle_from_dict(data, path.name, path.stem)
    check_geometry(vehicle.axle(), vehicle.effects, f"vehicle file {path.name}")
    if assemble:
        check_assembles(vehicle)
    return vehicle


def vehicle_from_dict(data: dict[str, Any], where: str, default_name: str) -> VehicleFile:
    """A :class:`VehicleFile` from a parsed vehicle file (rules: :func:`load_vehicle`)."""
    check_keywords(f"vehicle file {where}", data, KNOWN_KEYS, "key")
    for key in ("name", "description"):
        optional(text, f"vehicle file {where}", key, data.get(key), empty=True)
    space = design_space()
    tables = {}
    for key in ("design", "design_right"):
        table = _table(data, key, where)
        check_keywords(f"vehicle file {where} [{key}]", table, space.names, "parameter")
        tables[key] = _floats(table, f"vehicle file {where} [{key}]")
    left = space.from_dict(tables["design"])
    right = left.copy()
    for k, v in tables["design_right"].items():
        right[space.index(k)] = v
    bounds = _bounds(_table(data, "bounds", where), where)
    orientation = _orientation(_table(data, "orientation", where), where)
    check_vehicle_values(left, right, bounds, orientation, f"vehicle file {where}")
    values = _constants(_table(data, "constants", where), where)  # refused with their place
    try:
        constants = AxleConstants.from_dict(values)
    except ValidationError as exc:
        raise ValidationError(f"vehicle file {where} [constants]: {exc}") from None
    return VehicleFile(
        str(data.get("name", default_name)),
        left,
        right,
        constants,
        _effects(data.get("effects", []), where),
        str(data.get("description", "")),
        bounds,
        orientation,
    )


def check_assembles(vehicle: VehicleFile) -> None:
    """Refuse a vehicle whose linkage has no static equilibrium, with the reason.

    Checks, in order: the geometry rules of
    :func:`~suspenv.models.mcpherson.vehicle_checks.check_links` on both corners (every
    point on its own side, the strut top at least 1 mm above the ball joint, every link
    at least 1 mm long); here, the lower ball joint of each corner more than 1e-6 m
    off the lower-arm pivot axis (the line of the two bushes); the ideal-joint linkage
    has a unique kinematic motion at the design position (the spring preload is sized on
    it); the compliant axle (with its effects) finds a static equilibrium on the rig pads
    (:class:`AxleSolver`, the rig's own first solve) with bushing deflections within the
    rig's plausibility limits.
    """
    from suspenv.models.mcpherson.solver import AxleSolver, lockup_text

    what = f"vehicle {vehicle.name!r} does not assemble"
    with np.errstate(all="ignore"):  # a degenerate strut line is reported below
        axle = vehicle.axle()
    check_links(axle, what)
    for side, name in enumerate(("left", "right")):
        p = {k: v[0, side] for k, v in axle.points.items()}  # [m]
        axis = p["lca_rear_bush"] - p["lca_front_bush"]
        arm = p["lower_ball_joint"] - p["lca_front_bush"]
        off = float(np.linalg.norm(np.cross(axis, arm)) / np.linalg.norm(axis))
        if not off > 1e-6:  # m
            raise ValidationError(
                f"{what}: the {name} lower ball joint must lie off the lower-arm pivot "
                f"axis, but it is {off * 1e3:.3g} mm from it"
            )
    try:
        with np.errstate(all="ignore"):
            solver = AxleSolver(axle, vehicle.effects)
            if not np.isfinite(solver.pad_static).all():
                raise ValidationError(
                    f"{what}: the ideal-joint linkage has no unique motion at the design "
                    "position (the spring preload is not finite)"
                )
            st, conv, _ = solver.solve(solver.initial_state(), solver.pad_static)
    except np.linalg.LinAlgError as exc:
        raise ValidationError(
            f"{what}: the ideal-joint linkage is singular at the design position ({exc})"
        ) from None
    except EvaluationError as exc:  # ConvergenceError, LockupError
        raise ValidationError(f"{what}: {exc}") from None
    if not conv.all():
        raise ValidationError(
            f"{what}: ConvergenceError: no static equilibrium at the design position (Newton "
            f"did not converge in {solver.maxit} iterations)"
        )
    for name, tr, rot, locked in solver.lockups(st):
        if locked.any():
            raise ValidationError(
                f"{what}: LockupError: at the static position "
                f"{lockup_text(name, float(tr.max()), float(rot.max()))}: the design cannot "
                "carry its static load"
            )


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
    at = f"vehicle file {where} [constants]"
    check_keywords(at, table, defaults, "constant")
    out: dict[str, Any] = {}
    for k, v in table.items():
        if isinstance(defaults[k], tuple):
            if not isinstance(v, list) or len(v) != 3:
                raise ValidationError(f"{at} {k} must be a point [x, y, z] (mm), but got {v!r}")
            out[k] = [number(at, k, x) for x in v]
        else:
            out[k] = number(at, k, v)
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
                f"vehicle file {where}: effect {i} must be an [[effects]] table, but got {table!r}"
            )
        missing = [k for k in ("kind", "location") if k not in table]
        if missing:
            raise ValidationError(f"vehicle file {where}: effect {i} has no {missing}")
        at = f"vehicle file {where}: effect {i}"
        kind = choice(at, "kind", table["kind"], tuple(PLACEMENTS))
        location = choice(at, "location", table["location"], tuple(LOCATIONS))
        name = optional(text, at, "name", table.get("name"), empty=True)
        params = {k: v for k, v in table.items() if k not in ("kind", "location", "name")}
        spec = get_kind(kind)
        unknown = [k for k in params if not spec.accepts(k)]
        check_keywords(f"{at} ({kind})", unknown, spec.parameter_names, "parameter")
        values = _floats(params, f"{at} ({kind})")
        out.append(axle_effect(kind, location, name, **values))
    return tuple(out)


def _floats(table: dict, where: str) -> dict[str, float]:
    """Every value of ``table`` as a finite float, refused as ``where``'s ``key``."""
    return {k: number(where, k, v) for k, v in table.items()}


def _bounds(table: dict[str, Any], where: str) -> dict[str, tuple[float, float, bool]]:
    """The ``[bounds]`` table: ``name = [low, high]`` or ``[low, high, "log"]`` (file units)."""
    at = f"vehicle file {where} [bounds]"
    check_keywords(at, table, PARAMETER_NAMES, "parameter")
    out = {}
    for k, v in table.items():
        scale = "linear"
        if isinstance(v, list) and len(v) == 3 and isinstance(v[2], str):
            scale = v[2]
            v = v[:2]
        if not isinstance(v, list) or len(v) != 2 or scale not in ("linear", "log"):
            raise ValidationError(
                f'{at} {k} must be [low, high] or [low, high, "log"] (file units), but got '
                f"{table[k]!r}"
            )
        out[k] = (number(at, f"{k} low", v[0]), number(at, f"{k} high", v[1]), scale == "log")
    return out


def _orientation(table: dict[str, Any], where: str) -> dict[str, tuple[float, float, float]]:
    """The ``[orientation]`` table: ``bushing = [a, b, c]`` ADAMS 3-1-3 Euler angles [deg]."""
    at = f"vehicle file {where} [orientation]"
    check_keywords(at, table, BUSHINGS, "bushing")
    out = {}
    for k, v in table.items():
        if not isinstance(v, list) or len(v) != 3:
            raise ValidationError(
                f"{at} {k} must be three Euler angles [a, b, c] (deg, body-fixed 3-1-3), but "
                f"got {v!r}"
            )
        a, b, c = (number(at, k, x) for x in v)
        out[k] = (a, b, c)
    return out


def _fmt(v: float) -> str:
    """A float as TOML text that reads back to the same float."""
    return repr(float(v))


def dump_vehicle(vehicle: VehicleFile) -> str:
    """TOML text of a vehicle that :func:`load_vehicle` reads back to the same vehicle:
    design (units as comments), right-side differences, the full identification bounds
    of :meth:`VehicleFile.space`, bushing orientations, every constant and the effects
    (scalar parameters only). Numbers are written exactly (``repr``)."""
    space = vehicle.space()
    lines = [f"name = {toml_value(vehicle.name)}"]
    if vehicle.description:
        lines.append(f"description = {toml_value(vehicle.description)}")
    lines += ["", "[design]  # ADAMS/Car convention: mm, x rearward, y right, z up; left side"]
    for p, v in zip(space.parameters, vehicle.left, strict=True):
        lines.append(f"{p.name} = {_fmt(v)}  # {p.unit}")
    diff = [
        (n, b)
        for n, a, b in zip(PARAMETER_NAMES, vehicle.left, vehicle.right, strict=True)
        if a != b
    ]
    if diff:
        lines += ["", "[design_right]  # right side, same (left-side) convention"]
        lines += [f"{n} = {_fmt(v)}" for n, v in diff]
    lines += ["", '[bounds]  # identification bounds [low, high] in file units; "log": log scale']
    for p in space.parameters:
        tail = ', "log"' if p.log else ""
        lines.append(f"{p.name} = [{_fmt(p.low)}, {_fmt(p.high)}{tail}]")
    if vehicle.orientation:
        lines += ["", "[orientation]  # bushing frames: ADAMS 3-1-3 Euler angles (deg), left side"]
        for k, (a, b, c) in vehicle.orientation.items():
            lines.append(f"{k} = [{_fmt(a)}, {_fmt(b)}, {_fmt(c)}]")
    lines += ["", "[constants]  # vehicle data that are not design variables (mm, N/mm, kg)"]
    for k, v in vehicle.constants.as_dict().items():
        text = f"[{', '.join(_fmt(x) for x in v)}]" if isinstance(v, tuple) else _fmt(v)
        lines.append(f"{k} = {text}")
    for e in vehicle.effects:
        lines += ["", "[[effects]]", f"kind = {toml_value(e.kind)}"]
        lines += [f"location = {toml_value(e.location)}", f"name = {toml_value(e.name)}"]
        for k, v in e.params.items():
            if np.ndim(v) != 0:
                raise ValidationError(
                    f"dump_vehicle: effect {e.name!r} parameter `{k}` must be a scalar to be "
                    f"written, but has shape {np.shape(v)}"
                )
            lines.append(f"{k} = {_fmt(v)}")
    return "\n".join(lines) + "\n"
