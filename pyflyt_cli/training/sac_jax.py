"""Soft Actor-Critic on JAX: SBX's ``SAC`` in the toolkit's runs (``algo=sac_jax``).

SBX (``sbx-rl``, the JAX Stable Baselines) keeps SB3's algorithm classes, replay buffers,
vector envs and callbacks and replaces the networks and their updates with Flax modules and
Optax optimisers compiled by XLA: a call of ``train(gradient_steps=k)`` is one compiled loop
over the ``k`` gradient steps, without Python between them.  On SAC's small networks that is
what an update's time is (``experiments/sac_update_cost.py``): one gradient step of batch 256
on [128, 128] networks cost 3-6 ms of CPU time here against SB3's 17-20 ms, on a 2-core
machine under heavy load (``experiments/results/sac_update_cost.md``).  Install it with ``pip install
'pyflyt-toolkit[jax]'``.

**The same algorithm, not the same numbers as** ``algo=sac``.  SAC (Haarnoja et al. 2018,
arXiv:1801.01290) with automatic entropy tuning (arXiv:1812.05905), clipped double Q, the
tanh-squashed Gaussian actor, Polyak-averaged target critics, SB3's replay buffers (and so
SB3's n-step returns: ``algo.n_steps`` > 1 fills an ``NStepReplayBuffer`` whose per-sample
discounts, ``gamma ** steps taken``, SBX's critic target uses).  What SBX does in another way:

* within a gradient step the critic learns first, then the actor and the temperature, the
  temperature from the entropy of the actor's freshly sampled actions (SB3: temperature,
  critic, actor, all from one sample); the targets move at every step (no
  ``target_update_interval``), and ``algo.policy_delay`` spaces the actor's updates;
* the networks are initialised by Flax (LeCun normal weights, zero biases; SB3: torch's
  uniform), the actor clips its mean's pre-activation (SBX ``clip_mean`` 2) and its log
  standard deviation to [-20, 2]; random numbers come from JAX's counter-based generator;
* the replay samples of a ``train()`` call are drawn in one batch (``batch_size x
  gradient_steps`` at once, from NumPy's stream as SB3 does), then split.

**Determinism.**  The same seed and configuration give the same weights in every process
and rerun on the same machine with the same number of CPUs available to the process: a
process allowed one CPU instead of two trained other weights
(``experiments/results/sac_update_cost.md``), so ``algo=sac``'s cross-CPU promise does not
extend to this class.  XLA's Eigen kernels run single-threaded, and in the pinned mode its
code is compiled for AVX2 (``--xla_cpu_max_isa=AVX2``; on this AVX-512 CPU the same weights
as XLA's own choice), both set when ``pyflyt_engine`` is imported, before JAX
(``pyflyt_engine.numerics``).  A resume is exact: a checkpoint holds the parameters, the
target critics, the Adam states and step counts, the temperature's state and the JAX keys
(:meth:`SACJax.random_streams`), besides what every run's checkpoint holds
(``docs/reproducibility.md``).

**What it does not do.**  gSDE (SBX's SAC has none), ``train.imitation`` (its policy is not
a torch module), ``policy_kwargs.activation_fn`` / ``log_std_init`` (SBX's networks: ReLU),
``pyflyt export`` (the exporters read torch actors).  Policy files and checkpoints are the
toolkit's ``.pt`` archives of tensors, as for every algorithm (the Flax parameter trees
flattened by name, e.g. ``actor.params.Dense_0.kernel``).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, ClassVar

import jax
import jax.numpy as jnp
import numpy as np
import torch
from sbx import SAC as _SBXSAC
from sbx.sac.policies import SACPolicy


def _path_name(path: tuple[Any, ...]) -> str:
    """``actor.params.Dense_0.kernel``: a pytree path by its keys, field names and indices."""
    parts = []
    for key in path:
        for attr in ("key", "name", "idx"):
            if hasattr(key, attr):
                parts.append(str(getattr(key, attr)))
                break
        else:
            parts.append(str(key))
    return ".".join(parts)


def to_tensors(prefix: str, tree: Any) -> dict[str, torch.Tensor]:
    """The leaves of pytree ``tree`` as CPU tensors named ``<prefix>.<path>`` (copies).

    JAX keys (uint32) are stored as int64, which every torch operation takes; :func:`from_tensors`
    casts back to each leaf's own dtype, so the values round-trip exactly."""
    out: dict[str, torch.Tensor] = {}
    for path, leaf in jax.tree_util.tree_flatten_with_path(tree)[0]:
        array = np.array(leaf)  # a copy, off the device
        if array.dtype == np.uint32:
            array = array.astype(np.int64)
        out[f"{prefix}.{_path_name(path)}"] = torch.from_numpy(array)
    return out


def from_tensors(prefix: str, tree: Any, tensors: Mapping[str, Any], used: set[str]) -> Any:
    """``tree`` with every leaf replaced by the tensor of its name (:func:`to_tensors`), of the same
    shape and cast to the leaf's dtype; the names read are added to ``used``.  ``KeyError`` for a
    missing name, ``RuntimeError`` for a shape that does not fit (as torch's ``load_state_dict``)."""
    leaves, treedef = jax.tree_util.tree_flatten_with_path(tree)
    new = []
    for path, leaf in leaves:
        name = f"{prefix}.{_path_name(path)}"
        if name not in tensors:
            raise KeyError(f"missing {name}")
        value = tensors[name]
        array = value.detach().cpu().numpy() if isinstance(value, torch.Tensor) else np.asarray(value)
        old = np.asarray(leaf)
        if array.shape != old.shape:
            raise RuntimeError(f"size mismatch for {name}: the file has {tuple(array.shape)}, the model {old.shape}")
        new.append(jnp.asarray(array.astype(old.dtype)))
        used.add(name)
    return jax.tree_util.tree_unflatten(treedef, new)


def _unexpected(tensors: Mapping[str, Any], prefixes: tuple[str, ...], used: set[str]) -> list[str]:
    return sorted(k for k in tensors if k.startswith(prefixes) and k not in used) + sorted(
        k for k in tensors if not k.startswith(prefixes)
    )


class SACJaxPolicy(SACPolicy):
    """SBX's SAC policy whose ``state_dict`` / ``load_state_dict`` speak tensors, as SB3's policies do:
    the actor's and the critics' parameters and the target critics', flattened by name."""

    PARTS: ClassVar[tuple[str, ...]] = ("actor.", "qf.", "qf_target.")

    def state_dict(self, *args: Any, **kwargs: Any) -> dict[str, Any]:  # type: ignore[override]
        return {
            **to_tensors("actor", self.actor_state.params),
            **to_tensors("qf", self.qf_state.params),
            **to_tensors("qf_target", self.qf_state.target_params),
        }

    def load_state_dict(self, state_dict: Mapping[str, Any], strict: bool = True, assign: bool = False) -> Any:
        used: set[str] = set()
        actor = from_tensors("actor", self.actor_state.params, state_dict, used)
        qf = from_tensors("qf", self.qf_state.params, state_dict, used)
        target = from_tensors("qf_target", self.qf_state.target_params, state_dict, used)
        extra = _unexpected(state_dict, self.PARTS, used)
        if strict and extra:
            raise RuntimeError(f"unexpected key {extra[0]} in the policy's tensors")
        self.actor_state = self.actor_state.replace(params=actor)
        self.qf_state = self.qf_state.replace(params=qf, target_params=target)
        return None


class SACJax(_SBXSAC):
    """SBX's SAC with the toolkit's files: tensors for the policy, the optimisers and the JAX keys
    (see the module docstring)."""

    policy_aliases: ClassVar[dict[str, type[SACPolicy]]] = {
        "MlpPolicy": SACJaxPolicy,
        "MultiInputPolicy": SACJaxPolicy,  # SBX flattens a Dict observation
    }

    def __init__(self, policy: Any, env: Any, *, optimize_memory_usage: bool = False, **kwargs: Any) -> None:
        if optimize_memory_usage:
            raise ValueError("algo=sac_jax has no memory-optimised replay buffer")
        ent_coef = kwargs.get("ent_coef", "auto")
        if isinstance(ent_coef, (int, float)) and not isinstance(ent_coef, bool):
            kwargs["ent_coef"] = float(ent_coef)  # SBX checks for a float
        super().__init__(policy, env, **kwargs)

    # --------------------------------------------------- optimisers (checkpoints)

    def _trainer_states(self) -> dict[str, Any]:
        """What learns besides the policy's parameters: the Adam states and step counts, the temperature."""
        actor, qf = self.policy.actor_state, self.policy.qf_state
        return {
            "actor": {"step": actor.step, "opt_state": actor.opt_state},
            "qf": {"step": qf.step, "opt_state": qf.opt_state},
            "ent_coef": {"step": self.ent_coef_state.step, "params": self.ent_coef_state.params,
                         "opt_state": self.ent_coef_state.opt_state},
        }  # fmt: skip

    def get_parameters(self) -> dict[str, dict[str, Any]]:
        return {"policy": self.policy.state_dict(), "jax_trainer": to_tensors("trainer", self._trainer_states())}

    def set_parameters(self, load_path_or_dict: Any, exact_match: bool = True, device: Any = "auto") -> None:
        if not isinstance(load_path_or_dict, Mapping):
            raise ValueError("algo=sac_jax loads its parameters from the toolkit's checkpoint files only")
        params = dict(load_path_or_dict)
        if "policy" in params:
            self.policy.load_state_dict(params.pop("policy"))
        trainer = params.pop("jax_trainer")
        if exact_match and params:
            raise ValueError(f"unexpected parameters {sorted(params)} for algo=sac_jax")
        used: set[str] = set()
        states = from_tensors("trainer", self._trainer_states(), trainer, used)
        extra = _unexpected(trainer, ("trainer.",), used)
        if exact_match and extra:
            raise ValueError(f"unexpected trainer state {extra[0]}")
        policy = self.policy
        policy.actor_state = policy.actor_state.replace(**states["actor"])
        policy.qf_state = policy.qf_state.replace(**states["qf"])
        self.ent_coef_state = self.ent_coef_state.replace(**states["ent_coef"])

    # ------------------------------------------------ random streams (continuity)

    def random_streams(self) -> dict[str, torch.Tensor]:
        """JAX's keys: the updates' (``key``), the policy's and its exploration noise's."""
        keys = {"key": self.key, "policy_key": self.policy.key, "noise_key": self.policy.noise_key}
        return to_tensors("jax", keys)

    def set_random_streams(self, tensors: Mapping[str, Any]) -> None:
        keys = {"key": self.key, "policy_key": self.policy.key, "noise_key": self.policy.noise_key}
        restored = from_tensors("jax", keys, tensors, set())
        self.key = restored["key"]
        self.policy.key, self.policy.noise_key = restored["policy_key"], restored["noise_key"]
