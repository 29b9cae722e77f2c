"""What a training config may instantiate: plain maps of names, nothing else.

:data:`ALGORITHMS` is the one table of what the library knows of each algorithm (its
class, its hyper-parameters' model, on- or off-policy, what ``init_from`` accepts,
whether imitation can fit its policy, its policies and the policy keys only it takes).

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
from dataclasses import dataclass
from typing import Any

from pyflyt_engine.errors import ConfigError


@dataclass(frozen=True)
class Algorithm:
    """What the library knows of one algorithm (a row of :data:`ALGORITHMS`)."""

    #: the class that trains it (import string, resolved lazily)
    cls: str
    #: its hyper-parameters' model in :mod:`pyflyt_cli.training.schema` (``algo:`` of a config)
    config: str
    #: learns from a replay buffer: its checkpoints also save the buffer, which an exact
    #: resume needs; otherwise on-policy (rollouts of ``n_steps`` per env)
    off_policy: bool
    #: ``init_from``: the algorithms whose policy weights it can start from, besides itself
    init_from: frozenset[str] = frozenset()
    #: ``train.imitation`` (DAgger before learning) can fit its policy state by state: its
    #: policy gives a differentiable deterministic action from one observation
    imitation: bool = True
    #: the policies it takes (every one is in :data:`POLICIES`)
    policies: frozenset[str] = frozenset({"MlpPolicy"})
    #: the ``algo.policy_kwargs`` keys its policies take that not every algorithm's do
    #: (every one in :data:`SPECIFIC_POLICY_KEYS`; the others must leave them null)
    policy_keys: frozenset[str] = frozenset()
    #: import strings of the library classes it computes exactly (its ``cls`` is a subclass
    #: with the same numbers): a config's ``_target_`` may name those too
    same_as: tuple[str, ...] = ()
    #: the optional extra of pyproject.toml it needs (``pip install 'pyflyt-toolkit[<extra>]'``)
    #: and the modules that extra brings; none: the core ``[rl]`` install has it
    extra: str | None = None
    needs: tuple[str, ...] = ()
    #: the ``algo.policy_kwargs`` keys its policies do not take (they must stay null)
    no_policy_keys: frozenset[str] = frozenset()


#: algorithm name (``algo.name``, ``conf/algo/<name>.yaml`` holds its defaults) -> its facts
ALGORITHMS: dict[str, Algorithm] = {
    "ppo": Algorithm("stable_baselines3:PPO", "PPOConfig", off_policy=False),
    "a2c": Algorithm("stable_baselines3:A2C", "A2CConfig", off_policy=False),
    # ours (pyflyt_cli/training/sac.py): SB3's SAC with cheaper gradient steps, the same numbers
    "sac": Algorithm("pyflyt_cli.training.sac:SAC", "SACConfig", off_policy=True, same_as=("stable_baselines3:SAC",)),
    # ours (pyflyt_cli/training/sac_jax.py): SBX's SAC (JAX), its gradient steps compiled by XLA;
    # not imitation (its policy is not a torch module), no activation or log_std choice
    "sac_jax": Algorithm(
        "pyflyt_cli.training.sac_jax:SACJax",
        "SACJaxConfig",
        off_policy=True,
        imitation=False,
        extra="jax",
        needs=("sbx", "jax", "flax", "optax"),
        no_policy_keys=frozenset({"activation_fn", "log_std_init"}),
    ),
    "td3": Algorithm("stable_baselines3:TD3", "TD3Config", off_policy=True),
    "ddpg": Algorithm("stable_baselines3:DDPG", "DDPGConfig", off_policy=True),
    # not in SB3: ours (pyflyt_cli/training/awac.py), on SB3's SAC policy class unchanged,
    # so it bootstraps from a SAC run as in Nair et al. (2020)
    "awac": Algorithm("pyflyt_cli.training.awac:AWAC", "AWACConfig", off_policy=True, init_from=frozenset({"sac"})),
    # not in SB3: ours (pyflyt_cli/training/ccge.py), SAC with an oracle policy: a SAC run's
    # actor becomes the oracle (Tai et al. 2022)
    "ccge": Algorithm("pyflyt_cli.training.ccge:CCGE", "CCGEConfig", off_policy=True, init_from=frozenset({"sac"})),
    # sb3-contrib
    "tqc": Algorithm("sb3_contrib:TQC", "TQCConfig", off_policy=True, policy_keys=frozenset({"n_quantiles"})),
    # batch renormalisation: its policy does not fit one state at a time
    "crossq": Algorithm(
        "sb3_contrib:CrossQ",
        "CrossQConfig",
        off_policy=True,
        imitation=False,
        policy_keys=frozenset({"batch_norm_momentum"}),
    ),
    "trpo": Algorithm("sb3_contrib:TRPO", "TRPOConfig", off_policy=False),
    # an LSTM's memory: its policy does not fit one state at a time
    "recurrent_ppo": Algorithm(
        "sb3_contrib:RecurrentPPO",
        "RecurrentPPOConfig",
        off_policy=False,
        imitation=False,
        policies=frozenset({"MlpLstmPolicy"}),
        policy_keys=frozenset({"lstm_hidden_size", "n_lstm_layers", "shared_lstm", "enable_critic_lstm"}),
    ),
}

#: views of :data:`ALGORITHMS`: name -> class (import string); the off-policy ones;
#: ``init_from`` beyond the algorithm itself
ALGOS: dict[str, str] = {name: a.cls for name, a in ALGORITHMS.items()}
OFF_POLICY: frozenset[str] = frozenset(name for name, a in ALGORITHMS.items() if a.off_policy)
INIT_FROM: dict[str, frozenset[str]] = {name: a.init_from for name, a in ALGORITHMS.items() if a.init_from}

#: policies an algorithm may use (the envs' observations are flattened to one Box)
POLICIES: frozenset[str] = frozenset().union(*(a.policies for a in ALGORITHMS.values()))
#: ``algo.policy_kwargs`` key -> the algorithms whose policies take it (keys only some take)
SPECIFIC_POLICY_KEYS: dict[str, frozenset[str]] = {
    key: frozenset(name for name, a in ALGORITHMS.items() if key in a.policy_keys)
    for key in sorted(set().union(*(a.policy_keys for a in ALGORITHMS.values())))
}

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
} | {path: ("algo", name) for name, a in ALGORITHMS.items() for entry in a.same_as for path in _dotted(entry)}


def check_installed(name: str) -> None:
    """A :class:`ConfigError` naming the extra to install if algorithm ``name`` needs modules that are missing."""
    import importlib.util

    algorithm = ALGORITHMS.get(name)
    if algorithm is None or not algorithm.needs:
        return
    missing = [m for m in algorithm.needs if importlib.util.find_spec(m) is None]
    if missing:
        raise ConfigError(
            f"algo={name} needs {', '.join(missing)}, which {'is' if len(missing) == 1 else 'are'} not installed: "
            f"pip install 'pyflyt-toolkit[{algorithm.extra}]' (or choose another algo, e.g. algo=sac)"
        )


def resolve(table: Mapping[str, str], name: str, what: str) -> Any:
    """Import the object registered under ``name`` in ``table`` (a :class:`ConfigError` if unknown)."""
    if name not in table:
        raise ConfigError(unknown(what, name, table))
    if table is ALGOS:
        check_installed(name)
    module, _, attr = table[name].partition(":")
    return getattr(importlib.import_module(module), attr)


def unknown(what: str, name: object, choices: Any) -> str:
    """``unknown <what> '<name>'. Did you mean '...'? Available: ...``."""
    from pyflyt_engine.suggest import did_you_mean

    options = sorted(choices)
    hint = did_you_mean(str(name), options)
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
