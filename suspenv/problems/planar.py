"""PlanarLinkage: find the 2-D hard points of a front-view linkage that meet a target.

Frame and units: see :mod:`suspenv.models.planar.geometry` (front view of the left
wheel, y outboard from the centreline, z up from the ground). Design variables are
hard-point coordinates in mm, named ``"<point>.y"`` / ``"<point>.z"``, each within
``+-span`` mm of the baseline geometry.

Two targets:

- *curves* (default, identification): reproduce the camber and half-track-change curves
  of a target geometry over ``+-travel`` mm. One objective, ``curve_error`` =
  ``sqrt(mean((d_camber / camber_scale)^2 + (d_track / track_scale)^2))`` over the
  travel points (dimensionless; 1 = errors of one scale unit everywhere). No constraints.
- *camber gain* (``target_camber_gain`` in deg/m): reach that camber gain at the design
  position. Objective ``camber_gain_error`` = |gain - target| (deg/m). Constraints
  (feasible when <= 0): the largest half-track change over the sweep must stay within
  ``max_half_track_change`` mm, and the design roll-centre height within
  ``roll_centre_range`` mm.

The analytic solver is the default (vectorised over the whole batch); ``solver="pymunk"``
runs the independent pymunk simulation one design at a time (about a second each).
Linkages that lock up within the travel come back as failed rows with the reason.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from suspenv.core import DesignSpace, EvaluationBatch, Parameter, Problem
from suspenv.core.errors import ValidationError
from suspenv.core.options import choice, integer, nearest, number, numbers, positive, text, texts
from suspenv.models.planar.analytic import PlanarSweep, solve_sweep
from suspenv.models.planar.geometry import PlanarGeometry, load_geometry
from suspenv.models.planar.outputs import SweepOutputs, sweep_outputs
from suspenv.registry import report_function

#: hard-point coordinates free by default, per kind of linkage
DEFAULT_VARIABLES = {
    "double_wishbone": (
        "lower_inner.y",
        "lower_inner.z",
        "upper_inner.y",
        "upper_inner.z",
        "upper_outer.y",
        "upper_outer.z",
    ),
    "mcpherson": ("lower_inner.y", "lower_inner.z", "strut_top.y", "strut_top.z"),
}
SOLVERS = ("analytic", "pymunk")
#: the curves of :class:`SweepOutputs` over travel, each with its unit
CURVE_UNITS = {
    "camber_deg": "deg",
    "half_track_mm": "mm",
    "roll_centre_mm": "mm",
    "motion_ratio": "-",
    "wheel_load_N": "N",
    "wheel_rate_N_per_mm": "N/mm",
}


class PlanarLinkage(Problem):
    """Front-view double wishbone or McPherson strut: hard points for a target curve.

    Args (every rule is checked at construction, before any evaluation):
        geometry: baseline linkage, a bundled name (``suspenv planar --list``) or a TOML
            path. Fixes every coordinate that is not a design variable.
        target: geometry whose camber and half-track curves are the target (curves mode);
            default ``"<kind>_target"``. Not together with ``target_camber_gain``.
        target_camber_gain: deg/m, finite; switches to the camber-gain target.
        variables: free coordinates, a non-empty list, e.g. ``["upper_inner.y",
            "upper_inner.z"]``.
        span: mm, half-width of each variable's range around the baseline; finite, > 0.
        travel: mm, the sweep covers ``[-travel, +travel]`` (rebound negative); finite, > 0.
        n_travel: points in the sweep, an odd integer >= 3 (so the design position is one
            of them).
        solver: ``"analytic"`` (default) or ``"pymunk"``.
        camber_scale: deg, camber error counted as one unit in ``curve_error``; finite, > 0.
        track_scale: mm, half-track error counted as one unit in ``curve_error``; finite,
            > 0.
        max_half_track_change: mm, constraint in camber-gain mode; finite, > 0.
        roll_centre_range: (low, high) mm, design roll-centre height, camber-gain mode;
            two finite numbers, low < high.
    """

    name = "PlanarLinkage"
    description = "front-view double wishbone / McPherson: 2-D hard points for a target camber"

    def __init__(
        self,
        geometry: str = "double_wishbone",
        target: str | None = None,
        target_camber_gain: float | None = None,
        variables: Sequence[str] | None = None,
        span: float = 40.0,
        travel: float = 60.0,
        n_travel: int = 61,
        solver: str = "analytic",
        camber_scale: float = 0.1,
        track_scale: float = 1.0,
        max_half_track_change: float = 10.0,
        roll_centre_range: Sequence[float] = (0.0, 150.0),
    ):
        owner = self.name
        if isinstance(geometry, Path):
            geometry = str(geometry)
        geometry = text(owner, "geometry", geometry)
        target = None if target is None else text(owner, "target", target)
        camber_gain = (
            None
            if target_camber_gain is None
            else number(owner, "target_camber_gain", target_camber_gain)
        )
        if target is not None and camber_gain is not None:
            raise ValidationError(
                f"{owner}: give `target` (curves) or `target_camber_gain` (camber gain), not "
                f"both, but got target={target!r} and target_camber_gain={camber_gain!r}"
            )
        variables = None if variables is None else texts(owner, "variables", variables, empty=False)
        self._set_sweep(solver, span, travel, n_travel)
        self._set_scales(camber_scale, track_scale, max_half_track_change, roll_centre_range)
        self.baseline = load_geometry(geometry)
        if self.baseline.batch_shape:
            raise ValidationError(f"{owner}: the baseline must be a single geometry")
        self.geometry_name = geometry
        self.travel = 1e-3 * np.linspace(-self.travel_mm, self.travel_mm, self.n_travel)
        kind = self.baseline.kind
        self.variables = tuple(variables) if variables is not None else DEFAULT_VARIABLES[kind]
        self.space = DesignSpace([self._parameter(v) for v in self.variables])
        self.target_camber_gain = camber_gain
        self._set_target(target)

    def _set_sweep(self, solver: str, span: float, travel: float, n_travel: int) -> None:
        """Check and keep the solver and the sweep's options (see the class docstring)."""
        owner = self.name
        self.solver = choice(owner, "solver", solver, SOLVERS)
        self.span = positive(owner, "span", span)
        self.travel_mm = positive(owner, "travel", travel)
        self.n_travel = integer(owner, "n_travel", n_travel)
        if self.n_travel < 3 or self.n_travel % 2 == 0:
            raise ValidationError(
                f"{owner}: `n_travel` must be an odd integer >= 3, but got n_travel={n_travel!r}"
            )

    def _set_scales(
        self,
        camber_scale: float,
        track_scale: float,
        max_half_track_change: float,
        roll_centre_range: Sequence[float],
    ) -> None:
        """Check and keep the error scales and the camber-gain mode's limits."""
        owner = self.name
        self.camber_scale = positive(owner, "camber_scale", camber_scale)
        self.track_scale = positive(owner, "track_scale", track_scale)
        self.max_half_track_change = positive(owner, "max_half_track_change", max_half_track_change)
        rc_lo, rc_hi = numbers(owner, "roll_centre_range", roll_centre_range, 2)
        if not rc_lo < rc_hi:
            raise ValidationError(
                f"{owner}: `roll_centre_range` must be (low, high) with low < high, but got "
                f"roll_centre_range=({rc_lo}, {rc_hi})"
            )
        self.roll_centre_range = (rc_lo, rc_hi)

    def _parameter(self, variable: str) -> Parameter:
        """The design variable ``"<point>.y"`` or ``"<point>.z"``: mm, ``+-span`` around
        the baseline's coordinate."""
        base = self.baseline.points_mm()
        point, _, axis = variable.partition(".")
        if point not in base or axis not in ("y", "z"):
            near = nearest(point, base)
            hint = f"; did you mean '{near}.{axis or 'y'}'?" if near and near != point else ""
            raise ValidationError(
                f"{self.name}: variable {variable!r} must be '<point>.y' or '<point>.z' with "
                f"point in {sorted(base)} ({self.baseline.kind}){hint}"
            )
        centre = base[point][0 if axis == "y" else 1]
        return Parameter(
            variable,
            centre - self.span,
            centre + self.span,
            unit="mm",
            default=centre,
            description=f"{axis} of {point.replace('_', ' ')}",
        )

    def _set_target(self, target: str | None) -> None:
        """The target curves (curves mode: ``target`` or ``"<kind>_target"``) or none (a
        camber-gain target), with the objectives and constraints of the mode."""
        kind = self.baseline.kind
        self.target_name: str | None
        self.target_geometry: PlanarGeometry | None
        self.target_outputs: SweepOutputs | None
        if self.target_camber_gain is not None:
            self.target_name = None
            self.target_geometry = None
            self.target_outputs = None
            self.objective_names = ("camber_gain_error",)
            self.objective_units = ("deg/m",)
            self.constraint_names = (
                "half_track_change_excess",
                "roll_centre_below_range",
                "roll_centre_above_range",
            )
            return
        self.target_name = target or f"{kind}_target"
        self.target_geometry = load_geometry(self.target_name)
        if self.target_geometry.kind != kind:
            raise ValidationError(
                f"{self.name}: target geometry must be a {kind}, but {self.target_name!r} is a "
                f"{self.target_geometry.kind}"
            )
        target_sweep = solve_sweep(self.target_geometry, self.travel)
        if not bool(target_sweep.ok):
            raise ValidationError(
                f"target geometry {self.target_name!r} cannot travel +-{self.travel_mm} mm: "
                f"{target_sweep.messages[0]}"
            )
        self.target_outputs = sweep_outputs(self.target_geometry, target_sweep)
        self.objective_names = ("curve_error",)
        self.objective_units = ("-",)
        self.constraint_names = ()

    # ------------------------------------------------------------ geometry
    def geometry(self, X: np.ndarray) -> PlanarGeometry:
        """The (batched) geometry of physical designs X (n, d) in mm."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        return self.baseline.with_points_mm(
            {name: X[:, j] for j, name in enumerate(self.space.names)}
        )

    # ------------------------------------------------------------ evaluation
    def _evaluate(self, X: np.ndarray) -> EvaluationBatch:
        geom = self.geometry(X)
        n = X.shape[0]
        if self.solver == "analytic":
            with np.errstate(all="ignore"):
                sw = solve_sweep(geom, self.travel)
                out = sweep_outputs(geom, sw)
            ok, messages = np.asarray(sw.ok, bool), list(sw.messages)
        else:
            out, ok, messages = self._pymunk_outputs(geom, n)
        with np.errstate(all="ignore"):
            objectives, constraints, extras = self._score(out)
        finite = np.isfinite(objectives).all(axis=1) & np.isfinite(constraints).all(axis=1)
        for i in np.flatnonzero(ok & ~finite):
            messages[i] = "EvaluationError: non-finite outputs (degenerate linkage)"
        ok = ok & finite
        objectives[~ok] = np.nan
        constraints[~ok] = np.nan
        return EvaluationBatch(objectives, constraints, ok, messages, extras)

    def _pymunk_outputs(
        self, geom: PlanarGeometry, n: int
    ) -> tuple[SweepOutputs, np.ndarray, list]:
        from suspenv.models.planar.pymunk_model import simulate_sweep

        arrays = {f: np.full((n, self.travel.size), np.nan) for f in CURVE_UNITS}
        gain = np.full(n, np.nan)
        ok = np.zeros(n, bool)
        messages = [""] * n
        for i in range(n):
            g = geom.take(i)
            try:
                o = sweep_outputs(g, simulate_sweep(g, self.travel))
            except Exception as exc:  # noqa: BLE001 - a failed row is a value
                messages[i] = f"{type(exc).__name__}: {exc}"
                continue
            for f in CURVE_UNITS:
                arrays[f][i] = getattr(o, f)
            gain[i] = o.camber_gain_deg_per_m
            ok[i] = True
        out = SweepOutputs(travel_mm=1e3 * self.travel, camber_gain_deg_per_m=gain, ok=ok, **arrays)
        return out, ok, messages

    def _score(self, out: SweepOutputs) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
        i0 = self.n_travel // 2
        extras = {
            "camber_gain_deg_per_m": np.asarray(out.camber_gain_deg_per_m, float),
            "roll_centre_mm": out.roll_centre_mm[:, i0],
            "max_half_track_change_mm": np.max(np.abs(out.half_track_mm), axis=1),
            "wheel_rate_N_per_mm": out.wheel_rate_N_per_mm[:, i0],
        }
        n = out.camber_deg.shape[0]
        if self.target_outputs is not None:
            dc = out.camber_deg - self.target_outputs.camber_deg
            dt = out.half_track_mm - self.target_outputs.half_track_mm
            extras["camber_rms_deg"] = np.sqrt(np.mean(dc**2, axis=1))
            extras["track_rms_mm"] = np.sqrt(np.mean(dt**2, axis=1))
            err = np.sqrt(
                np.mean((dc / self.camber_scale) ** 2 + (dt / self.track_scale) ** 2, axis=1)
            )
            return err[:, None], np.zeros((n, 0)), extras
        gain_err = np.abs(extras["camber_gain_deg_per_m"] - self.target_camber_gain)
        lo, hi = self.roll_centre_range
        rc = extras["roll_centre_mm"]
        cons = np.c_[
            extras["max_half_track_change_mm"] - self.max_half_track_change,
            lo - rc,
            rc - hi,
        ]
        return gain_err[:, None], cons, extras

    # ------------------------------------------------------------ reporting
    def config(self) -> dict[str, Any]:
        return {
            "geometry": self.geometry_name,
            "target": self.target_name,
            "target_camber_gain": self.target_camber_gain,
            "variables": list(self.variables),
            "span": self.span,
            "travel": self.travel_mm,
            "n_travel": self.n_travel,
            "solver": self.solver,
            "camber_scale": self.camber_scale,
            "track_scale": self.track_scale,
            "max_half_track_change": self.max_half_track_change,
            "roll_centre_range": list(self.roll_centre_range),
        }

    def single_sweep(self, x: np.ndarray) -> tuple[PlanarGeometry, PlanarSweep, SweepOutputs]:
        """Geometry, analytic sweep and outputs of one physical design (1-D, mm)."""
        geom = self.geometry(np.asarray(x, dtype=float).reshape(1, -1)).take(0)
        with np.errstate(all="ignore"):
            sw = solve_sweep(geom, self.travel)
        return geom, sw, sweep_outputs(geom, sw)

    def render_rgb(self, x_physical: np.ndarray) -> np.ndarray:
        """The linkage of one design as an RGB array (H, W, 3) uint8
        (:func:`suspenv.reports.planar.render_rgb`)."""
        geom, sw, _ = self.single_sweep(x_physical)
        return report_function("planar_rgb")(geom, sw)

    def write_report(self, run_dir: Path, archive: Any) -> list[Path]:
        """Best design as a geometry TOML, a figure against baseline/target, a Markdown note
        (:func:`suspenv.reports.planar.write_planar_report`)."""
        return report_function("PlanarLinkage")(self, Path(run_dir), archive)
