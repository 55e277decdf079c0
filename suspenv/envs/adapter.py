"""The one place where actions become designs and evaluations become observations/rewards.

Shared by :class:`~suspenv.envs.problem_env.ProblemEnv` (one design per step) and
:class:`~suspenv.envs.vector_env.ProblemVectorEnv` (a population per step), so both
produce the same numbers for the same designs. No physics here.

Conventions (all float64):

* action ``a`` in [-1, 1]^d -> unit cube ``u = (a + 1) / 2`` -> physical design
  ``x = space.to_physical(u)``. Finite actions outside [-1, 1] are clipped; NaN/inf
  actions and wrong shapes raise :class:`~suspenv.core.errors.ValidationError`.
* observation = objective vector (m,). A failed evaluation (``ok=False``, or any
  objective/constraint not finite, or an objective outside ``[-OBS_LIMIT, OBS_LIMIT]``)
  is reported with every objective (and constraint, in ``info``) equal to
  ``fail_value`` (default :data:`FAIL_VALUE`, finite and worse than any real design).
* reward = -(scalarised objectives + penalty * total constraint violation), where the
  violation is the batch's dimensionless ``sum_j max(g_j / s_j, 0)``
  (:attr:`EvaluationBatch.violation <suspenv.core.result.EvaluationBatch.violation>`,
  ``s_j`` the problem's constraint scales); a failed evaluation gets the lowest reward of a
  working design this env has seen (the reset's reference design included) minus a
  margin of ``0.1 * |lowest| + 1`` (:meth:`ProblemAdapter.failed_reward`): finite,
  below every working design, on the scale of the episode (``-fail_value`` only while
  no design has worked). ``reward="vector"`` (two or more objectives, MO-Gymnasium's
  convention: every component maximised) gives ``-(f_j + penalty * v)`` per objective,
  in the objectives' units, and a failure the lowest seen per component minus the same
  margin. With
  ``reward="normalized"`` each objective is divided by its scale
  (:mod:`suspenv.envs.scales`) before it is scalarised; ``reward="sum"`` scalarises the
  objectives in their own units. The default is "normalized" for objectives in more
  than one unit and "sum" otherwise (:func:`default_reward`).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from suspenv.core.errors import ValidationError
from suspenv.core.options import choice, number, numbers
from suspenv.core.problem import Problem
from suspenv.core.result import EvaluationBatch
from suspenv.core.scalarize import get_scalarizer
from suspenv.envs.scales import ObjectiveScales, cache_key, objective_scales
from suspenv.registry import make_problem

#: reported objective/constraint value of a failed evaluation (finite, inside the space)
FAIL_VALUE = 1.0e10
#: observation bounds: objective values beyond +-OBS_LIMIT count as failed evaluations
OBS_LIMIT = 1.0e300

Scalarizer = str | Callable[[np.ndarray], np.ndarray]

#: the reward modes: objectives divided by their scales, in their own units, or one
#: reward per objective (multi-objective problems, MO-Gymnasium's convention)
REWARDS = ("normalized", "sum", "vector")


class MixedUnitsWarning(UserWarning):
    """``reward="sum"`` adds objectives of different units (see :func:`check_reward`)."""


def mixed_units(problem: Problem) -> list[str]:
    """The distinct units of ``problem``'s objectives when there are several (sorted),
    else []: the objectives a plain sum would add across units."""
    units = sorted(set(problem.objective_units or ()))
    return units if problem.n_objectives > 1 and len(units) > 1 else []


def default_reward(problem: Problem) -> str:
    """The reward mode an env uses when none is given: "normalized" when the objectives
    are in more than one unit (their plain sum weighs them by accident of unit:
    KCIdentification's ``opp_roll_rate`` was 57 % of the reference design's sum), "sum"
    for one objective or several in one unit (or without units)."""
    return "normalized" if mixed_units(problem) else "sum"


def check_reward(reward: Any, problem: Problem) -> str:
    """``reward`` as one of :data:`REWARDS` (None: the problem's default), or a
    ValidationError naming the rule and the value.

    ``reward="sum"`` on objectives in several units is allowed (it reproduces the numbers
    of earlier versions, and ``weights`` may convert the units) but warned about before
    any evaluation with a :class:`MixedUnitsWarning` naming the units (shown once per
    process under Python's default warning filters)."""
    if reward is None:
        return default_reward(problem)
    reward = choice(f"{problem.name} env", "reward", reward, REWARDS)
    if reward == "vector" and problem.n_objectives < 2:
        raise ValidationError(
            f"reward='vector' needs two or more objectives, but {problem.name} has "
            f"{problem.n_objectives}: use 'sum' or 'normalized'"
        )
    units = mixed_units(problem) if reward == "sum" else []
    if units:
        warnings.warn(
            f"reward='sum' adds {problem.name}'s objectives across units ({', '.join(units)}):"
            " suspenv adds values of different units only when asked; use "
            "reward='normalized' (or 'vector'), or weights that convert the units",
            MixedUnitsWarning,
            stacklevel=3,
        )
    return reward


def problem_key(
    problem: str | Problem, problem_options: dict[str, Any] | None, built: Problem
) -> str | None:
    """Cache key of the objective scales of ``built``: the class it was built from by a
    registered name, and its options (instances are not cached: two instances of one
    class may differ)."""
    if not isinstance(problem, str):
        return None
    cls = type(built)
    return cache_key(f"{cls.__module__}:{cls.__qualname__}:{problem}", problem_options)


def build_problem(problem: str | Problem, problem_options: dict[str, Any] | None) -> Problem:
    """A problem instance from a registered name (with options) or an instance."""
    if isinstance(problem, Problem):
        if problem_options:
            raise ValidationError(
                "`problem_options` can only be given with a problem name, but got a "
                f"{type(problem).__name__} instance and problem_options={problem_options!r}"
            )
        return problem
    if not isinstance(problem, str):
        raise ValidationError(
            f"`problem` must be a registered name or a Problem instance, but got {problem!r}"
        )
    return make_problem(problem, **(problem_options or {}))


class ProblemAdapter:
    """Maps actions to designs and :class:`EvaluationBatch` rows to env outputs."""

    def __init__(
        self,
        problem: Problem,
        *,
        scalarizer: Scalarizer = "weighted_sum",
        weights: Sequence[float] | None = None,
        penalty: float = 100.0,
        fail_value: float = FAIL_VALUE,
        batch_scalarizer_ok: bool = False,
        reward: str | None = None,
        scales_key: str | None = None,
    ):
        self.problem = problem
        self.space = problem.space
        self.dim = problem.space.dim
        self.m = problem.n_objectives
        self.k = problem.n_constraints
        owner = f"{problem.name} env"
        self.penalty = number(owner, "penalty", penalty, lo=0.0)
        self.fail_value = number(owner, "fail_value", fail_value, lo=0.0, hi=OBS_LIMIT)
        self.scalarizer_name, self._scalarize = self._resolve_scalarizer(
            scalarizer, weights, batch_scalarizer_ok
        )
        self.reward = check_reward(reward, problem)
        self._scales_key = scales_key
        self._scales: ObjectiveScales | None = None
        #: the lowest reward of a working design seen so far (per component for "vector")
        self.lowest_reward: np.ndarray | None = None

    def failed_reward(self) -> np.ndarray:
        """The reward of a failed evaluation: the lowest reward of a working design seen
        so far minus ``0.1 * |lowest| + 1``; ``-fail_value`` while none has worked."""
        width = self.m if self.reward == "vector" else 1
        if self.lowest_reward is None:
            return np.full(width, -self.fail_value)
        low = self.lowest_reward
        return low - (0.1 * np.abs(low) + 1.0)

    # ---------------------------------------------------------------- scales
    @property
    def scales(self) -> ObjectiveScales:
        """The objective scales of the normalised reward (computed on first use)."""
        if self._scales is None:
            self._scales = objective_scales(self.problem, self._scales_key)
        return self._scales

    def reward_objectives(self, F: np.ndarray) -> np.ndarray:
        """The objectives the scalariser sees: divided by their scales when normalised."""
        if self.reward == "normalized":
            return F / self.scales.scales
        return F

    # ------------------------------------------------------------ scalariser
    def _resolve_scalarizer(
        self, scalarizer: Scalarizer, weights: Sequence[float] | None, batch_ok: bool
    ) -> tuple[str, Callable[[np.ndarray], np.ndarray]]:
        if weights is not None and scalarizer != "weighted_sum":
            raise ValidationError(
                f"`weights` only apply to scalarizer='weighted_sum', but got "
                f"scalarizer={scalarizer!r} with weights={weights!r}"
            )
        if callable(scalarizer):
            return getattr(scalarizer, "__name__", type(scalarizer).__name__), scalarizer
        fn = get_scalarizer(scalarizer)
        if scalarizer == "weighted_sum":
            if weights is not None:  # one finite number per objective
                w = np.asarray(numbers(f"{self.problem.name} env", "weights", weights, self.m))
                return scalarizer, lambda F: fn(F, w)
            return scalarizer, fn
        if not batch_ok:
            raise ValidationError(
                f"scalarizer={scalarizer!r} normalises over a batch, but this env evaluates "
                "one design per step: use the vector env (gymnasium.make_vec) or "
                "scalarizer='weighted_sum'"
            )
        return scalarizer, fn

    # --------------------------------------------------------------- actions
    def actions_to_designs(self, actions: Any, n: int) -> np.ndarray:
        """Actions (n, d) in [-1, 1] -> physical designs (n, d). Rejects NaN/inf/shape."""
        raw = np.asarray(actions)
        if np.iscomplexobj(raw):  # a float cast would drop the imaginary part silently
            raise ValidationError(
                f"action values must be real numbers, but got complex values (dtype {raw.dtype})"
            )
        A = np.asarray(raw, dtype=float)
        if A.shape != (n, self.dim) and not (n == 1 and A.shape == (self.dim,)):
            want = f"({self.dim},)" if n == 1 else f"({n}, {self.dim})"
            raise ValidationError(f"action must have shape {want}, but got {np.shape(actions)}")
        A = A.reshape(n, self.dim)
        bad = ~np.isfinite(A)
        if bad.any():
            r, c = np.argwhere(bad)[0]
            where = f"row {r} " if n > 1 else ""
            raise ValidationError(
                f"action values must be finite, but {where}component {c} "
                f"({self.space.names[c]!r}) is {A[r, c]}"
            )
        U = (np.clip(A, -1.0, 1.0) + 1.0) / 2.0
        return self.space.to_physical(U)

    def designs_to_actions(self, X: np.ndarray) -> np.ndarray:
        """Physical designs (n, d) -> actions in [-1, 1] (inverse map, for callers)."""
        return np.clip(2.0 * self.space.to_unit(X) - 1.0, -1.0, 1.0)

    # --------------------------------------------------------------- outputs
    def outputs(self, X: np.ndarray, batch: EvaluationBatch) -> dict[str, Any]:
        """Observation, reward and info arrays for every row of an evaluated batch.

        Returns a dict of (n, ...) arrays: ``obs`` (n, m), ``reward`` (n,),
        ``objectives`` (n, m), ``constraints`` (n, k), ``ok`` (n,), ``message`` (n,)
        object, ``violation`` (n,), ``scalarized`` (n,), and ``x`` (n, d).
        """
        F = np.asarray(batch.objectives, dtype=float)
        G = np.asarray(batch.constraints, dtype=float).reshape(len(batch), self.k)
        messages = list(batch.messages)
        ok = np.asarray(batch.ok, dtype=bool).copy()
        finite = np.isfinite(F).all(axis=1) & np.isfinite(G).all(axis=1)
        inside = finite & (np.abs(np.nan_to_num(F)) <= OBS_LIMIT).all(axis=1)
        for i in np.flatnonzero(ok & ~inside):
            ok[i] = False
            messages[i] = (
                "non-finite objective or constraint"
                if not finite[i]
                else f"objective outside the observation space [-{OBS_LIMIT:g}, {OBS_LIMIT:g}]"
            )
        violation = np.where(ok, batch.violation, 0.0)
        scal = np.full(len(batch), np.nan)
        if ok.any():
            scal[ok] = np.asarray(
                self._scalarize(self.reward_objectives(F[ok])), dtype=float
            ).reshape(-1)
        with np.errstate(over="ignore", invalid="ignore"):
            reward = -(scal + self.penalty * violation)
            if self.reward == "vector":
                reward = -(F + self.penalty * violation[:, None])
        for i in np.flatnonzero(ok & ~np.isfinite(reward.reshape(len(ok), -1)).all(axis=1)):
            ok[i] = False
            messages[i] = f"scalarized objective is not finite ({scal[i]})"
        fail = self.fail_value
        obs = np.where(ok[:, None], F, fail)
        return {
            "obs": obs,
            "reward": self._with_failed(reward, ok),
            "objectives": obs.copy(),
            "constraints": np.where(ok[:, None], G, fail),
            "ok": ok,
            "message": np.array(messages, dtype=object),
            "violation": np.where(ok, violation, fail),
            "scalarized": np.where(ok, scal, fail),
            "x": np.asarray(X, dtype=float),
        }

    def _with_failed(self, reward: np.ndarray, ok: np.ndarray) -> np.ndarray:
        """Rewards with every failed row set to :meth:`failed_reward`, after the lowest
        reward seen is updated with this batch's working rows."""
        R = reward.reshape(len(ok), -1)
        if ok.any():
            low = R[ok].min(axis=0)
            seen = self.lowest_reward
            self.lowest_reward = low if seen is None else np.minimum(seen, low)
        R = np.where(ok[:, None], R, self.failed_reward()[None, :])
        return R if self.reward == "vector" else R[:, 0]

    def info_row(self, out: dict[str, Any], i: int, evaluations: int) -> dict[str, Any]:
        """The ``info`` dict of row ``i`` (fresh objects every call)."""
        return {
            "objectives": out["objectives"][i].copy(),
            "constraints": out["constraints"][i].copy(),
            "parameters": self.space.as_dict(out["x"][i]),
            "ok": bool(out["ok"][i]),
            "message": str(out["message"][i]),
            "violation": float(out["violation"][i]),
            "scalarized": float(out["scalarized"][i]),
            "evaluations": int(evaluations),
        }

    def info_batch(self, out: dict[str, Any], evaluations: int) -> dict[str, Any]:
        """The vector-env ``info``: the keys of :meth:`info_row`, stacked along axis 0."""
        n = out["obs"].shape[0]
        info = {
            "objectives": out["objectives"].copy(),
            "constraints": out["constraints"].copy(),
            "parameters": {name: out["x"][:, j].copy() for j, name in enumerate(self.space.names)},
            "ok": out["ok"].copy(),
            "message": out["message"].copy(),
            "violation": out["violation"].copy(),
            "scalarized": out["scalarized"].copy(),
            "evaluations": np.full(n, int(evaluations), dtype=np.int64),
        }
        return with_masks(info, n)


def with_masks(info: dict[str, Any], n: int) -> dict[str, Any]:
    """Add gymnasium's ``_key`` presence masks (every sub-env has every key)."""
    out: dict[str, Any] = {}
    for key, value in info.items():
        out[key] = with_masks(value, n) if isinstance(value, dict) else value
        out[f"_{key}"] = np.ones(n, dtype=bool)
    return out
