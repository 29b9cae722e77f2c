"""Training and evaluation of agents on the pyflyt environments (Stable-Baselines3).

Plain functions on plain, validated configs:

* :func:`compose_config` — the configuration ``pyflyt train`` composes from ``conf/``
  (:mod:`.compose`, the only module here that uses Hydra)
* :func:`train` / :func:`resume` — :mod:`.loop`
* :func:`evaluate_run`, :func:`evaluate_oracle` — :mod:`.evaluate`
* :class:`TrainConfig`, :func:`parse_train_config`, :class:`EvalOptions` — :mod:`.schema`
* what a config may instantiate — :mod:`.registry`
* the run directory layout — :mod:`.rundir`
"""

from __future__ import annotations

from typing import Any

_LAZY = {
    "compose_config": "pyflyt_cli.training.compose",
    "train": "pyflyt_cli.training.loop",
    "resume": "pyflyt_cli.training.loop",
    "RunResult": "pyflyt_cli.training.loop",
    "evaluate_run": "pyflyt_cli.training.evaluate",
    "evaluate_oracle": "pyflyt_cli.training.evaluate",
    "EvalReport": "pyflyt_cli.training.evaluate",
    "TrainConfig": "pyflyt_cli.training.schema",
    "EvalOptions": "pyflyt_cli.training.schema",
    "parse_train_config": "pyflyt_cli.training.schema",
    "parse_eval_options": "pyflyt_cli.training.schema",
}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "EvalOptions",
    "EvalReport",
    "RunResult",
    "TrainConfig",
    "compose_config",
    "evaluate_oracle",
    "evaluate_run",
    "parse_eval_options",
    "parse_train_config",
    "resume",
    "train",
]
