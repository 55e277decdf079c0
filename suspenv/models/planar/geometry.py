"""Front-view (planar) suspension geometries: double wishbone and McPherson strut.

Frame, units and signs (used by every module of :mod:`suspenv.models.planar`):

- Front view of the LEFT wheel of a quarter vehicle, seen from the front, body fixed.
  ``y`` is lateral, measured from the vehicle centreline, positive outboard (this is
  ISO 8855 ``y`` (left) for the left wheel); ``z`` is up, zero on the ground plane at
  the design position. A point is the pair ``(y, z)``.
- SI units inside (m, rad, N). Geometry files and user-facing values use mm and deg;
  the conversion happens in :func:`geometry_from_dict` / :meth:`PlanarGeometry.points_mm`.
- Rotations are counter-clockwise positive in the (y, z) plane.
- Camber: angle of the wheel plane from the vertical, positive when the top of the
  wheel leans outboard; negative camber = top of the wheel towards the body.
- The tyre is a rigid disc seen edge-on: the contact point is the lowest point of the
  wheel plane, ``wheel_centre - radius * (sin(camber), cos(camber))``, and rests on a
  frictionless pad that moves vertically (wheel travel = pad displacement, bump positive).
- Spring and damper are coaxial (a coil-over); their length is measured between their
  two mounts, and compression is positive.

Every coordinate array may carry leading batch dimensions: a field of shape ``(..., 2)``
describes one geometry per leading index, so one object can hold a whole population.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, fields, replace
from importlib import resources
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.core.options import check_keywords, choice, number, numbers, positive, text
from suspenv.core.tomlfile import parse_toml, read_toml, toml_value

_MM = 1e-3


def _vec(value: Any, name: str) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if arr.shape[-1:] != (2,):
        raise ValidationError(
            f"point {name!r} must be a (y, z) pair (last axis of length 2), but got shape "
            f"{arr.shape}"
        )
    if not np.all(np.isfinite(arr)):
        raise ValidationError(f"point {name!r} must be finite, but got {arr.tolist()}")
    return arr


@dataclass(frozen=True)
class PlanarGeometry:
    """Common part of a front-view linkage (SI, see the module docstring for the frame).

    Attributes:
        lower_inner: lower-arm pivot on the body, (..., 2) m.
        lower_outer: lower ball joint on the upright, (..., 2) m.
        wheel_centre: wheel centre at the design position, (..., 2) m.
        tyre_radius: (...,) m, loaded radius of the rigid tyre disc.
        static_camber: (...,) rad, camber at the design position.
        spring_rate: (...,) N/m, coil spring stiffness.
        spring_preload: (...,) N, spring compression force at the design position.
        damping: (...,) N*s/m, damper coefficient (the pymunk model uses it to settle).
        name: label for plots and tables.
    """

    kind: ClassVar[str] = ""
    point_names: ClassVar[tuple[str, ...]] = ()
    #: points that move with the upright (the rest are on the body or on an arm)
    upright_points: ClassVar[tuple[str, ...]] = ()
    #: the coil-over's two mounts: (on the body, on the moving part)
    spring_points: ClassVar[tuple[str, str]] = ("", "")

    lower_inner: np.ndarray
    lower_outer: np.ndarray
    wheel_centre: np.ndarray
    tyre_radius: np.ndarray
    static_camber: np.ndarray
    spring_rate: np.ndarray
    spring_preload: np.ndarray
    damping: np.ndarray
    name: str = ""

    def __post_init__(self) -> None:
        for f in fields(self):
            if f.name == "name":
                continue
            v = getattr(self, f.name)
            if f.name in self.point_names:
                object.__setattr__(self, f.name, _vec(v, f.name))
            else:
                object.__setattr__(self, f.name, np.asarray(v, dtype=float))
        for name in _SCALARS:
            v = getattr(self, name)
            if not np.all(np.isfinite(v)):
                raise ValidationError(f"`{name}` must be finite, but got {np.ravel(v).tolist()}")
        r = self.tyre_radius
        if not np.all(r > 0):
            raise ValidationError(f"`tyre_radius > 0` must hold, but got {np.min(r)} m")
        if not np.all(self.spring_rate >= 0):
            raise ValidationError(
                f"`spring_rate >= 0` must hold, but got {np.min(self.spring_rate)} N/m"
            )
        if not np.all(self.damping >= 0):
            raise ValidationError(f"`damping >= 0` must hold, but got {np.min(self.damping)} N*s/m")
        if np.any(np.abs(self.static_camber) >= math.radians(45)):
            raise ValidationError(
                "`|static_camber| < 45 deg` must hold, but got "
                f"{math.degrees(float(np.max(np.abs(self.static_camber)))):.3g} deg"
            )

    # ----------------------------------------------------------------- derived
    @property
    def batch_shape(self) -> tuple[int, ...]:
        shapes = [getattr(self, n).shape[:-1] for n in self.point_names]
        shapes += [np.shape(getattr(self, n)) for n in _SCALARS]
        return tuple(np.broadcast_shapes(*shapes))

    @property
    def contact_point(self) -> np.ndarray:
        """Design contact point (..., 2) m: lowest point of the tilted wheel plane."""
        g = self.static_camber
        down = np.stack([np.sin(g), np.cos(g)], axis=-1)
        return self.wheel_centre - self.tyre_radius[..., None] * down

    def points_mm(self) -> dict[str, list[float]]:
        """Hard points in mm of a single (unbatched) geometry, for files and tables."""
        if self.batch_shape:
            raise ValidationError(
                f"points_mm needs a single geometry, but got batch shape {self.batch_shape}"
            )
        return {n: [round(float(c) / _MM, 9) for c in getattr(self, n)] for n in self.point_names}

    def to_dict(self) -> dict[str, Any]:
        """The geometry-file form (mm, deg, N/mm) of a single geometry."""
        return {
            "kind": self.kind,
            "name": self.name,
            "points": self.points_mm(),
            "wheel": {
                "tyre_radius": float(self.tyre_radius) / _MM,
                "static_camber": math.degrees(float(self.static_camber)),
            },
            "spring": {
                "rate": float(self.spring_rate) * _MM,
                "preload": float(self.spring_preload),
                "damping": float(self.damping),
            },
        }

    def with_points_mm(self, values: Mapping[str, float | np.ndarray]) -> PlanarGeometry:
        """A copy with coordinates replaced, keys ``"<point>.y"``/``"<point>.z"`` in mm.

        Values may be arrays (a batch); every other field broadcasts against them.
        """
        # point name -> (..., 2) array; typed Any because replace(**changes) is checked
        # against every field's type, including ``name: str``, which is never a key here
        changes: dict[str, Any] = {}
        for key, val in values.items():
            point, _, axis = key.partition(".")
            if point not in self.point_names or axis not in ("y", "z"):
                raise ValidationError(
                    f"coordinate keys must be '<point>.y' or '<point>.z' with point in "
                    f"{list(self.point_names)}, but got {key!r}"
                )
            base = changes.get(point, getattr(self, point))
            v = np.asarray(val, dtype=float) * _MM
            base = np.broadcast_to(base, np.broadcast_shapes(base.shape, v.shape + (2,))).copy()
            base[..., 0 if axis == "y" else 1] = v
            changes[point] = base
        return replace(self, **changes)

    def take(self, index: Any) -> PlanarGeometry:
        """One geometry (or a sub-batch) of a batched geometry."""
        shape = self.batch_shape
        out = {}
        for f in fields(self):
            if f.name == "name":
                continue
            v = getattr(self, f.name)
            tail = (2,) if f.name in self.point_names else ()
            out[f.name] = np.broadcast_to(v, shape + tail)[index]
        return replace(self, **out)


_SCALARS = ("tyre_radius", "static_camber", "spring_rate", "spring_preload", "damping")


@dataclass(frozen=True)
class DoubleWishbone(PlanarGeometry):
    """Double wishbone (SLA): two arms on the body, an upright between their outer joints.

    Extra attributes (all (..., 2) m at the design position):
        upper_inner: upper-arm pivot on the body.
        upper_outer: upper ball joint on the upright.
        spring_body: spring/damper mount on the body.
        spring_arm: spring/damper mount on the lower arm.
    """

    kind: ClassVar[str] = "double_wishbone"
    point_names: ClassVar[tuple[str, ...]] = (
        "lower_inner",
        "lower_outer",
        "upper_inner",
        "upper_outer",
        "wheel_centre",
        "spring_body",
        "spring_arm",
    )
    upright_points: ClassVar[tuple[str, ...]] = ("lower_outer", "upper_outer", "wheel_centre")
    spring_points: ClassVar[tuple[str, str]] = ("spring_body", "spring_arm")

    upper_inner: np.ndarray = None  # type: ignore[assignment]
    upper_outer: np.ndarray = None  # type: ignore[assignment]
    spring_body: np.ndarray = None  # type: ignore[assignment]
    spring_arm: np.ndarray = None  # type: ignore[assignment]


@dataclass(frozen=True)
class McPherson(PlanarGeometry):
    """McPherson strut: a lower arm and a strut rigidly fixed to the upright.

    The strut slides through its top mount: the strut axis, fixed in the upright, runs
    from ``strut_lower`` (a point on the axis fixed to the upright, the lower spring seat)
    through ``strut_top`` (pivot on the body). Spring length = |strut_top - strut_lower|.

    Extra attributes (all (..., 2) m at the design position):
        strut_top: top mount on the body.
        strut_lower: point on the strut axis fixed to the upright.
    """

    kind: ClassVar[str] = "mcpherson"
    point_names: ClassVar[tuple[str, ...]] = (
        "lower_inner",
        "lower_outer",
        "strut_top",
        "strut_lower",
        "wheel_centre",
    )
    upright_points: ClassVar[tuple[str, ...]] = ("lower_outer", "strut_lower", "wheel_centre")
    spring_points: ClassVar[tuple[str, str]] = ("strut_top", "strut_lower")

    strut_top: np.ndarray = None  # type: ignore[assignment]
    strut_lower: np.ndarray = None  # type: ignore[assignment]


#: the kinds of linkage the planar solvers understand, by their key
GEOMETRY_CLASSES: dict[str, type[PlanarGeometry]] = {c.kind: c for c in (DoubleWishbone, McPherson)}


# ---------------------------------------------------------------- file format
#: keys of a geometry file: top level, ``[wheel]`` and ``[spring]`` (``[points]`` keys are
#: the point names of the kind)
FILE_KEYS = ("kind", "name", "points", "wheel", "spring")
WHEEL_KEYS = ("tyre_radius", "static_camber")
SPRING_KEYS = ("rate", "preload", "damping")


def _table(owner: str, data: Mapping[str, Any], key: str, allowed: tuple[str, ...]) -> dict:
    """The sub-table ``key`` of a geometry file ({} when absent), its keys checked."""
    table = data.get(key, {})
    if not isinstance(table, Mapping):
        raise ValidationError(
            f"{owner}: `{key}` must be a table ([{key}]), but got {key}={table!r}"
        )
    if allowed:
        check_keywords(f"{owner} [{key}]", table, allowed, what="key")
    return dict(table)


def geometry_from_dict(data: Mapping[str, Any], source: str = "planar geometry") -> PlanarGeometry:
    """Build a geometry from the file form (see ``suspenv/data/planar/README.md``).

    Keys: ``kind``; optional ``name``; ``[points]`` with ``name = [y, z]`` in mm;
    ``[wheel]`` ``tyre_radius`` (mm) and ``static_camber`` (deg); ``[spring]`` ``rate``
    (N/mm), ``preload`` (N), ``damping`` (N*s/m). ``source`` names the file in messages.

    Rules: no keys or tables besides these (a misspelt one is refused with the nearest
    name); every point of the kind given, no other, each a pair of finite numbers;
    ``tyre_radius > 0``, ``-45 < static_camber < 45``, ``rate >= 0``, ``damping >= 0``,
    ``preload`` finite (negative: the spring is in tension at the design position);
    ``name`` a string.
    """
    owner = source
    if not isinstance(data, Mapping):
        raise ValidationError(f"{owner}: a geometry must be a table, but got {data!r}")
    check_keywords(owner, data, FILE_KEYS, what="key")
    kind = choice(owner, "kind", data.get("kind"), tuple(GEOMETRY_CLASSES))
    cls = GEOMETRY_CLASSES[kind]
    points = _table(owner, data, "points", ())
    unknown = [p for p in points if p not in cls.point_names]
    if unknown:
        check_keywords(f"{owner} [points] of a {kind}", unknown, cls.point_names, "point")
    missing = [p for p in cls.point_names if p not in points]
    if missing:
        raise ValidationError(
            f"{owner}: a {kind} geometry needs points {list(cls.point_names)}, but "
            f"missing={missing}, unknown={unknown}"
        )
    wheel = _table(owner, data, "wheel", WHEEL_KEYS)
    spring = _table(owner, data, "spring", SPRING_KEYS)
    kwargs: dict[str, Any] = {
        p: np.asarray(numbers(owner, f"points.{p}", points[p], 2), dtype=float) * _MM
        for p in cls.point_names
    }
    tyre_radius = positive(owner, "wheel.tyre_radius", wheel.get("tyre_radius", 300.0))
    camber = number(
        owner,
        "wheel.static_camber",
        wheel.get("static_camber", 0.0),
        lo=-45.0,
        hi=45.0,
        lo_open=True,
        hi_open=True,
    )
    kwargs.update(
        tyre_radius=tyre_radius * _MM,
        static_camber=math.radians(camber),
        spring_rate=number(owner, "spring.rate", spring.get("rate", 30.0), lo=0.0) / _MM,
        spring_preload=number(owner, "spring.preload", spring.get("preload", 3000.0)),
        damping=number(owner, "spring.damping", spring.get("damping", 3000.0), lo=0.0),
        name=text(owner, "name", data.get("name", kind), empty=True),
    )
    return cls(**kwargs)


def stack_geometries(geometries: list[PlanarGeometry]) -> PlanarGeometry:
    """One batched geometry (batch shape (n,)) from n single geometries of one kind."""
    if not geometries:
        raise ValidationError("stack_geometries needs at least one geometry, but got none")
    cls = type(geometries[0])
    kinds = sorted({g.kind for g in geometries})
    if len(kinds) > 1:
        raise ValidationError(f"geometries to stack must be of one kind, but got {kinds}")
    values = {
        f.name: np.stack([np.asarray(getattr(g, f.name), dtype=float) for g in geometries])
        for f in fields(cls)
        if f.name != "name"
    }
    return cls(**values, name=geometries[0].name)


def bundled_geometries() -> list[str]:
    """Names of the example geometries shipped in ``suspenv/data/planar``."""
    root = resources.files("suspenv") / "data" / "planar"
    return sorted(p.name[:-5] for p in root.iterdir() if p.name.endswith(".toml"))


def load_geometry(source: str | Path) -> PlanarGeometry:
    """Load a geometry from a TOML path or the name of a bundled example.

    Every key and value is checked (:func:`geometry_from_dict`); a file that is not valid
    TOML is a :class:`ValidationError` naming the file and the TOML error.
    """
    path = Path(source)
    if path.is_file():
        label = f"planar geometry {str(path)!r}"
        data = read_toml(path, label)
    else:
        name = str(source)
        bundled = resources.files("suspenv") / "data" / "planar" / f"{name}.toml"
        if not bundled.is_file():
            raise ValidationError(
                f"geometry {str(source)!r} is neither a file nor a bundled example "
                f"(bundled: {bundled_geometries()})"
            )
        label = f"planar geometry {name!r} (bundled)"
        data = parse_toml(bundled.read_bytes(), label)
    return geometry_from_dict(data, label)


def geometry_to_toml(geometry: PlanarGeometry) -> str:
    """The geometry-file text of a single geometry (inverse of :func:`load_geometry`)."""
    d = geometry.to_dict()
    lines = [
        "# front view of the left wheel: y outboard from the centreline, z up from the",
        "# ground, mm; camber in deg (negative = top of the wheel towards the body)",
        f"kind = {toml_value(d['kind'])}",
        f"name = {toml_value(d['name'])}",
        "",
        "[points]",
    ]
    for k, (y, z) in d["points"].items():
        lines.append(f"{k} = [{y!r}, {z!r}]")
    lines += ["", "[wheel]"]
    lines += [f"{k} = {v:.6g}" for k, v in d["wheel"].items()]
    lines += ["", "[spring]"]
    lines += [f"{k} = {v:.6g}" for k, v in d["spring"].items()]
    return "\n".join(lines) + "\n"
