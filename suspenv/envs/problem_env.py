"""``ProblemEnv``: any suspenv problem as a Gymnasium environment, one design per step."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from suspenv.core.errors import ValidationError
from suspenv.core.options import integer
from suspenv.core.problem import Problem
from suspenv.envs.adapter import (
    FAIL_VALUE,
    OBS_LIMIT,
    ProblemAdapter,
    Scalarizer,
    build_problem,
    problem_key,
)


def single_spaces(adapter: ProblemAdapter) -> tuple[spaces.Box, spaces.Box]:
    """(action space [-1, 1]^d, observation space [-OBS_LIMIT, OBS_LIMIT]^m), float64."""
    action = spaces.Box(-1.0, 1.0, shape=(adapter.dim,), dtype=np.float64)
    observation = spaces.Box(-OBS_LIMIT, OBS_LIMIT, shape=(adapter.m,), dtype=np.float64)
    return action, observation


class EnvBase:
    """What both envs share: the problem, its adapter and budget, the reference
    evaluation and the read-outs of the reward."""

    problem: Problem
    adapter: ProblemAdapter
    budget: int
    _reference: dict[str, Any] | None = None

    def _bind(
        self,
        problem: str | Problem,
        problem_options: dict[str, Any] | None,
        budget: int,
        **shaping: Any,
    ) -> None:
        """Build the problem and its adapter (``shaping``: the adapter's keywords) and
        check the budget."""
        self.problem = build_problem(problem, problem_options)
        key = problem_key(problem, problem_options, self.problem)
        self.adapter = ProblemAdapter(self.problem, scales_key=key, **shaping)
        self.budget = integer(type(self).__name__, "budget", budget, lo=1)

    def _reference_outputs(self) -> dict[str, Any]:
        """The adapter's outputs of the reference design, evaluated once per env."""
        if self._reference is None:
            x = self.problem.reference_design()[None, :]
            self._reference = self.adapter.outputs(x, self.problem.evaluate(x))
        return self._reference

    @property
    def reward_mode(self) -> str:
        """The reward mode: "normalized", "sum" or "vector" (see the Rewards section)."""
        return self.adapter.reward

    @property
    def objective_scales(self) -> np.ndarray:
        """The scales ``s_j`` (m,) of the normalised reward, in the objectives' units
        (the problem's declared ones, else computed on first use by 65 evaluations; see
        :mod:`suspenv.envs.scales`)."""
        return self.adapter.scales.scales.copy()

    def spec_sheet(self, with_scales: bool = False) -> str:
        """This env's spec sheet (Markdown): spaces with names, units and bounds, reward,
        episode and arguments. ``with_scales`` adds the objective scales (computes them)."""
        from suspenv.envs.spec import spec_sheet

        return spec_sheet(self, with_scales=with_scales)


class ProblemEnv(EnvBase, gym.Env[np.ndarray, np.ndarray]):
    """A suspenv problem as a black-box optimisation episode (``suspenv/<Name>-v0``).

    ## Description

    Every registered problem is an env: ``gymnasium.make("suspenv/CarSideImpact-v0")``
    after ``import suspenv``. Each step evaluates one design; an episode is one
    optimisation run of ``budget`` evaluations. There is no hidden state: the next
    observation depends only on the action, so the env suits black-box optimisers and
    bandit-style agents alike. The concrete spaces, units and reward of one env are in
    its spec sheet: ``env.unwrapped.spec_sheet()`` (:func:`suspenv.envs.spec.spec_sheet`)
    and ``docs/envs.md``.

    ## Action Space

    ``Box(-1, 1, (d,), float64)``, d = number of design parameters. Action ``a`` maps
    to the unit cube ``u = (a + 1) / 2`` and to physical values through the problem's
    :class:`~suspenv.core.DesignSpace` (linear or log per parameter; each parameter's
    name, unit and bounds are in the spec sheet). Finite actions outside [-1, 1] are
    clipped; NaN/inf or complex actions or a wrong shape raise
    :class:`~suspenv.core.errors.ValidationError`. ``design_to_action(x)`` inverts the map.

    ## Observation Space

    ``Box(-1e300, 1e300, (m,), float64)``: the m objective values (minimised) of the
    design just evaluated, in the problem's units (``problem.objective_names``,
    ``problem.objective_units``); never normalised. A failed evaluation is observed as
    ``fail_value`` (default 1e10) in every component, with ``info["ok"] = False`` and
    the reason in ``info["message"]``.

    ## Rewards

    ``-(s + penalty * v)`` per step, where

    * ``s`` is the scalarised objectives (``scalarizer`` "weighted_sum" with ``weights``,
      default all 1, or a callable ``F (n, m) -> (n,)``) of either
      - ``reward="normalized"``: each objective divided by its scale: the problem's
        declared ``objective_scales`` (KCIdentification: each objective's standard
        error), else ``s_j = max(|f_j(x_ref)|, 0.1 * IQR_j)`` (its value at the
        reference design, at least a tenth of its interquartile range over a fixed
        seeded sample of 64 designs; :mod:`suspenv.envs.scales`), so at the reference
        design each objective contributes at most 1 and an objective no design can move
        never dominates; or
      - ``reward="sum"``: the objectives in their own units (the reward of earlier
        versions; reproduces their numbers); on objectives in several units a
        :class:`~suspenv.envs.adapter.MixedUnitsWarning` names them.
      The default is "normalized" for objectives in more than one unit (KCIdentification,
      MinibusRideHandling, CarSideImpact) and "sum" otherwise
      (:func:`~suspenv.envs.adapter.default_reward`).
    * ``v = sum_j max(g_j / s_j, 0)`` is the total constraint violation (constraints are
      feasible when ``g <= 0``; ``s_j`` the problem's constraint scales), dimensionless
      (:attr:`EvaluationBatch.violation <suspenv.core.result.EvaluationBatch.violation>`);
      ``penalty`` defaults to 100.
    * A failed evaluation earns the lowest reward of a working design this env has seen
      (the reset's reference design included) minus ``0.1 * |lowest| + 1``: finite and
      below every working design (``-fail_value`` only while none has worked).
    * ``reward="vector"`` (two or more objectives): MO-Gymnasium's convention, a reward
      vector ``-(f_j + penalty * v)`` (m,), every component maximised, in the objectives'
      units; ``reward_space`` and ``reward_dim`` are set; a failure gets the lowest seen
      per component minus the same margin.

    The batch-normalised "rank_sum" needs a population: use the vector env.

    ## Starting State

    ``reset()`` evaluates the problem's reference design
    (``problem.reference_design()``: each parameter's default, else the centre of its
    range) and returns its objectives; this evaluation is not counted in the budget. The
    problem is deterministic, so the reference evaluation is computed once per env and
    reused. ``seed`` only seeds ``np_random`` (unused by the dynamics, which are
    deterministic). With ``reward="normalized"`` the first reset also computes the
    objective scales (65 evaluations, cached per problem name and options).

    ## Episode End

    ``terminated`` is always False (there is no goal state); ``truncated`` is True on
    the ``budget``-th step. Stepping again before ``reset()`` raises ``RuntimeError``.

    ## Info

    Fresh objects every call: ``objectives`` (m,), ``constraints`` (k,) (both
    ``fail_value`` when failed), ``parameters`` {name: physical value}, ``ok``,
    ``message``, ``violation``, ``scalarized`` (``s`` above), ``evaluations`` (steps
    taken in this episode).

    ## Rendering

    ``render_mode="rgb_array"`` when the problem defines
    ``render_rgb(x_physical) -> uint8 (H, W, 3)`` (the last evaluated design);
    otherwise ``metadata["render_modes"]`` is empty and ``render()`` returns None.

    ## Arguments

    * ``problem``: registered problem name (see ``suspenv list``) or a Problem instance.
    * ``problem_options``: constructor options of a named problem.
    * ``budget``: evaluations per episode, an integer >= 1 (default 100).
    * ``reward``: "normalized", "sum" or "vector" (default: the problem's, see Rewards).
    * ``scalarizer``, ``weights``, ``penalty`` (>= 0), ``fail_value`` (0 <= . <= 1e300):
      reward shaping, see Rewards.
    * ``render_mode``: None or "rgb_array".

    ## Version History

    * v0: initial version. Later in v0: the ``reward`` argument; the default reward of
      objectives in several units became "normalized" (KCIdentification first, then
      every such problem; pass ``reward="sum"`` for the earlier numbers). Later: a
      problem's declared objective scales set the normalised reward (KCIdentification:
      standard errors); the violation is dimensionless; ``reward="sum"`` on objectives
      in several units warns.
    """

    metadata: dict[str, Any] = {"render_modes": ["rgb_array"], "render_fps": 4}

    def __init__(
        self,
        problem: str | Problem,
        problem_options: dict[str, Any] | None = None,
        budget: int = 100,
        scalarizer: Scalarizer = "weighted_sum",
        weights: Sequence[float] | None = None,
        penalty: float = 100.0,
        fail_value: float = FAIL_VALUE,
        render_mode: str | None = None,
        reward: str | None = None,
    ):
        self._bind(
            problem,
            problem_options,
            budget,
            scalarizer=scalarizer,
            weights=weights,
            penalty=penalty,
            fail_value=fail_value,
            reward=reward,
        )
        can_render = callable(getattr(self.problem, "render_rgb", None))
        self.metadata = {"render_modes": ["rgb_array"] if can_render else [], "render_fps": 4}
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValidationError(
                f"`render_mode` must be one of {self.metadata['render_modes'] + [None]} for "
                f"{self.problem.name}, but got {render_mode!r}"
                + ("" if can_render else " (the problem defines no render_rgb)")
            )
        self.render_mode = render_mode
        self.action_space, self.observation_space = single_spaces(self.adapter)
        if self.adapter.reward == "vector":  # MO-Gymnasium's attributes
            self.reward_space = spaces.Box(-np.inf, np.inf, shape=(self.adapter.m,))
            self.reward_dim = self.adapter.m
        self._steps = 0
        self._done = False
        self._last_x: np.ndarray | None = None

    # -------------------------------------------------------------- gym API
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        out = self._reference_outputs()
        self._steps = 0
        self._done = False
        self._last_x = self.problem.reference_design()
        return out["obs"][0].copy(), self.adapter.info_row(out, 0, 0)

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        if self._done:
            raise RuntimeError(
                f"the episode ended after budget={self.budget} steps: call reset() before step()"
            )
        X = self.adapter.actions_to_designs(action, 1)
        out = self.adapter.outputs(X, self.problem.evaluate(X))
        self._steps += 1
        self._done = self._steps >= self.budget
        self._last_x = X[0].copy()
        info = self.adapter.info_row(out, 0, self._steps)
        r = out["reward"][0]
        reward = r.copy() if self.adapter.reward == "vector" else float(r)
        return out["obs"][0].copy(), reward, False, self._done, info

    def render(self) -> np.ndarray | None:
        if self.render_mode != "rgb_array" or self._last_x is None:
            return None
        render_rgb = self.problem.render_rgb
        assert render_rgb is not None  # invariant: "rgb_array" is only accepted when defined
        return np.asarray(render_rgb(self._last_x.copy()), dtype=np.uint8)

    # ------------------------------------------------------------- helpers
    def design_to_action(self, x_physical: Sequence[float]) -> np.ndarray:
        """The action that evaluates the physical design ``x_physical``."""
        return self.adapter.designs_to_actions(np.asarray(x_physical, dtype=float)[None, :])[0]
