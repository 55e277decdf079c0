"""The Gymnasium face: every registered problem as env ``suspenv/<Name>-v0``.

Importing suspenv (or this package) registers the envs (lazily: no problem module is
imported)::

    import gymnasium as gym
    import suspenv  # registers suspenv/<Name>-v0 for every problem

    env = gym.make("suspenv/CarSideImpact-v0", budget=50)
    vec = gym.make_vec("suspenv/CarSideImpact-v0", num_envs=16)  # one batch call per step

Thin adapters only: no physics here (see :mod:`suspenv.envs.adapter`).
"""

from suspenv.envs.problem_env import ProblemEnv
from suspenv.envs.registration import (
    env_id,
    make_env,
    make_vector_env,
    register_envs,
)
from suspenv.envs.vector_env import ProblemVectorEnv

register_envs()

__all__ = [
    "ProblemEnv",
    "ProblemVectorEnv",
    "env_id",
    "make_env",
    "make_vector_env",
    "register_envs",
]
