"""Spec sheets of the envs: the sections of Gymnasium's classic-control docstrings
(Description, Action Space, Observation Space, Rewards, Starting State, Episode End,
Arguments, Version History) filled in with one env's concrete spaces, units and reward.

``spec_sheet("KCIdentification")`` or ``env.unwrapped.spec_sheet()`` returns Markdown;
``python -m suspenv.envs.spec KCIdentification`` prints it. The generic definitions are in
the docstrings of :class:`~suspenv.envs.problem_env.ProblemEnv` and
:class:`~suspenv.envs.vector_env.ProblemVectorEnv`.
"""

from __future__ import annotations

import sys
from typing import Any

from suspenv.core.markdown import table_lines
from suspenv.envs.adapter import FAIL_VALUE, OBS_LIMIT, default_reward
from suspenv.envs.registration import NAMESPACE, VERSION, resolve_env_id
from suspenv.envs.scales import SAMPLE_SEED, SAMPLE_SIZE, SPREAD_FRACTION

#: the section headers every spec sheet (and every env class docstring) has, in order
SECTIONS = (
    "Description",
    "Action Space",
    "Observation Space",
    "Rewards",
    "Starting State",
    "Episode End",
    "Arguments",
    "Version History",
)


def _g(x: float) -> str:
    return f"{x:.6g}"


def spec_sheet(env: Any, with_scales: bool = False, **env_kwargs: Any) -> str:
    """Markdown spec sheet of ``env``: a ProblemEnv / ProblemVectorEnv (or a gymnasium
    wrapper of one), or a problem name or env id (the env is built with ``env_kwargs``).

    ``with_scales``: list each objective's scale of the normalised reward (computes them:
    65 evaluations of the problem)."""
    if isinstance(env, str):  # built through gymnasium's registry (no import of the env)
        import gymnasium as gym

        env = gym.make(resolve_env_id(env), **env_kwargs)
    env = getattr(env, "unwrapped", env)
    adapter = env.adapter
    problem = adapter.problem
    sections = {
        "Description": _description_rows(env, problem),
        "Action Space": _action_rows(env, problem.space),
        "Observation Space": _observation_rows(env, with_scales),
        "Rewards": _reward_rows(adapter, problem),
        "Starting State": [
            "`reset()` evaluates the reference design (column *reference* above) and "
            "returns its objectives; not counted in the budget. The dynamics are "
            "deterministic; `seed` seeds `np_random` only."
        ],
        "Episode End": [
            f"`terminated` is always False; `truncated` is True on step {env.budget} "
            "(`budget`)."
            + (" Autoreset NEXT_STEP." if _vector(env) else " Step again only after `reset()`.")
        ],
        "Arguments": _argument_rows(env, problem),
        "Version History": [
            "v0: initial version; later in v0 the `reward` argument (KCIdentification's "
            'default became "normalized").'
        ],
    }
    lines = [f"# {NAMESPACE}/{problem.name}-v{VERSION}", ""]
    for title in SECTIONS:
        lines.extend([f"## {title}", "", *sections[title], ""])
    return "\n".join(lines)


def _vector(env: Any) -> bool:
    """Whether ``env`` is a vector env (a population of designs per step)."""
    return hasattr(env, "num_envs")


def _batch_dim(env: Any) -> str:
    """The leading dimension of a vector env's spaces (``"N, "``), '' for one env."""
    return f"{env.num_envs}, " if _vector(env) else ""


def _description_rows(env: Any, problem: Any) -> list[str]:
    """The Description section: the problem, its options, what a step and an episode are."""
    options = problem.config()
    vector = _vector(env)
    return [
        f"{problem.description or problem.name} "
        f"(`{type(problem).__module__}:{type(problem).__name__}`"
        + (f", options `{options}`" if options else "")
        + ").",
        ("A population of designs" if vector else "One design")
        + f" per step; an episode is one optimisation run of {env.budget} evaluations"
        + (f" per sub-env ({env.num_envs} sub-envs)." if vector else "."),
    ]


def _action_rows(env: Any, space: Any) -> list[str]:
    """The Action Space section: the box, its map to physical values, the parameters."""
    return [
        f"`Box(-1.0, 1.0, ({_batch_dim(env)}{space.dim},), float64)`. Action `a` -> unit cube "
        "`u = (a + 1) / 2` -> physical value (linear: `low + u (high - low)`; log: "
        "`low (high / low)^u`); finite actions outside [-1, 1] are clipped.",
        "",
        *table_lines(
            ["#", "parameter", "unit", "low", "high", "map", "reference"],
            (
                [
                    i,
                    f"`{p.name}`",
                    p.unit or "-",
                    _g(p.low),
                    _g(p.high),
                    "log" if p.log else "linear",
                    _g(p.reference),
                ]
                for i, p in enumerate(space.parameters)
            ),
        ),
    ]


def _observation_rows(env: Any, with_scales: bool) -> list[str]:
    """The Observation Space section: the box and the objectives (with the normalised
    reward's scales when ``with_scales``)."""
    adapter = env.adapter
    problem = adapter.problem
    units = tuple(problem.objective_units) or ("",) * problem.n_objectives
    scales = adapter.scales if with_scales else None
    return [
        f"`Box({-OBS_LIMIT:g}, {OBS_LIMIT:g}, ({_batch_dim(env)}{problem.n_objectives},), "
        "float64)`: the objectives (minimised) of the design just evaluated, in their units; "
        f"every component is `fail_value` ({adapter.fail_value:g}) when the evaluation failed.",
        "",
        *table_lines(
            ["#", "objective", "unit"] + (["scale s_j"] if scales else []),
            (
                [j, f"`{name}`", units[j] or "-"] + ([_g(scales.scales[j])] if scales else [])
                for j, name in enumerate(problem.objective_names)
            ),
        ),
    ]


def _argument_rows(env: Any, problem: Any) -> list[str]:
    """The Arguments section: the constructor arguments with their current values."""
    adapter = env.adapter
    return [
        f"`problem={problem.name!r}`, `problem_options` (the problem's constructor options, "
        f"now {problem.config()}), `budget={env.budget}`, "
        f"`reward` ({adapter.reward!r}; default {default_reward(problem)!r}), "
        f"`scalarizer={adapter.scalarizer_name!r}`, `weights`, `penalty={adapter.penalty:g}`, "
        f"`fail_value={adapter.fail_value:g}` (default {FAIL_VALUE:g}), `render_mode`"
        + (f", `num_envs={env.num_envs}`" if _vector(env) else "")
        + "."
    ]


def _reward_rows(adapter: Any, problem: Any) -> list[str]:
    """The Rewards section's paragraphs: the reward, the scales of its mode, the
    constraints."""
    rows = [
        f"`-(s + penalty * v)`, reward mode **{adapter.reward}**, scalarizer "
        f"`{adapter.scalarizer_name}`, penalty {adapter.penalty:g}; a failed evaluation "
        "earns the lowest reward of a working design seen so far minus `0.1 * |lowest| "
        f"+ 1` (`-fail_value` = {-adapter.fail_value:g} only while none has worked)."
    ]
    if adapter.reward == "normalized" and problem.objective_scales is not None:
        rows.append(
            "`s` scalarises `f_j / s_j` with `s_j` the scales the problem declares "
            "(`problem.objective_scales`, in the objectives' units). "
            '`reward="sum"` gives the objectives in their own units.'
        )
    elif adapter.reward == "normalized":
        rows.append(
            "`s` scalarises `f_j / s_j` with `s_j = max(|f_j(x_ref)|, "
            f"{SPREAD_FRACTION:g} * IQR_j)`: the objective at the reference design, at "
            "least a tenth of its interquartile range over a fixed sample of "
            f"{SAMPLE_SIZE} uniform designs (`numpy.random.default_rng({SAMPLE_SEED})`); "
            "1 where that is 0. Each objective contributes at most 1 at the reference "
            'design. `reward="sum"` gives the objectives in their own units.'
        )
    else:
        rows.append(
            '`s` scalarises the objectives in their own units; `reward="normalized"` '
            "divides each by its scale first (see `suspenv.envs.scales`)."
        )
    if problem.n_constraints:
        rows.append(
            f"`v = sum_j max(g_j, 0)` over the {problem.n_constraints} constraints "
            f"(feasible when g <= 0): {', '.join(f'`{c}`' for c in problem.constraint_names)}."
        )
    else:
        rows.append("No constraints: `v = 0`.")
    return rows


def main(argv: list[str] | None = None) -> int:
    """``python -m suspenv.envs.spec NAME [--scales]``: print one env's spec sheet."""
    args = list(sys.argv[1:] if argv is None else argv)
    with_scales = "--scales" in args
    names = [a for a in args if a != "--scales"]
    if len(names) != 1:
        print("usage: python -m suspenv.envs.spec NAME [--scales]", file=sys.stderr)
        return 2
    print(spec_sheet(names[0], with_scales=with_scales), end="")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
