"""What a training config may instantiate: plain maps of names, nothing else.

A config never names a Python object by import path.  Algorithms, policies, activation
functions, action noises and callbacks are picked by *name* from the maps below;
environments by the env configs in ``conf/env`` (which name a registered Gymnasium id,
see :data:`pyflyt_engine.envs.ENVS`).  Hydra-style ``_target_`` keys are accepted only
when they name one of these same objects by its import path (:data:`TARGETS`); anything
else (``os.system``, ``builtins.eval`` ...) is refused before anything runs.

The maps hold import strings, resolved lazily, so reading a config never imports torch.
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from typing import Any

from pyflyt_engine.errors import ConfigError

#: algorithm name -> Stable-Baselines3 class (import string); ``algo.name`` in a config
ALGOS: dict[str, str] = {
    "ppo": "stable_baselines3:PPO",
    "a2c": "stable_baselines3:A2C",
    "sac": "stable_baselines3:SAC",
    "td3": "stable_baselines3:TD3",
    "ddpg": "stable_baselines3:DDPG",
    # not in SB3: ours, on SB3's SAC policy (pyflyt_cli/training/awac.py)
    "awac": "pyflyt_cli.training.awac:AWAC",
    # not in SB3: ours, SAC with an oracle policy (pyflyt_cli/training/ccge.py)
    "ccge": "pyflyt_cli.training.ccge:CCGE",
    # sb3-contrib
    "tqc": "sb3_contrib:TQC",
    "crossq": "sb3_contrib:CrossQ",
    "trpo": "sb3_contrib:TRPO",
    "recurrent_ppo": "sb3_contrib:RecurrentPPO",
}

#: algorithms that learn from a replay buffer (checkpoints also save the buffer)
OFF_POLICY: frozenset[str] = frozenset({"sac", "td3", "ddpg", "awac", "ccge", "tqc", "crossq"})

#: ``init_from``: algorithm -> algorithms whose policy weights it can start from (besides
#: itself).  AWAC uses SAC's policy class unchanged, so it bootstraps from a SAC run as in
#: Nair et al. (2020).
#: CCGE likewise takes a SAC policy: its actor becomes the oracle (Tai et al. 2022).
INIT_FROM: dict[str, frozenset[str]] = {"awac": frozenset({"sac"}), "ccge": frozenset({"sac"})}

#: policies an algorithm may use (the envs' observations are flattened to one Box)
POLICIES: frozenset[str] = frozenset({"MlpPolicy", "MlpLstmPolicy"})

#: ``algo.policy_kwargs.activation_fn`` -> torch module class
ACTIVATIONS: dict[str, str] = {
    "tanh": "torch.nn:Tanh",
    "relu": "torch.nn:ReLU",
    "elu": "torch.nn:ELU",
    "leaky_relu": "torch.nn:LeakyReLU",
    "gelu": "torch.nn:GELU",
    "silu": "torch.nn:SiLU",
}

#: ``algo.action_noise.type`` -> SB3 action noise class (off-policy algorithms)
ACTION_NOISES: dict[str, str] = {
    "normal": "stable_baselines3.common.noise:NormalActionNoise",
    "ornstein_uhlenbeck": "stable_baselines3.common.noise:OrnsteinUhlenbeckActionNoise",
}

#: ``callbacks[].name`` -> SB3 callback class; called after each evaluation
CALLBACKS: dict[str, str] = {
    "stop_on_reward": "stable_baselines3.common.callbacks:StopTrainingOnRewardThreshold",
    "stop_on_no_improvement": "stable_baselines3.common.callbacks:StopTrainingOnNoModelImprovement",
}


def _dotted(entry: str) -> set[str]:
    module, _, name = entry.partition(":")
    paths = {f"{module}.{name}"}
    if module == "stable_baselines3":  # stable_baselines3.PPO and stable_baselines3.ppo.PPO
        paths.add(f"stable_baselines3.{name.lower()}.{name}")
    if module == "sb3_contrib":  # sb3_contrib.TQC and sb3_contrib.tqc.TQC (RecurrentPPO: ppo_recurrent)
        paths.add(f"sb3_contrib.{'ppo_recurrent' if name == 'RecurrentPPO' else name.lower()}.{name}")
    return paths


#: accepted ``_target_`` import path -> (config group, registry name)
TARGETS: dict[str, tuple[str, str]] = {
    path: (group, name)
    for group, table in (
        ("algo", ALGOS),
        ("activation", ACTIVATIONS),
        ("action_noise", ACTION_NOISES),
        ("callback", CALLBACKS),
    )
    for name, entry in table.items()
    for path in _dotted(entry)
}


def resolve(table: Mapping[str, str], name: str, what: str) -> Any:
    """Import the object registered under ``name`` in ``table`` (a :class:`ConfigError` if unknown)."""
    if name not in table:
        raise ConfigError(unknown(what, name, table))
    module, _, attr = table[name].partition(":")
    return getattr(importlib.import_module(module), attr)


def unknown(what: str, name: str, choices: Any) -> str:
    """``unknown <what> '<name>'. Did you mean '...'? Available: ...``."""
    import difflib

    options = sorted(choices)
    close = difflib.get_close_matches(str(name), options, n=1)
    hint = f" Did you mean '{close[0]}'?" if close else ""
    return f"unknown {what} '{name}'.{hint} Available: {', '.join(options)}"


def check_targets(tree: Any, path: str = "") -> Any:
    """A copy of ``tree`` where every ``_target_`` is replaced by its registry ``name``.

    Raises :class:`ConfigError` for a ``_target_`` outside :data:`TARGETS` and for Hydra's
    other instantiation keys (``_args_``, ``_partial_``, ``_call_``, ``_recursive_``,
    ``_convert_``), which nothing here honours.  Nothing is imported or called.
    """
    if isinstance(tree, Mapping):
        out: dict[str, Any] = {}
        for key, value in tree.items():
            where = f"{path}.{key}" if path else str(key)
            if key == "_target_":
                if not isinstance(value, str) or value not in TARGETS:
                    allowed = ", ".join(sorted(TARGETS))
                    raise ConfigError(
                        f"{where}: refusing to instantiate {value!r}: a config may only name the project's "
                        f"registered algorithms, activations, action noises and callbacks (by name, e.g. "
                        f"algo=sac, or by one of these import paths: {allowed})"
                    )
                _, name = TARGETS[value]
                if "name" in tree and tree["name"] != name:
                    raise ConfigError(f"{where}: _target_ {value} contradicts name={tree['name']!r}")
                out["name"] = name
            elif key in ("_args_", "_partial_", "_call_", "_recursive_", "_convert_"):
                raise ConfigError(
                    f"{where}: Hydra instantiation key '{key}' is not supported; name a registered object instead"
                )
            else:
                out[key] = check_targets(value, where)
        return out
    if isinstance(tree, (list, tuple)):
        return [check_targets(v, f"{path}[{i}]") for i, v in enumerate(tree)]
    return tree
