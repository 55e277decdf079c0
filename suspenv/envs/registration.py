"""Register every suspenv problem with Gymnasium as ``suspenv/<Name>-v0``, lazily.

Registration stores only entry-point strings and ``kwargs={"problem": name}``: no problem
module is imported until an env is made. It runs on ``import suspenv`` (Gymnasium
1.x has no plugin entry points, so an import is the trigger) and again inside
:func:`make_env`, which also picks up problems registered later with
:func:`suspenv.registry.register_problem`. Without importing first, the id can carry
the module: ``gymnasium.make("suspenv.envs:suspenv/Sphere-v0")``.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym

from suspenv.core.errors import ValidationError
from suspenv.core.options import did_you_mean
from suspenv.registry import list_problems

NAMESPACE = "suspenv"
VERSION = 0
ENTRY_POINT = "suspenv.envs.problem_env:ProblemEnv"
VECTOR_ENTRY_POINT = "suspenv.envs.vector_env:ProblemVectorEnv"


def env_id(problem_name: str) -> str:
    """The Gymnasium id of a problem: ``suspenv/<Name>-v0``."""
    return f"{NAMESPACE}/{problem_name}-v{VERSION}"


def register_envs() -> list[str]:
    """Register every problem of :func:`~suspenv.registry.list_problems` (idempotent).

    Returns the ids of all suspenv envs.
    """
    ids = []
    for name in list_problems():
        eid = env_id(name)
        if eid not in gym.registry:
            gym.register(
                id=eid,
                entry_point=ENTRY_POINT,
                vector_entry_point=VECTOR_ENTRY_POINT,
                kwargs={"problem": name},
            )
        ids.append(eid)
    return ids


def resolve_env_id(name: str) -> str:
    """``"CarSideImpact"`` or ``"suspenv/CarSideImpact-v0"`` -> the registered id."""
    ids = register_envs()
    eid = name if name.startswith(f"{NAMESPACE}/") else env_id(name)
    if eid in ids:
        return eid
    names = list_problems()
    hint = did_you_mean(name.removeprefix(f"{NAMESPACE}/"), names, cutoff=0.4)
    raise ValidationError(f"unknown env {name!r}{hint} (known problems: {', '.join(names)})")


def make_env(name: str, **kwargs: Any) -> gym.Env:
    """``gymnasium.make`` for a suspenv problem name or env id, with env options."""
    return gym.make(resolve_env_id(name), **kwargs)


def make_vector_env(name: str, num_envs: int = 8, **kwargs: Any) -> gym.vector.VectorEnv:
    """The batch-evaluating vector env (``gymnasium.make_vec`` via the vector entry point)."""
    return gym.make_vec(
        resolve_env_id(name), num_envs=num_envs, vectorization_mode="vector_entry_point", **kwargs
    )
