"""``ProblemVectorEnv``: a whole population per step, evaluated with one batch call."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from suspenv.core.errors import ValidationError
from suspenv.core.options import integer
from suspenv.core.problem import Problem
from suspenv.envs.adapter import (
    FAIL_VALUE,
    Scalarizer,
)
from suspenv.envs.problem_env import EnvBase, single_spaces


class ProblemVectorEnv(EnvBase, VectorEnv):
    """``num_envs`` copies of :class:`~suspenv.envs.problem_env.ProblemEnv` stepped as one.

    ## Description

    ``gymnasium.make_vec("suspenv/<Name>-v0", num_envs=n)`` builds this class (the
    registered ``vector_entry_point``). Each ``step(actions)`` maps the (n, d) actions
    to designs and evaluates them with ONE ``problem.evaluate(X)`` call, so a problem
    that vectorises its physics evaluates a population as fast as one design. With
    ``scalarizer="weighted_sum"`` (or any row-wise callable) every row gets exactly the
    observation, reward and info a single ``ProblemEnv`` would give (same reward mode,
    same objective scales).

    ## Action Space

    ``Box(-1, 1, (n, d), float64)``; ``single_action_space`` as in ``ProblemEnv``.

    ## Observation Space

    ``Box(-1e300, 1e300, (n, m), float64)``: row i is the objectives of sub-env i's
    design, in the problem's units; ``single_observation_space`` as in ``ProblemEnv``.

    ## Rewards

    Row by row as in ``ProblemEnv`` (``reward`` "normalized" or "sum", ``scalarizer``,
    ``weights``, ``penalty``, ``fail_value``). ``scalarizer="rank_sum"`` (Tey et al.
    2014) min-max normalises each objective over the rows of the step (failed rows left
    out) and sums to ``10 * m`` at most, so a row's reward depends on the other rows; it
    is invariant to the objective scales, so both reward modes give the same numbers.

    ## Starting State

    ``reset()`` evaluates the reference design once and repeats it for every sub-env
    (not counted in the budget).

    ## Episode End

    Every sub-env truncates together on the ``budget``-th step (``terminated`` is always
    False). Autoreset mode ``NEXT_STEP`` (gymnasium's default): the step after a
    truncation ignores its actions, resets every sub-env (reference design, reward 0, not
    counted in the budget) and returns the reset observations.

    ## Info

    The keys of ``ProblemEnv``'s info stacked along axis 0 (``parameters`` is a dict of
    (n,) arrays, ``message`` an object array), each with gymnasium's ``_key`` presence
    mask.

    ## Arguments

    ``num_envs`` (population size, an integer >= 1, default 8) and the arguments of
    ``ProblemEnv``; ``render_mode`` must be None (no vector rendering).

    ## Version History

    * v0: initial version. Later in v0: the ``reward`` argument, as in ``ProblemEnv``.
    """

    metadata: dict[str, Any] = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}

    def __init__(
        self,
        problem: str | Problem,
        num_envs: int = 8,
        problem_options: dict[str, Any] | None = None,
        budget: int = 100,
        scalarizer: Scalarizer = "weighted_sum",
        weights: Sequence[float] | None = None,
        penalty: float = 100.0,
        fail_value: float = FAIL_VALUE,
        render_mode: str | None = None,
        reward: str | None = None,
    ):
        self.num_envs = integer(type(self).__name__, "num_envs", num_envs, lo=1)
        if render_mode is not None:
            raise ValidationError(
                f"`render_mode` must be None for the vector env, but got {render_mode!r}"
            )
        self._bind(
            problem,
            problem_options,
            budget,
            scalarizer=scalarizer,
            weights=weights,
            penalty=penalty,
            fail_value=fail_value,
            batch_scalarizer_ok=True,
            reward=reward,
        )
        self.render_mode = None
        self.single_action_space, self.single_observation_space = single_spaces(self.adapter)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self._steps = 0
        self._started = False
        self._autoreset = False

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        ref = self._reference_outputs()
        out = {k: np.repeat(v, self.num_envs, axis=0) for k, v in ref.items()}
        self._steps = 0
        self._started = True
        self._autoreset = False
        return out["obs"].copy(), self.adapter.info_batch(out, 0)

    def step(
        self, actions: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        if not self._started:
            raise RuntimeError("call reset() before step()")
        n = self.num_envs
        if self._autoreset:
            obs, info = self.reset()
            width = (n, self.adapter.m) if self.adapter.reward == "vector" else (n,)
            return obs, np.zeros(width), np.zeros(n, bool), np.zeros(n, bool), info
        X = self.adapter.actions_to_designs(actions, n)
        out = self.adapter.outputs(X, self.problem.evaluate(X))
        self._steps += 1
        self._autoreset = self._steps >= self.budget
        truncated = np.full(n, self._autoreset, dtype=bool)
        info = self.adapter.info_batch(out, self._steps)
        return out["obs"], out["reward"].astype(np.float64), np.zeros(n, bool), truncated, info

    def render(self) -> None:
        return None
