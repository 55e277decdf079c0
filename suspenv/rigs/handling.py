"""Handling rigs for the minibus: steady-state circular test and pylon-course slalom.

Frame, units, signs: those of :mod:`suspenv.models.minibus.handling_model` (ISO 8855,
SI inside; left turn = positive yaw rate, lateral acceleration and body roll). Every
test number is a parameter of a frozen config; defaults follow GB/T 6323 practice for
light buses (ride_standards.md, "Handling tests").

Steady-state circular test (:func:`steady_circle`)
    Circle radius R (default 15 m), speed raised slowly. **Maximum quasi-steady lateral
    acceleration** is defined as the largest a_y = u^2/R for which the model has a
    steady-state equilibrium on the circle, i.e. the limit of the test as the speed
    ramp becomes infinitely slow (GB/T 6323 asks for <= 0.25 m/s^2 per second, slow
    against the vehicle's ~0.3 s yaw and roll time constants). At a steady state the
    axles must carry Fyf = m a_y b/L and Fyr = m a_y a/L (yaw and lateral balance), the
    body rolls phi = a_y dphi/da_y, and the load transfer of each axle follows. The
    equilibrium exists while (1) each axle's required force is no more than its
    capacity, the peak over slip angle of the sum of its two tyres' forces at their
    transferred loads (front short: limit understeer, the vehicle drifts off the circle;
    rear short: it spins), and (2) not both inner wheels have lifted (rollover). The
    three conditions are monotonic in a_y, so a bisection on a grid of a_y finds the
    limit (compiled, row by row, on the axle capacity tabulated over both wheel loads);
    ``limit`` names the condition that bounds it. The limit counts equilibria, stable
    or not (near a rear-axle limit the steady state can be unstable, a spin mode that
    the driver has to hold).

Pylon-course slalom (:func:`slalom_run`)
    n cones (default 10) on a straight line, spacing s (30 m), constant speed (60 km/h).
    The reference path weaves through the cones, y = A cos(pi x / s), passing each cone
    at a lateral offset A (default 1.25 m: half the vehicle width plus clearance) on
    alternate sides, blended in over the run-in and out after the last cone. The driver
    (:func:`driver_steer`) adds a curvature feed-forward, (L + K u^2) times the path
    curvature a short preview ahead (K the vehicle's linear understeer gradient: a
    driver used to the vehicle), to a pure-pursuit-type feedback on the predicted
    lateral error one look-ahead (u * preview time) ahead and a yaw-rate feedback; the
    command reaches the road wheels through a first-order steering lag. The gains were
    chosen so that 300 random designs of the study's box, both load cases, all complete
    the course with an RMS path error of about 10 % of the cone offset. The rig returns
    channels: completion, path error and, on request, time histories; every step it
    hands the vehicle's ground position and its yaw rate, roll, steer and lateral
    acceleration to the caller's accumulator (:class:`StepAccumulator`), so the run is
    measured without storing it (:func:`slalom`: per-cone peaks over the middle cones,
    default the 3rd to the 8th). :func:`slalom_linear`: the same course followed exactly
    by the linearised vehicle, in the frequency domain.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.core.options import integer, number, positive
from suspenv.models.minibus import handling_kernel
from suspenv.models.minibus.handling_model import (
    HandlingParams,
    HandlingState,
    linear_system,
    steer_response,
    step,
)
from suspenv.models.minibus.tyre import LateralTyre
from suspenv.models.minibus.vehicle import G

#: axle-capacity table of the steady circle: loads 0 .. CAPACITY_TABLE_MAX x fz0 (26 kN
#: for the reference tyre, 3x the heaviest static wheel load) in CAPACITY_TABLE_POINTS
#: steps per wheel
CAPACITY_TABLE_MAX = 4.0
CAPACITY_TABLE_POINTS = 161


# ------------------------------------------------------------------ steady circle
@dataclass(frozen=True)
class SteadyCircleConfig:
    """Steady-state circular test settings.

    Attributes:
        radius: m, circle radius (GB/T 6323 practice 15 m; ISO 4138 prefers >= 40 m).
        ay_upper: m/s^2, upper end of the search (above any tyre-limited value).
        tolerance: m/s^2, bisection tolerance on the limit.
        alpha_max_deg: deg, largest slip angle searched for an axle's peak force.
        alpha_points: grid points for the peak search (refined by a parabola).
    """

    radius: float = 15.0
    ay_upper: float = 1.5 * G
    tolerance: float = 1e-3
    alpha_max_deg: float = 20.0
    alpha_points: int = 41

    def __post_init__(self) -> None:
        for name in ("radius", "ay_upper", "tolerance", "alpha_max_deg"):
            positive("SteadyCircleConfig", name, getattr(self, name))
        integer("SteadyCircleConfig", "alpha_points", self.alpha_points, lo=5)


@dataclass
class SteadyCircleResult:
    """Maximum quasi-steady lateral acceleration of a batch (arrays (n,)).

    Attributes:
        ay_max: m/s^2, the limit defined in the module docstring.
        holds: (n, 2), one grid step above ay_max: 1 where the front axle carries its
            share (column 0) and where an inner wheel still carries load (column 1),
            else 0.
        limit (property): "front", "rear" or "rollover", the condition that bounds ay_max.
    """

    ay_max: np.ndarray
    holds: np.ndarray
    config: SteadyCircleConfig

    @property
    def limit(self) -> np.ndarray:
        front, rollover = self.holds.T
        return np.where(rollover == 0, "rollover", np.where(front == 0, "front", "rear"))


def axle_capacity(
    tyre: LateralTyre, fz_a: np.ndarray, fz_b: np.ndarray, config: SteadyCircleConfig
) -> tuple[np.ndarray, np.ndarray]:
    """Peak over slip angle of an axle's lateral force (N) and the slip angle (rad) at it.

    Grid search over 0..alpha_max refined by a parabola through the best three points
    (the compiled loop :func:`suspenv.models.minibus.handling_kernel.capacity_loop`).
    ``fz_a``/``fz_b``: the axle's two wheel loads (N; arrays of one shape, or broadcast).
    """
    fz = np.stack(np.broadcast_arrays(np.asarray(fz_a, float), np.asarray(fz_b, float)))
    d, b, e = (f.reshape(2, -1) for f in tyre.factors(fz))
    out = np.empty((2, d.shape[1]))
    handling_kernel.capacity_loop(d, b, e, float(tyre.pCy1), _slip_grid(config), out)
    return out[0].reshape(fz.shape[1:]), out[1].reshape(fz.shape[1:])


@functools.lru_cache(maxsize=8)
def _slip_grid(config: SteadyCircleConfig) -> np.ndarray:
    """The slip angles (rad) of the axle-capacity search: ``alpha_points`` evenly from 0
    to ``alpha_max_deg`` (read-only, cached)."""
    grid = np.linspace(0.0, np.radians(config.alpha_max_deg), config.alpha_points)
    grid.flags.writeable = False
    return grid


@functools.lru_cache(maxsize=8)
def _capacity_table(
    tyre: LateralTyre, alpha_max_deg: float, alpha_points: int
) -> tuple[float, np.ndarray]:
    """Axle capacity (:func:`axle_capacity`) tabulated over both wheel loads.

    Returns the load step (N) and the (N, N) table on ``0 .. CAPACITY_TABLE_MAX x
    fz0`` in both loads; built once per tyre and search setting (about 50 ms). The
    capacity is smooth in the loads (the peak of a sum of two smooth curves), so the
    bilinear interpolation on the table's 163 N step
    (:func:`suspenv.models.minibus.handling_kernel.tabulated`) stays within about 1e-5
    of the grid search (tests).
    """
    fz = np.linspace(0.0, CAPACITY_TABLE_MAX * tyre.fz0, CAPACITY_TABLE_POINTS)
    config = SteadyCircleConfig(alpha_max_deg=alpha_max_deg, alpha_points=alpha_points)
    cap, _ = axle_capacity(tyre, fz[:, None], fz[None, :], config)
    cap.flags.writeable = False  # shared by every call (cached)
    return float(fz[1] - fz[0]), cap


def steady_circle(
    P: HandlingParams, config: SteadyCircleConfig | None = None
) -> SteadyCircleResult:
    """Maximum quasi-steady lateral acceleration on the circle, for every row of ``P``.

    The limit is searched on the grid ``ay_upper j / 2^B`` (``B = ceil(log2(ay_upper /
    tolerance))``): the largest grid point below ``ay_upper`` with an equilibrium (the
    conditions are monotonic in a_y), by bisection per row on the tabulated axle
    capacity (:func:`_capacity_table`; the compiled loop
    :func:`suspenv.models.minibus.handling_kernel.circle_loop`), so a row's result does
    not depend on its batch; the conditions one grid step above the limit name it.
    """
    config = config or SteadyCircleConfig()
    bits, scale = _circle_grid(config)
    h, table = _capacity_table(P.tyre, config.alpha_max_deg, config.alpha_points)
    out = np.empty((P.n, 3))
    handling_kernel.circle_loop(P.rows, table, h, bits, scale, out)
    return SteadyCircleResult(ay_max=out[:, 0] * scale, holds=out[:, 1:], config=config)


@functools.lru_cache(maxsize=8)
def _circle_grid(config: SteadyCircleConfig) -> tuple[int, float]:
    """``(B, ay_upper / 2^B)`` of :func:`steady_circle`'s search grid, ``B =
    ceil(log2(ay_upper / tolerance))`` (cached)."""
    bits = int(np.ceil(np.log2(config.ay_upper / config.tolerance)))
    return bits, config.ay_upper / float(2**bits)


@dataclass
class SteadyStateSweep:
    """Steady states on the circle at given lateral accelerations (arrays (N, n)).

    Attributes:
        ay: m/s^2 (N,); steer: rad, front road-wheel steer command; roll: rad;
        alpha_front, alpha_rear: rad, axle slip angles; force_front, force_rear: N, the
        axle forces the state needs; feasible: bool.
    """

    ay: np.ndarray
    steer: np.ndarray
    roll: np.ndarray
    alpha_front: np.ndarray
    alpha_rear: np.ndarray
    force_front: np.ndarray
    force_rear: np.ndarray
    feasible: np.ndarray

    def take(self, rows: slice | np.ndarray) -> SteadyStateSweep:
        """The states of some of the accelerations (rows of the first axis)."""
        return SteadyStateSweep(**{name: value[rows] for name, value in vars(self).items()})


#: regula-falsi (Illinois) passes of the steady state's slip-angle solve: a fixed count
#: (no data-dependent stopping, so a row's result does not depend on its batch); the
#: residual after them is at round-off on the rising branch (tests)
SLIP_SOLVE_PASSES = 14


def steady_state_sweep(
    P: HandlingParams, ay: np.ndarray, config: SteadyCircleConfig | None = None
) -> SteadyStateSweep:
    """Quasi-steady states on the circle for lateral accelerations ``ay`` (N,) >= 0.

    Steer from the kinematics of the single-track model:
    delta = L/R + alpha_f - alpha_r - eps_f phi - c_Ff Fyf + eps_r phi + c_F Fyr, the
    axles' slip angles on the rising branch by Illinois regula falsi
    (:data:`SLIP_SOLVE_PASSES` passes) between the first point of the capacity search's
    slip grid whose force reaches the axle's share and the one before (the axle force
    is unimodal in the slip angle), else on ``[0, peak slip]``. The compiled loop
    :func:`suspenv.models.minibus.handling_kernel.sweep_loop`, row by row.
    """
    config = config or SteadyCircleConfig()
    ay = np.asarray(ay, dtype=float)
    if ay.ndim != 1 or (ay < 0).any():
        raise ValidationError(f"`ay` must be a 1-D array of values >= 0, but got {ay!r}")
    out = np.empty((7, ay.size, P.n))
    handling_kernel.sweep_loop(
        P.rows,
        np.ascontiguousarray(ay),
        P.tyre.coefficients,
        _slip_grid(config),
        float(config.radius),
        SLIP_SOLVE_PASSES,
        out,
    )
    steer, phi, af, ar, fyf, fyr, ok = out
    return SteadyStateSweep(ay, steer, phi, af, ar, fyf, fyr, ok > 0)


def secant_axle_stiffness(
    P: HandlingParams,
    ay: np.ndarray | float,
    config: SteadyCircleConfig | None = None,
    sweep: SteadyStateSweep | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Quasi-steady secant cornering stiffness of each axle's two tyres, N/rad, arrays
    of shape ``ay.shape + (n,)`` (front, rear).

    At the steady state on the circle at lateral acceleration ``ay`` (m/s^2, > 0;
    :func:`steady_state_sweep`, or ``sweep`` if already at hand for exactly these
    accelerations): the axle force the state needs (``m a_y b/L`` front, ``m a_y a/L``
    rear) over its tyres' slip angle, at the wheel loads that the load transfer leaves
    (so the stabiliser bars, the roll-centre heights and the tyres' load sensitivity
    enter as they do at ``ay``). In place of the static-load stiffnesses, the linear
    model (:func:`suspenv.models.minibus.handling_model.linear_system`) reproduces the
    steady state at ``ay`` exactly. NaN where no steady state exists.
    """
    acc = np.asarray(ay, dtype=float)
    if not (acc > 0).all():
        raise ValidationError(f"`ay > 0` must hold, but got ay={ay!r}")
    sw = sweep if sweep is not None else steady_state_sweep(P, acc.reshape(-1), config)
    cf = np.where(sw.feasible, sw.force_front / sw.alpha_front, np.nan)
    cr = np.where(sw.feasible, sw.force_rear / sw.alpha_rear, np.nan)
    shape = acc.shape + (P.n,)
    return cf.reshape(shape), cr.reshape(shape)


def gradient_accelerations(ay: np.ndarray, step: float = 0.2) -> np.ndarray:
    """The sweep's accelerations (m/s^2, (2N,)) of :func:`understeer_gradients`:
    ``ay - step/2`` then ``ay + step/2``."""
    ay = np.asarray(ay, dtype=float)
    h = 0.5 * step
    if ay.ndim != 1 or (ay - h < 0).any():
        raise ValidationError(f"`ay - step/2 >= 0` must hold for every ay, but got {ay!r}")
    return np.concatenate([ay - h, ay + h])


def understeer_gradients(
    P: HandlingParams,
    ay: np.ndarray,
    config: SteadyCircleConfig | None = None,
    step: float = 0.2,
    sweep: SteadyStateSweep | None = None,
) -> np.ndarray:
    """ISO 4138 understeer gradient ``d delta / d a_y`` (rad of road-wheel steer per
    m/s^2) on the constant-radius circle at each lateral acceleration ``ay`` (N,), for
    every row: (N, n). Central difference of :func:`steady_state_sweep`'s steer over
    ``ay +- step/2`` (m/s^2; ``sweep``: that sweep if already at hand, at
    :func:`gradient_accelerations`); the steer is solved to round-off, so the
    difference's error is the curvature term, ``step^2/24`` times the third derivative.
    NaN where a state does not exist.
    """
    if sweep is None:
        sweep = steady_state_sweep(P, gradient_accelerations(ay, step), config)
    steer = np.where(sweep.feasible, sweep.steer, np.nan)
    n = steer.shape[0] // 2
    return (steer[n:] - steer[:n]) / step


# ------------------------------------------------------------------ slalom
@dataclass(frozen=True)
class SlalomConfig:
    """Pylon-course slalom settings (GB/T 6323 practice for light buses).

    Attributes:
        n_cones: cones on the line; spacing: m between cones; speed_kmh: reference speed.
        amplitude: m, lateral offset of the path at each cone.
        run_in: m of approach before the first cone (the path blends in over one spacing).
        preview_time: s, feedback look-ahead time (look-ahead = u * preview_time, at
            least ``min_lookahead``).
        feedforward_preview: s, preview of the curvature feed-forward (covers the
            steering lag and the vehicle's yaw response time).
        yaw_rate_gain: s, rad of steer per rad/s of yaw-rate error against u * kappa.
        steer_lag: s, first-order lag between the driver's command and the road wheels.
        dt: s, integration step.
        measure_cones: (first, stop) cone indices (0-based, Python range) measured.
        max_path_error: m; a run whose lateral distance to the path exceeds it anywhere
            in the measured windows did not complete the course (it hit cones).
        record_every: keep every k-th sample of the channels (0: keep none).
    """

    n_cones: int = 10
    spacing: float = 30.0
    speed_kmh: float = 60.0
    amplitude: float = 1.25
    run_in: float = 60.0
    preview_time: float = 2.0
    feedforward_preview: float = 0.4
    yaw_rate_gain: float = 0.3
    min_lookahead: float = 4.0
    steer_lag: float = 0.15
    dt: float = 0.02
    measure_cones: tuple[int, int] = (2, 8)
    max_path_error: float = 2.0
    record_every: int = 0

    def __post_init__(self) -> None:
        for name in (
            "spacing",
            "speed_kmh",
            "amplitude",
            "preview_time",
            "dt",
            "min_lookahead",
            "feedforward_preview",
            "max_path_error",
        ):
            positive("SlalomConfig", name, getattr(self, name))
        number("SlalomConfig", "steer_lag", self.steer_lag, lo=0.0)
        if self.run_in < self.spacing:
            raise ValidationError(
                f"SlalomConfig: `run_in >= spacing` must hold, but got (run_in={self.run_in}, "
                f"spacing={self.spacing})"
            )
        first, stop = self.measure_cones
        if not 0 <= first < stop <= self.n_cones:
            raise ValidationError(
                "SlalomConfig: `0 <= measure_cones[0] < measure_cones[1] <= n_cones` must "
                f"hold, but got (measure_cones={self.measure_cones}, n_cones={self.n_cones})"
            )

    @property
    def speed(self) -> float:
        """m/s."""
        return self.speed_kmh / 3.6

    @property
    def lookahead(self) -> float:
        """m, the feedback look-ahead: ``u * preview_time``, at least ``min_lookahead``."""
        return max(self.speed * self.preview_time, self.min_lookahead)

    @property
    def cone_x(self) -> np.ndarray:
        """m, cone positions along the line."""
        return self.spacing * np.arange(self.n_cones)

    def path_y(self, x: np.ndarray, side: float = 1.0) -> np.ndarray:
        """Reference lateral position (m) at ground x (m); ``side=-1`` mirrors the course."""
        x = np.asarray(x, dtype=float)
        s = self.spacing
        last = self.cone_x[-1]
        w_in = 0.5 * (1.0 - np.cos(np.pi * np.clip((x + s) / s, 0.0, 1.0)))
        w_out = 0.5 * (1.0 + np.cos(np.pi * np.clip((x - last) / s, 0.0, 1.0)))
        return side * self.amplitude * w_in * w_out * np.cos(np.pi * x / s)

    def path_slope_curvature(
        self, x: np.ndarray, side: float = 1.0, h: float = 0.05
    ) -> tuple[np.ndarray, np.ndarray]:
        """Slope dy/dx and curvature (1/m) of the reference path (central differences)."""
        y0 = self.path_y(x - h, side)
        y1 = self.path_y(x, side)
        y2 = self.path_y(x + h, side)
        d1 = (y2 - y0) / (2.0 * h)
        d2 = (y2 - 2.0 * y1 + y0) / h**2
        return d1, d2 / (1.0 + d1**2) ** 1.5

    @property
    def measured_cone_x(self) -> np.ndarray:
        """m, positions of the measured cones (``measure_cones``)."""
        first, stop = self.measure_cones
        return self.cone_x[first:stop]

    def measured_end(self) -> float:
        """m, ground x where the last measured window ends (the run stops there)."""
        return float(self.cone_x[self.measure_cones[1] - 1] + 0.5 * self.spacing)


class PathTable:
    """The reference path tabulated on a fine grid for fast lookups during a run.

    Rows: lateral position (m), slope (-), curvature (1/m); linear interpolation,
    clamped at the ends of the grid.
    """

    def __init__(
        self, config: SlalomConfig, side: float, x_min: float, x_max: float, step: float = 0.02
    ):
        self.x0 = float(x_min)
        self.dx = float(step)
        xs = np.arange(x_min, x_max + 2 * step, step)
        slope, curvature = config.path_slope_curvature(xs, side)
        self.table = np.stack([config.path_y(xs, side), slope, curvature])
        self._last = xs.size - 2

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """(3, n) lateral position, slope and curvature at ground positions ``x`` (n,)."""
        t = (x - self.x0) / self.dx
        i = np.clip(np.floor(t).astype(np.intp), 0, self._last)
        w = np.clip(t - i, 0.0, 1.0)
        lo = self.table[:, i]
        return lo + w * (self.table[:, i + 1] - lo)


#: the signals a slalom run hands to its accumulator every step, in this order
SLALOM_SIGNALS = ("yaw_rate", "roll", "steer", "ay")


class StepAccumulator(Protocol):
    """Receives every integration step of a manoeuvre (e.g. a running peak per window).

    ``update(x, values)``: ground positions ``x`` (n,) in m and the signals (k, n) of that
    step, SI units (rad/s, rad, rad, m/s^2 for :data:`SLALOM_SIGNALS`).
    """

    def update(self, x: np.ndarray, values: np.ndarray) -> None: ...


@dataclass
class SlalomRun:
    """Channels of a slalom run of a batch.

    Attributes:
        path_error_rms: m (n,), RMS lateral distance to the path while the vehicle is
            within half a spacing of a measured cone.
        completed: bool (n,), False where the vehicle spun or left the course (heading
            beyond 90 deg, non-finite states, or a path error above ``max_path_error``);
            its other results are meaningless.
        config: the settings of the run.
        channels: recorded time histories (T, n) when ``record_every > 0``: t, x, y,
            psi, r, phi, delta, ay.
    """

    path_error_rms: np.ndarray
    completed: np.ndarray
    config: SlalomConfig
    channels: dict[str, np.ndarray] = field(default_factory=dict)


def driver_steer(
    P: HandlingParams,
    s: HandlingState,
    u: float,
    config: SlalomConfig,
    path: PathTable,
    understeer: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Road-wheel steer command (rad) and the current path error (m).

    The command is a curvature feed-forward plus preview feedback.

    Feed-forward ``(L + K u^2) kappa(x + u T_ff)``: the steady-state steer of the
    linear vehicle on the path's curvature a preview ``T_ff`` ahead. Feedback: the
    lateral error predicted one look-ahead l ahead along the direction of travel,
    ``e = (y - y_ref) + l tan(psi + beta - psi_ref)`` (beta the CoM sideslip), steered
    out with the pure-pursuit gain ``2 L / l^2``; and a yaw-rate feedback
    ``-k_r (r - u kappa)`` that damps the loop where the vehicle departs from the linear
    response the feed-forward assumes (load transfer near a wheel lift).
    ``understeer`` (rad/(m/s^2), (n,)) defaults to the vehicle's linear gradient.
    """
    L = P.wheelbase
    lookahead = config.lookahead
    kappa = path(s.x + u * config.feedforward_preview)[2]
    y_ref, slope, kappa_now = path(s.x)
    if understeer is None:
        understeer = P.understeer_gradient()
    feedforward = (L + understeer * u**2) * kappa
    course = s.psi + np.arctan2(s.v, u)  # direction of travel of the CoM
    error = (s.y - y_ref) + lookahead * np.tan(course - np.arctan(slope))
    yaw_error = s.r - u * kappa_now
    command = feedforward - 2.0 * L * error / lookahead**2 - config.yaw_rate_gain * yaw_error
    return command, s.y - y_ref


def slalom_run(
    P: HandlingParams,
    config: SlalomConfig | None = None,
    side: float = 1.0,
    accumulator: StepAccumulator | None = None,
) -> SlalomRun:
    """Run the pylon-course slalom for every row of ``P`` (closed loop, constant speed).

    ``accumulator`` (optional) is updated after every step with the ground positions and
    the :data:`SLALOM_SIGNALS` stacked (4, n); the per-cone peaks of the slalom's metrics
    are measured this way (:func:`slalom`).
    """
    config = config or SlalomConfig()
    n = P.n
    u = config.speed
    dt = config.dt
    s = HandlingState.zeros(n)
    s.x[:] = -config.run_in
    centres = config.measured_cone_x
    half = 0.5 * config.spacing
    err2 = np.zeros(n)
    err_max = np.zeros(n)
    n_err = np.zeros(n)
    x_end = config.measured_end()
    n_steps = int(np.ceil((x_end + config.run_in) / (u * dt))) + 1
    path = PathTable(config, side, -config.run_in - 1.0, x_end + config.lookahead + 1.0)
    rec: dict[str, list[np.ndarray]] = {
        k: [] for k in ("t", "x", "y", "psi", "r", "phi", "delta", "ay")
    }
    lo, hi = centres[0] - half, centres[-1] + half
    understeer = P.understeer_gradient()
    with np.errstate(all="ignore"):  # a spinning row may overflow; it is flagged below
        for i in range(n_steps):
            inside = (s.x >= lo) & (s.x < hi)
            cmd, err = driver_steer(P, s, u, config, path, understeer)
            k = step(P, s, u, cmd, dt, config.steer_lag)
            if accumulator is not None:
                accumulator.update(s.x, np.stack([s.r, s.phi, s.delta, k.ay]))
            err2 += np.where(inside, err**2, 0.0)
            err_max = np.maximum(err_max, np.where(inside, np.abs(err), 0.0))
            n_err += inside
            if config.record_every and i % config.record_every == 0:
                for key in ("x", "y", "psi", "r", "phi", "delta"):
                    rec[key].append(getattr(s, key).copy())
                rec["ay"].append(k.ay.copy())
                rec["t"].append(np.full(n, (i + 1) * dt))
    completed = (
        np.isfinite(s.r)
        & np.isfinite(s.psi)
        & (np.abs(s.psi) < np.pi / 2)
        & (err_max <= config.max_path_error)
    )
    return SlalomRun(
        path_error_rms=np.sqrt(err2 / np.maximum(n_err, 1)),
        completed=completed,
        config=config,
        channels={k: np.array(v) for k, v in rec.items() if v},
    )


# ------------------------------------------------------------------ slalom measured
class WindowedPeaks:
    """Running peak |signal| per position window, updated sample by sample for a batch.

    Window k covers ``centres[k] - half_width <= x < centres[k] + half_width``; the
    windows must not overlap. Used by the slalom to measure the peak of each
    half-cycle around each cone without storing the time histories. Several signals
    (``n_signals``) share the positions and are updated together.
    """

    def __init__(self, centres: np.ndarray, half_width: float, n: int, n_signals: int = 1):
        c = np.asarray(centres, dtype=float)
        if c.ndim != 1 or c.size == 0:
            raise ValidationError(f"`centres` must be a non-empty 1-D array, but got {c.shape}")
        if half_width <= 0:
            raise ValidationError(f"`half_width > 0` must hold, but got half_width={half_width}")
        if c.size > 1 and np.min(np.diff(c)) < 2.0 * half_width - 1e-9:
            raise ValidationError(
                "windows must not overlap: `diff(centres) >= 2 half_width` must hold, but got "
                f"(min spacing={np.min(np.diff(c))}, half_width={half_width})"
            )
        self.centres = c
        self.half_width = float(half_width)
        # last window row collects the samples outside every window
        self.peaks = np.zeros((n_signals, c.size + 1, n))
        self._cols = np.arange(n)
        self._starts = c - self.half_width
        self._ends = c + self.half_width

    def update(self, x: np.ndarray, values: np.ndarray) -> None:
        """Fold one sample in: positions ``x`` (n,), values (n_signals, n) or (n,)."""
        vals = np.abs(np.asarray(values, dtype=float)).reshape(self.peaks.shape[0], -1)
        k = np.searchsorted(self._starts, x, side="right") - 1
        inside = (k >= 0) & (x < self._ends[np.clip(k, 0, None)])
        k = np.where(inside, k, self.centres.size)
        cur = self.peaks[:, k, self._cols]
        self.peaks[:, k, self._cols] = np.maximum(cur, vals)

    def result(self, signal: int = 0) -> np.ndarray:
        """(n_windows, n) peak |value| of one signal in every window."""
        return self.peaks[signal, :-1].copy()


@dataclass(kw_only=True)
class SlalomResult(SlalomRun):
    """Slalom results of a batch: the run's (:class:`SlalomRun`:
    path error, completion, settings, channels) and its measures.

    Attributes:
        yaw_rate_amplitude: rad/s (n,), mean of the per-cone peaks |r|.
        roll_amplitude: rad (n,), mean of the per-cone peaks |phi|.
        ay_amplitude: m/s^2 (n,), same windows.
        yaw_rate_peaks: (n_measured_cones, n) the per-cone peaks |r|.
    """

    yaw_rate_amplitude: np.ndarray
    roll_amplitude: np.ndarray
    ay_amplitude: np.ndarray
    yaw_rate_peaks: np.ndarray


def slalom(
    P: HandlingParams, config: SlalomConfig | None = None, side: float = 1.0
) -> SlalomResult:
    """Run the pylon-course slalom for every row of ``P`` and measure it over the middle
    cones (``config.measure_cones``, default the 3rd to the 8th): for each cone the peak
    |yaw rate| and peak |roll angle| while the vehicle is within half a spacing of the
    cone, and their means over the cones. The peaks are folded in step by step
    (:class:`WindowedPeaks`, :func:`slalom_run`'s accumulator): no time history is kept."""
    config = config or SlalomConfig()
    centres = config.measured_cone_x
    peaks = WindowedPeaks(centres, 0.5 * config.spacing, P.n, n_signals=len(SLALOM_SIGNALS))
    run = slalom_run(P, config, side, accumulator=peaks)
    r_peaks = peaks.result(SLALOM_SIGNALS.index("yaw_rate"))
    return SlalomResult(
        **vars(run),
        yaw_rate_amplitude=r_peaks.mean(axis=0),
        roll_amplitude=peaks.result(SLALOM_SIGNALS.index("roll")).mean(axis=0),
        ay_amplitude=peaks.result(SLALOM_SIGNALS.index("ay")).mean(axis=0),
        yaw_rate_peaks=r_peaks,
    )


# ------------------------------------------------------------------ linear-range slalom
@dataclass
class SlalomLinearResult:
    """Linear-range slalom of a batch (:func:`slalom_linear`), arrays (n,).

    Attributes:
        steering_wheel_amplitude: rad, steering-wheel angle amplitude the course needs
            (road-wheel steer times the vehicle's steering ratio).
        steer_amplitude: rad, front road-wheel steer amplitude.
        yaw_rate_amplitude: rad/s; roll_amplitude: rad; ay_amplitude: m/s^2 (the path's).
        yaw_rate_gain: 1/s, yaw rate per rad of steering-wheel angle at the course's
            frequency; frequency: Hz.
        stable: bool, every pole of the linearised vehicle in the left half-plane (an
            unstable row's numbers are meaningless: the problem fails it).
    """

    steering_wheel_amplitude: np.ndarray
    steer_amplitude: np.ndarray
    yaw_rate_amplitude: np.ndarray
    roll_amplitude: np.ndarray
    ay_amplitude: np.ndarray
    yaw_rate_gain: np.ndarray
    frequency: float
    stable: np.ndarray


def course_lateral_acceleration(config: SlalomConfig) -> float:
    """Lateral acceleration amplitude (m/s^2) of the course's path: ``A (pi u / s)^2``."""
    return float(config.amplitude * (np.pi * config.speed / config.spacing) ** 2)


def slalom_linear(
    P: HandlingParams,
    config: SlalomConfig | None = None,
    circle: SteadyCircleConfig | None = None,
    working_point: bool = True,
    system: tuple[np.ndarray, np.ndarray] | None = None,
    stable: np.ndarray | None = None,
) -> SlalomLinearResult:
    """The slalom course followed exactly, evaluated by the linearised vehicle's frequency
    response (:func:`suspenv.models.minibus.handling_model.steer_response`, ISO 7401's
    frequency-response quantities) at the course's frequency ``u / (2 s)``: the path's
    lateral acceleration amplitude ``A (pi u / s)^2`` divided by the lateral-acceleration
    gain gives the road-wheel steer the course needs, times the steering ratio the
    steering-wheel angle (GB/T 6323.1's second slalom index, the "average steering-wheel
    angle peak"); the roll and yaw-rate amplitudes follow from their gains. No time loop:
    one 4x4 complex solve per design (the problem's default handling measures).

    ``working_point=True`` (default): the axles' tyres at their quasi-steady secant
    stiffness at the course's lateral acceleration amplitude
    (:func:`course_lateral_acceleration`, 3.8 m/s^2 = 0.39 g at 60 km/h and 30 m; by
    :func:`secant_axle_stiffness`), so the load transfer (the stabiliser bars' balance),
    the tyres' load sensitivity and the compliances enter as they do where the course
    runs; ``False``: the small-amplitude linearisation about straight running (the
    bars' split then only moves the roll steer).
    ``system``: (A, B) of :func:`linear_system` at the course's speed and working point,
    if already at hand; ``stable``: whether each row of that A is finite with every pole
    in the left half-plane, if already known (else from A's eigenvalues).
    """
    config = config or SlalomConfig()
    u = config.speed
    f = u / (2.0 * config.spacing)  # one cycle per two cones
    ay = course_lateral_acceleration(config)
    if system is None:
        stiffness = secant_axle_stiffness(P, ay, circle) if working_point else None
        system = linear_system(P, u, stiffness)
    A, B = system
    H = steer_response(P, u, f, (A, B))
    steer = ay / np.abs(H.ay[:, 0])
    yaw_gain = np.abs(H.yaw_rate[:, 0])
    ratio = P.vehicle.steering_ratio
    if stable is None:
        with np.errstate(invalid="ignore"):
            poles = np.linalg.eigvals(np.nan_to_num(A, nan=1.0))
        stable = np.all(poles.real < 0, axis=-1) & np.isfinite(A).all(axis=(1, 2))
    return SlalomLinearResult(
        steering_wheel_amplitude=ratio * steer,
        steer_amplitude=steer,
        yaw_rate_amplitude=steer * yaw_gain,
        roll_amplitude=steer * np.abs(H.roll[:, 0]),
        ay_amplitude=np.full(P.n, ay),
        yaw_rate_gain=yaw_gain / ratio,
        frequency=f,
        stable=stable,
    )
