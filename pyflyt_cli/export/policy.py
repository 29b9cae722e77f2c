"""A trained run's deterministic policy as one chain of plain layers, from raw observation to env action.

:func:`deployed_policy` reads a run (or a shipped agent), rebuilds its SB3 model and
lays out, as a ``torch.nn.Sequential`` of float32 layers, everything that happens between
the observation the env returns and the action the env receives:

1. the observation normaliser (``VecNormalize``), if the run trained with one:
   ``clip((obs - mean) / sqrt(var + eps), -clip_obs, clip_obs)`` (:class:`Standardize`);
2. the actor's layers as SB3 builds them (``Linear`` and activations), taken from the
   model itself;
3. the deterministic action: the Gaussian's mean clipped to the agent's action space
   (PPO, A2C, TRPO: what SB3's ``predict`` does), or squashed by ``tanh`` (SAC, TQC, AWAC,
   CCGE; TD3 and DDPG end their actor with it);
4. the agent's [-1, 1] rescaled to the env's action bounds (the ``RescaleAction`` the
   agent wrapper adds, taken from the wrapper itself; :class:`Affine`);
5. the env's own clip to its bounds (:class:`Clamp`).

The exporters (:mod:`.onnx_model`, :mod:`.c_source`) write this chain and nothing else; the
same :class:`DeployedPolicy` carries the reference (the SB3 path) that tests and the
export's own check compare it with.  Recurrent (LSTM) policies, image (CNN / Dict)
observations and layers other than those of :data:`ACTIVATIONS` are refused by name.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch

from pyflyt_cli.errors import UsageError


class ExportError(UsageError):
    """A policy that cannot be exported, or an export request that cannot be carried out as given."""


#: activation modules the exporters write (by class name; :mod:`.c_source` writes each in C)
ACTIVATIONS = ("ReLU", "Tanh", "ELU", "LeakyReLU", "GELU", "SiLU", "Sigmoid", "Hardtanh")


class Standardize(torch.nn.Module):
    """``clip((x - mean) / std, -clip, clip)``: SB3's ``VecNormalize.normalize_obs`` with
    ``std = sqrt(var + epsilon)`` (computed in float64, stored in float32)."""

    # buffers (register_buffer), declared for the type checker: nn.Module's __getattr__ types them loosely
    mean: torch.Tensor
    std: torch.Tensor

    def __init__(self, mean: np.ndarray, std: np.ndarray, clip: float) -> None:
        super().__init__()
        self.register_buffer("mean", torch.as_tensor(np.asarray(mean, dtype=np.float32)))
        self.register_buffer("std", torch.as_tensor(np.asarray(std, dtype=np.float32)))
        self.clip = float(clip)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return torch.clamp((x - self.mean) / self.std, -self.clip, self.clip)


class Affine(torch.nn.Module):
    """``x * scale + offset``, element by element."""

    scale: torch.Tensor
    offset: torch.Tensor

    def __init__(self, scale: np.ndarray, offset: np.ndarray) -> None:
        super().__init__()
        self.register_buffer("scale", torch.as_tensor(np.asarray(scale, dtype=np.float32)))
        self.register_buffer("offset", torch.as_tensor(np.asarray(offset, dtype=np.float32)))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return x * self.scale + self.offset


class Clamp(torch.nn.Module):
    """``min(max(x, low), high)``, element by element."""

    low: torch.Tensor
    high: torch.Tensor

    def __init__(self, low: np.ndarray, high: np.ndarray) -> None:
        super().__init__()
        self.register_buffer("low", torch.as_tensor(np.asarray(low, dtype=np.float32)))
        self.register_buffer("high", torch.as_tensor(np.asarray(high, dtype=np.float32)))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return torch.minimum(torch.maximum(x, self.low), self.high)


@dataclass(frozen=True)
class DeployedPolicy:
    """A run's deterministic policy from the raw observation to the action the env receives."""

    #: ``(batch, obs_dim)`` float32 -> ``(batch, act_dim)`` float32, every step a layer the exporters write
    network: Any
    #: the same through SB3 (normaliser, ``model.predict(deterministic=True)``, the action wrapper, the
    #: env's clip), in float64 as the env receives it: ``(batch, obs_dim)`` -> ``(batch, act_dim)``
    reference: Callable[[np.ndarray], np.ndarray] = field(repr=False)
    #: what was exported, for the files' headers and the command's summary (plain data)
    about: dict[str, Any] = field(default_factory=dict)

    @property
    def obs_dim(self) -> int:
        return int(self.about["observation"]["size"])

    @property
    def act_dim(self) -> int:
        return int(self.about["action"]["size"])

    def forward(self, obs: np.ndarray) -> np.ndarray:
        """The exported chain run by PyTorch on a ``(batch, obs_dim)`` array (float32 out)."""
        with torch.no_grad():
            return self.network(torch.as_tensor(np.asarray(obs, dtype=np.float32))).numpy()


def resolve_source(source: str | Path) -> Path:
    """A run directory, or ``zoo:<name>``: the shipped agent's folder (read in place, never written)."""
    text = str(source)
    if text.startswith("zoo:"):
        from pyflyt_cli.zoo import agent

        return agent(text[len("zoo:") :]).path
    return Path(text).expanduser()


def deployed_policy(source: str | Path, model: str = "auto") -> DeployedPolicy:
    """The deterministic policy of a run directory or ``zoo:<name>`` as a :class:`DeployedPolicy`.

    ``model``: ``auto`` (best, else final, else latest), ``best``, ``final`` or ``latest``
    (as ``pyflyt eval model=``).

    Raises:
        ExportError: a policy the exporters cannot write (recurrent, image observations, a
            discrete or unbounded action, a layer they do not know), with the reason.
        RunDirError, ArtifactError: a missing run, config or policy file.
    """
    from pyflyt_cli.training import rundir

    path = rundir.check_run_dir(resolve_source(source))
    cfg = rundir.load_run_config(path)
    model_path, which = rundir.find_model(path, model)
    from pyflyt_cli.training.envs import EnvFactory
    from pyflyt_cli.training.models import load_policy, read_policy

    env = EnvFactory(cfg.env, monitor=False)()
    try:
        sb3, normalize = load_policy(model_path, cfg, env)
        normalizer = read_policy(model_path).normalizer
        return _assemble(path, str(source), cfg, sb3, normalize, normalizer, env, model_path, which)
    finally:
        env.close()


def _assemble(
    run: Path, source: str, cfg: Any, sb3: Any, normalize: Any, normalizer: Any, env: Any, model_path: Path, which: str
) -> DeployedPolicy:
    from gymnasium import spaces

    algo = cfg.algo.name
    obs_space = env.observation_space
    if not (isinstance(obs_space, spaces.Box) and len(obs_space.shape) == 1):
        from pyflyt_cli.training.envs import is_image

        entries = obs_space.spaces.values() if isinstance(obs_space, spaces.Dict) else [obs_space]
        seen = (
            "camera images (a CNN over env.camera_observation)" if any(is_image(s) for s in entries) else str(obs_space)
        )
        raise ExportError(
            f"{run}: its policy sees {seen}; the exporters write policies of one flat observation vector "
            "only (no images, no Dict observations)"
        )
    act_space = env.action_space
    if not (isinstance(act_space, spaces.Box) and len(act_space.shape) == 1):
        raise ExportError(
            f"{run}: the policy's action is {act_space}; the exporters write continuous (Box) actions only"
        )
    policy = sb3.policy
    if hasattr(policy, "lstm_actor"):
        raise ExportError(
            f"{run}: a {algo} policy carries an LSTM state from step to step; the exporters write feed-forward "
            "policies only (one observation in, one action out): train with algo=ppo to deploy"
        )

    layers: list[Any] = []
    steps: list[str] = []
    if normalizer is not None and normalizer.get("norm_obs"):
        rms = normalizer["obs_rms"]
        if "mean" not in rms:
            raise ExportError(f"{run}: its normaliser holds statistics per Dict entry; only a flat observation exports")
        mean, var, epsilon, clip = _normaliser(run, model_path, rms, normalizer, int(obs_space.shape[0]))
        std = np.sqrt(var + epsilon)
        layers.append(Standardize(mean, std, clip))
        steps.append(
            f"observation normaliser (VecNormalize): clip((obs - mean) / sqrt(var + {epsilon:g}), -{clip:g}, {clip:g})"
        )
    else:
        steps.append("no observation normaliser (the run trained on raw observations)")

    low = np.asarray(sb3.action_space.low, dtype=np.float64)
    high = np.asarray(sb3.action_space.high, dtype=np.float64)
    if not (np.all(np.isfinite(low)) and np.all(np.isfinite(high))):
        raise ExportError(
            f"{run}: the policy's action space {sb3.action_space} is unbounded: nothing to clip or rescale to"
        )

    # the actor's layout, read from the policy itself: PPO, A2C, TRPO (a Gaussian over an action head);
    # SAC, TQC, AWAC, CCGE (a squashed Gaussian); TD3, DDPG (a deterministic actor ending in tanh)
    if hasattr(policy, "action_net") and hasattr(policy, "mlp_extractor"):
        _flat_features(
            run, policy.pi_features_extractor if hasattr(policy, "pi_features_extractor") else policy.features_extractor
        )
        layers += _actor_layers(run, algo, [policy.mlp_extractor.policy_net, policy.action_net])
        steps.append(f"{algo} actor: the Gaussian's mean (deterministic action)")
        if policy.squash_output:
            layers.append(torch.nn.Tanh())
            steps.append("tanh squashing (gSDE with squash_output)")
            layers.append(_unscale(low, high))
        else:
            layers.append(Clamp(low, high))
            steps.append(
                f"clip to the agent's action space, low {_bounds(low)}, high {_bounds(high)} (as SB3's predict)"
            )
    elif hasattr(policy, "actor") and hasattr(policy.actor, "latent_pi"):
        actor = policy.actor
        _flat_features(run, actor.features_extractor)
        layers += _actor_layers(run, algo, [actor.latent_pi, actor.mu])
        layers.append(torch.nn.Tanh())
        layers.append(_unscale(low, high))
        steps.append(f"{algo} actor: tanh of the Gaussian's mean (deterministic action)")
    elif hasattr(policy, "actor") and hasattr(policy.actor, "mu"):
        actor = policy.actor
        _flat_features(run, actor.features_extractor)
        layers += _actor_layers(run, algo, [actor.mu])
        layers.append(_unscale(low, high))
        steps.append(f"{algo} actor (deterministic, ends in tanh)")
    else:
        raise ExportError(f"{run}: a {algo} policy ({type(policy).__name__}) has no actor layout the exporters know")
    layers = [layer for layer in layers if layer is not None]

    rescale = _rescaler(env)
    env_space = rescale.env.action_space if rescale is not None else act_space
    env_low = np.asarray(env_space.low, dtype=np.float64)
    env_high = np.asarray(env_space.high, dtype=np.float64)
    if rescale is not None:
        offset = np.asarray(rescale.action(np.zeros(act_space.shape)), dtype=np.float64)
        scale = np.asarray(rescale.action(np.ones(act_space.shape)), dtype=np.float64) - offset
        layers.append(Affine(scale, offset))
        steps.append(
            f"rescale from the agent's [-1, 1] to the env's action bounds (RescaleAction): a * {_bounds(scale)} + {_bounds(offset)}"
        )
    layers.append(Clamp(env_low, env_high))
    steps.append(f"clip to the env's action bounds, low {_bounds(env_low)}, high {_bounds(env_high)} (as the env does)")

    network = torch.nn.Sequential(*layers).to(torch.float32).eval()
    check_chain(run, network, int(obs_space.shape[0]), int(act_space.shape[0]))
    for p in network.parameters():
        p.requires_grad_(False)

    def reference(obs: np.ndarray) -> np.ndarray:
        x = np.asarray(obs, dtype=np.float32).reshape(-1, obs_space.shape[0])
        if normalize is not None:
            x = normalize(x)
        action, _ = sb3.predict(x, deterministic=True)
        action = np.asarray(action, dtype=np.float64)
        if rescale is not None:
            action = np.stack([np.asarray(rescale.action(a), dtype=np.float64) for a in action])
        return np.minimum(np.maximum(action, env_low), env_high)

    about = _about(source, cfg, env, rescale, env_low, env_high, model_path, which, normalizer, steps)
    about["observation"]["size"] = int(obs_space.shape[0])
    about["action"]["size"] = int(act_space.shape[0])
    return DeployedPolicy(network, reference, about)


def _numbers(run: Path, model_path: Path, what: str, value: Any) -> np.ndarray:
    """``value`` (a tensor or number from a policy file) as float64, or an :class:`ExportError` naming it."""
    try:
        array = np.asarray(value.numpy() if isinstance(value, torch.Tensor) else value, dtype=np.float64)
    except (TypeError, ValueError, RuntimeError):
        raise ExportError(
            f"{model_path}: the normaliser's {what} is not numbers ({type(value).__name__}); the file is damaged"
        ) from None
    if not np.all(np.isfinite(array)):
        raise ExportError(
            f"{model_path}: the normaliser's {what} holds non-finite values (NaN or inf): nothing to export"
        )
    return array


def _normaliser(
    run: Path, model_path: Path, rms: Any, normalizer: Any, obs_dim: int
) -> tuple[np.ndarray, np.ndarray, float, float]:
    """(mean, var, epsilon, clip) of a policy file's observation normaliser, checked against the observation:
    ``obs_dim`` finite values each, var >= 0, epsilon >= 0, clip > 0; else an :class:`ExportError` naming it."""
    mean = _numbers(run, model_path, "mean", rms.get("mean"))
    var = _numbers(run, model_path, "variance", rms.get("var"))
    for name, array in (("mean", mean), ("variance", var)):
        if array.shape != (obs_dim,):
            raise ExportError(
                f"{model_path}: the normaliser's {name} has shape {list(array.shape)}, the observation has {obs_dim} "
                "entries: the file is not this run's policy"
            )
    epsilon = _numbers(run, model_path, "epsilon", normalizer.get("epsilon"))
    clip = _numbers(run, model_path, "clip_obs", normalizer.get("clip_obs"))
    if epsilon.shape != () or clip.shape != ():
        raise ExportError(
            f"{model_path}: the normaliser's epsilon and clip_obs are single numbers; the file is damaged"
        )
    if np.any(var < 0) or epsilon < 0 or not clip > 0 or not np.all(var + epsilon > 0):
        raise ExportError(
            f"{model_path}: the normaliser's variance and epsilon must be >= 0 (their sum > 0) and clip_obs > 0: the file is damaged"
        )
    return mean, var, float(epsilon), float(clip)


#: per-element tensors of each layer kind, checked against the width the layer sees
_ELEMENTWISE = {"Standardize": ("mean", "std"), "Affine": ("scale", "offset"), "Clamp": ("low", "high")}


def check_chain(run: Path, network: Any, obs_dim: int, act_dim: int) -> None:
    """Refuse a chain the exporters would write wrongly: a tensor whose shape does not fit the width
    the layer sees (from ``obs_dim`` in, ``act_dim`` out), a non-finite weight, bias, statistic or
    bound, a zero or negative std, low above high.  Called before anything is written, for every format."""
    width = obs_dim
    for index, layer in enumerate(network):
        kind = type(layer).__name__
        tensors: dict[str, Any] = {}
        if isinstance(layer, torch.nn.Linear):
            weight = layer.weight.detach()
            if weight.dim() != 2 or weight.shape[1] != width:
                raise ExportError(
                    f"{run}: layer {index} (Linear) has weights of shape {list(weight.shape)}, it is fed {width} values"
                )
            bias = layer.bias
            if bias is not None and tuple(bias.shape) != (weight.shape[0],):
                raise ExportError(
                    f"{run}: layer {index} (Linear) has a bias of shape {list(bias.shape)} for {weight.shape[0]} outputs"
                )
            tensors = {"weight": weight, **({"bias": bias.detach()} if bias is not None else {})}
            width = int(weight.shape[0])
        elif kind in _ELEMENTWISE:
            for name in _ELEMENTWISE[kind]:
                value = getattr(layer, name)
                if tuple(value.shape) != (width,):
                    raise ExportError(
                        f"{run}: layer {index} ({kind}) has {name} of shape {list(value.shape)}, it is fed {width} values"
                    )
                tensors[name] = value
        else:
            tensors = {
                k: torch.as_tensor(float(getattr(layer, k)))
                for k in ("alpha", "negative_slope", "min_val", "max_val")
                if hasattr(layer, k)
            }
        if isinstance(layer, Standardize):
            tensors["clip"] = torch.as_tensor(layer.clip)
        for name, value in tensors.items():
            if not bool(torch.all(torch.isfinite(value))):
                raise ExportError(
                    f"{run}: layer {index} ({kind}) has non-finite {name} (NaN or inf): nothing to export"
                )
        if isinstance(layer, Standardize) and not bool(torch.all(layer.std > 0)):
            raise ExportError(f"{run}: layer {index} (observation normaliser) has a std of 0 or below")
        if isinstance(layer, Clamp) and not bool(torch.all(layer.low <= layer.high)):
            raise ExportError(f"{run}: layer {index} (clip) has a low bound above its high bound")
    if width != act_dim:
        raise ExportError(f"{run}: the chain ends with {width} values, the action has {act_dim}")


def _flat_features(run: Path, extractor: Any) -> None:
    if type(extractor).__name__ != "FlattenExtractor":
        raise ExportError(
            f"{run}: the policy's features extractor is {type(extractor).__name__} (a CNN or a Dict of inputs); "
            "the exporters write policies of one flat observation vector only"
        )


def _actor_layers(run: Path, algo: str, modules: list[Any]) -> list[Any]:
    """The leaf modules of ``modules`` in order, each a Linear or a known activation."""
    out: list[Any] = []

    def walk(module: Any) -> None:
        if isinstance(module, torch.nn.Sequential):
            for child in module:
                walk(child)
            return
        kind = type(module).__name__
        if isinstance(module, (torch.nn.Identity, torch.nn.Flatten)):
            return
        if isinstance(module, torch.nn.Linear) or kind in ACTIVATIONS:
            if kind == "GELU" and getattr(module, "approximate", "none") not in ("none", "tanh"):
                raise ExportError(f"{run}: GELU(approximate={module.approximate!r}) is not written by the exporters")
            import copy

            out.append(copy.deepcopy(module))
            return
        raise ExportError(
            f"{run}: the {algo} actor holds a {kind} layer; the exporters write Linear layers and the "
            f"activations {', '.join(ACTIVATIONS)} only"
        )

    for module in modules:
        walk(module)
    return out


def _unscale(low: np.ndarray, high: np.ndarray) -> Any:
    """SB3's ``unscale_action`` from [-1, 1] to ``[low, high]``; None when that is [-1, 1] itself."""
    if np.all(low == -1.0) and np.all(high == 1.0):
        return None
    return Affine(0.5 * (high - low), low + 0.5 * (high - low))


def _rescaler(env: Any) -> Any:
    """The ``RescaleAction`` wrapper in ``env``'s chain, or None."""
    import gymnasium

    e = env
    while e is not None:
        if isinstance(e, gymnasium.wrappers.RescaleAction):
            return e
        e = getattr(e, "env", None)
    return None


def _bounds(values: np.ndarray) -> str:
    return "[" + ", ".join(f"{v:.6g}" for v in np.asarray(values).reshape(-1)) + "]"


def _about(
    source: str,
    cfg: Any,
    env: Any,
    rescale: Any,
    low: np.ndarray,
    high: np.ndarray,
    model_path: Path,
    which: str,
    normalizer: Any,
    steps: list[str],
) -> dict[str, Any]:
    """Plain data describing the exported policy: where it came from, its interface, its steps."""
    from pyflyt_cli.training.models import read_policy

    env_cfg = cfg.env
    action = getattr(env_cfg, "action", None)
    names = list(getattr(action, "names", None) or [f"a{i}" for i in range(low.size)])
    units = list(getattr(action, "units", None) or ["" for _ in range(low.size)])
    return {
        "run": source,
        "model": model_path.name,
        "which": which,
        "algo": cfg.algo.name,
        "step": read_policy(model_path).step,
        "env_id": str(env_cfg.id),
        "env_name": cfg.env_name,
        "agent_hz": float(env_cfg.agent_hz),
        "observation": {
            "angle_representation": getattr(env_cfg, "angle_representation", None),
            "normalised_inside": bool(normalizer is not None and normalizer.get("norm_obs")),
        },
        "action": {
            "mode": getattr(action, "mode", None),
            "names": names,
            "units": units,
            "low": [float(v) for v in low],
            "high": [float(v) for v in high],
        },
        "steps": steps,
    }


def flown_observations(source: str | Path, policy: DeployedPolicy, steps: int = 1000, seed: int = 0) -> np.ndarray:
    """``(steps, obs_dim)`` float32 observations met by flying ``policy``'s reference actions in the
    run's env (episode ``i`` from ``reset(seed=seed + i)``): realistic inputs to check an exported
    file against (:func:`DeployedPolicy.reference`)."""
    from pyflyt_cli.training import rundir
    from pyflyt_cli.training.envs import EnvFactory

    cfg = rundir.load_run_config(resolve_source(source))
    env = EnvFactory(cfg.env, monitor=False)()
    rescale = _rescaler(env)
    below = rescale.env if rescale is not None else env  # takes the action in the env's units
    seen: list[np.ndarray] = []
    episode = 0
    try:
        obs, _ = below.reset(seed=seed)
        while len(seen) < steps:
            seen.append(np.asarray(obs, dtype=np.float32))
            obs, _, terminated, truncated, _ = below.step(policy.reference(obs)[0])
            if terminated or truncated:
                episode += 1
                obs, _ = below.reset(seed=seed + episode)
    finally:
        env.close()
    return np.stack(seen)
