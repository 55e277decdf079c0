"""pymunk model of a planar linkage, settled quasi-statically at each prescribed travel.

Frame, units and signs: see :mod:`suspenv.models.planar.geometry` (front view of the
left wheel, y outboard, z up, SI). pymunk is unit-free; we feed it metres, kilograms,
seconds and newtons. Gravity is off: the spring preload plays the static corner load.

This is an independent second solver, not a wrapper around :mod:`.analytic`: the arms
and the upright are rigid bodies with mass, joined by pivot joints; a McPherson strut is
a groove joint (the strut axis is a groove on the upright that slides and turns about a
pivot at the top mount); the coil-over is a pymunk damped spring. The tyre contact point
rides in a horizontal groove on a kinematic pad, so the pad fixes its height and lets it
slide sideways without friction. At each travel the pad is moved in small increments
and the simulation is stepped until the joints have closed and the bodies have stopped
(quasi-static). The wheel load is read from the pad groove's reaction impulse.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pymunk

from suspenv.core.errors import ConvergenceError, LockupError, ValidationError
from suspenv.models.planar.analytic import PlanarSweep
from suspenv.models.planar.geometry import DoubleWishbone, McPherson, PlanarGeometry


@dataclass(frozen=True)
class PymunkSettings:
    """Integration and settling settings.

    Attributes:
        dt: time step, s.
        iterations: constraint-solver iterations per step.
        max_increment: largest pad move between settles, m.
        position_tol: joint gap (m) below which the linkage counts as assembled.
        speed_tol: body speed (m/s, and rad/s times 1 m) below which it counts as at rest.
        max_steps: steps allowed to settle one increment before giving up.
        check_every: steps between convergence checks.
    """

    dt: float = 2e-3
    iterations: int = 60
    max_increment: float = 5e-3
    position_tol: float = 1e-8
    speed_tol: float = 1e-7
    max_steps: int = 20000
    check_every: int = 10


class PymunkLinkage:
    """One planar linkage built as a pymunk space (single geometry, not a batch)."""

    def __init__(self, geom: PlanarGeometry, settings: PymunkSettings | None = None):
        if geom.batch_shape:
            raise ValidationError(
                f"the pymunk model takes one geometry, but got batch shape {geom.batch_shape}"
            )
        if float(geom.spring_rate) <= 0:
            raise ValidationError(
                f"the pymunk model needs `spring_rate > 0`, but got {float(geom.spring_rate)}"
            )
        self.geom = geom
        self.settings = settings or PymunkSettings()
        self.space = pymunk.Space()
        self.space.gravity = (0.0, 0.0)
        self.space.iterations = self.settings.iterations
        self.space.damping = 1.0  # no velocity drag: it would bias the measured reactions
        self._pivots: list[tuple[pymunk.Body, tuple, pymunk.Body, tuple]] = []
        self._build()

    # --------------------------------------------------------------- building
    def _p(self, name: str) -> tuple[float, float]:
        v = getattr(self.geom, name) if name != "contact" else self.geom.contact_point
        return float(v[0]), float(v[1])

    def _body(self, names: list[str], mass: float) -> pymunk.Body:
        pts = np.array([self._p(n) for n in names])
        centre = pts.mean(axis=0)
        size = max(float(np.ptp(pts, axis=0).max()), 0.05)
        moment = mass * size**2 / 12.0
        body = pymunk.Body(mass, moment)
        body.position = (float(centre[0]), float(centre[1]))
        self.space.add(body)
        return body

    def _local(self, body: pymunk.Body, point: tuple[float, float]) -> tuple[float, float]:
        x, y = body.world_to_local(point)
        return x, y

    def _pivot(self, a: pymunk.Body, b: pymunk.Body, name: str) -> None:
        p = self._p(name)
        la, lb = self._local(a, p), self._local(b, p)
        self._add(pymunk.PivotJoint(a, b, la, lb))
        self._pivots.append((a, la, b, lb))

    def _add(self, constraint: pymunk.Constraint) -> pymunk.Constraint:
        constraint.error_bias = 1e-6  # fraction of a joint gap left after one second
        self.space.add(constraint)
        return constraint

    def _build(self) -> None:
        g, static = self.geom, self.space.static_body
        upright_names = [*g.upright_points, "contact"]
        if isinstance(g, DoubleWishbone):
            lower = self._body(["lower_inner", "lower_outer", "spring_arm"], 4.0)
            upper = self._body(["upper_inner", "upper_outer"], 2.0)
            upright = self._body(upright_names, 15.0)
            self._pivot(static, lower, "lower_inner")
            self._pivot(lower, upright, "lower_outer")
            self._pivot(static, upper, "upper_inner")
            self._pivot(upper, upright, "upper_outer")
            spring_on = lower
            self.bodies = {"lower_arm": lower, "upper_arm": upper, "upright": upright}
        elif isinstance(g, McPherson):
            lower = self._body(["lower_inner", "lower_outer"], 4.0)
            upright = self._body(upright_names, 20.0)
            self._pivot(static, lower, "lower_inner")
            self._pivot(lower, upright, "lower_outer")
            top, seat = np.array(self._p("strut_top")), np.array(self._p("strut_lower"))
            axis = (top - seat) / np.linalg.norm(top - seat)
            groove_end = top + 0.3 * axis  # the strut rod may slide 0.3 m past the top
            self.strut = self._add(
                pymunk.GrooveJoint(
                    upright,
                    static,
                    self._local(upright, tuple(seat)),
                    self._local(upright, tuple(groove_end)),
                    tuple(top),
                )
            )
            spring_on = upright
            self.bodies = {"lower_arm": lower, "upright": upright}
        else:
            raise ValidationError(f"unknown planar geometry type {type(g).__name__}")
        self.upright = upright
        a, b = (self._p(n) for n in g.spring_points)  # on the body, on ``spring_on``
        length0 = float(np.hypot(a[0] - b[0], a[1] - b[1]))
        k = float(g.spring_rate)
        self.spring = pymunk.DampedSpring(
            static,
            spring_on,
            a,
            self._local(spring_on, b),
            length0 + float(g.spring_preload) / k,  # free length: preload at design
            k,
            float(g.damping),
        )
        self.space.add(self.spring)
        self._spring_ends = (static, a, spring_on, self._local(spring_on, b))
        # the pad: a kinematic body with a horizontal groove the contact point rides in
        contact = self._p("contact")
        self.pad = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        self.pad.position = contact
        self.space.add(self.pad)
        self._contact_local = self._local(upright, contact)
        self.pad_groove = self._add(
            pymunk.GrooveJoint(self.pad, upright, (-0.5, 0.0), (0.5, 0.0), self._contact_local)
        )
        self.design_contact = contact
        # body-local anchors of every point that moves (taken at the design pose)
        self._moving: dict[str, tuple[pymunk.Body, tuple[float, float]]] = {}
        for n in (*g.upright_points, "contact"):
            self._moving[n] = (upright, self._local(upright, self._p(n)))
        if isinstance(g, DoubleWishbone):
            self._moving["spring_arm"] = (lower, self._local(lower, self._p("spring_arm")))

    # ------------------------------------------------------------- simulation
    def _gaps(self) -> float:
        gap = 0.0
        for a, la, b, lb in self._pivots:
            gap = max(gap, (a.local_to_world(la) - b.local_to_world(lb)).length)
        c = self.upright.local_to_world(self._contact_local)
        gap = max(gap, abs(c.y - self.pad.position.y))
        if isinstance(self.geom, McPherson):  # the top mount's distance from the strut axis
            ty, tz = self._p("strut_top")
            seat = self.upright.local_to_world(self.strut.groove_a)
            end = self.upright.local_to_world(self.strut.groove_b)
            ay, az = end.x - seat.x, end.y - seat.y
            cross = ay * (tz - seat.y) - az * (ty - seat.x)
            gap = max(gap, abs(cross) / (ay * ay + az * az) ** 0.5)
        return gap

    def _speed(self) -> float:
        return max(max(b.velocity.length, abs(b.angular_velocity)) for b in self.bodies.values())

    def settle(self) -> int:
        """Step until the joints are closed and the bodies at rest; returns the steps."""
        s = self.settings
        for step in range(0, s.max_steps, s.check_every):
            for _ in range(s.check_every):
                self.space.step(s.dt)
            if self._gaps() < s.position_tol and self._speed() < s.speed_tol:
                return step + s.check_every
        raise ConvergenceError(
            f"pymunk linkage did not settle in {s.max_steps} steps at pad height "
            f"{1e3 * (self.pad.position.y - self.design_contact[1]):.2f} mm "
            f"(joint gap {self._gaps():.3g} m, speed {self._speed():.3g} m/s)"
        )

    def move_pad(self, travel: float) -> None:
        """Move the pad to ``travel`` (m above the design contact) in settled increments."""
        y0, z0 = self.design_contact
        start = self.pad.position.y - z0
        n = max(1, int(np.ceil(abs(travel - start) / self.settings.max_increment)))
        for h in np.linspace(start, travel, n + 1)[1:]:
            self.pad.position = (y0, z0 + float(h))
            self.settle()

    def wheel_load(self) -> float:
        """Vertical pad force on the tyre, N (from the groove's last reaction impulse).

        pymunk reports the impulse's magnitude; the groove is frictionless, so the reaction
        is vertical, and a spring in compression makes it push the tyre up (a pad that
        would have to pull, i.e. wheel lift, would read as a positive load too).
        """
        return float(self.pad_groove.impulse / self.settings.dt)

    def spring_length(self) -> float:
        a, la, b, lb = self._spring_ends
        return float((a.local_to_world(la) - b.local_to_world(lb)).length)

    def point(self, name: str) -> np.ndarray:
        """World position of a named point in the current pose, m."""
        if name in self._moving:
            body, local = self._moving[name]
            return np.array(body.local_to_world(local))
        return np.array(self._p(name))  # a point fixed to the vehicle body


def simulate_sweep(
    geom: PlanarGeometry, travel: np.ndarray, settings: PymunkSettings | None = None
) -> PlanarSweep:
    """Sweep one geometry through ``travel`` (m, ascending) with the pymunk model.

    Raises :class:`ConvergenceError` when a pose does not settle and
    :class:`LockupError` when the joints cannot close at a travel point.
    """
    travel = np.asarray(travel, dtype=float).reshape(-1)
    if travel.size == 0 or np.any(np.diff(travel) <= 0):
        raise ValidationError("`travel` must be non-empty and strictly ascending")
    model = PymunkLinkage(geom, settings)
    model.settle()
    names = [*geom.point_names, "contact"]
    pts = {n: np.empty((travel.size, 2)) for n in names}
    theta = np.empty(travel.size)
    length = np.empty(travel.size)
    load = np.empty(travel.size)
    angle0 = model.upright.angle
    for i, s in enumerate(travel):
        try:
            model.move_pad(float(s))
        except ConvergenceError as exc:
            raise LockupError(f"pymunk linkage cannot follow the pad: {exc}") from exc
        for n in names:
            pts[n][i] = model.point(n)
        theta[i] = model.upright.angle - angle0
        length[i] = model.spring_length()
        load[i] = model.wheel_load()
    return PlanarSweep(
        travel=travel,
        points=pts,
        theta=theta,
        spring_length=length,
        ok=np.bool_(True),
        wheel_load=load,
        solver="pymunk",
        messages=[""],
    )
