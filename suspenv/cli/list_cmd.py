"""``suspenv list``: registered problems, strategies, envs and pipelines."""

from __future__ import annotations

import argparse

from suspenv import registry


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("list", help="list problems, strategies, envs and pipelines")
    p.set_defaults(func=_list)


def _describe(loader, name: str) -> str:
    try:
        return getattr(loader(name), "description", "") or ""
    except Exception as exc:  # noqa: BLE001 - a broken plug-in must not hide the others
        return f"(unavailable: {type(exc).__name__}: {exc})"


def _list(args: argparse.Namespace) -> int:
    print("problems (Gymnasium env id in brackets):")
    for name in registry.list_problems():
        print(f"  {name:<22} [suspenv/{name}-v0]  {_describe(registry.problem_class, name)}")
    from suspenv.envs import register_envs  # registers any new problems; returns every id

    print(f"gymnasium envs (after `import suspenv`): {', '.join(register_envs())}")
    print("strategies:")
    for name in registry.list_strategies():
        print(f"  {name:<22} {_describe(registry.strategy_class, name)}")
    print("pipelines (config key `pipeline`):")
    for name in registry.list_pipelines():
        print(f"  {name}")
    return 0
