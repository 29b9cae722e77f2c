"""Typed schema of a training run (``conf/train.yaml`` after composition) and of ``pyflyt eval``.

:func:`parse_train_config` validates a plain mapping — what
:func:`pyflyt_cli.training.compose_config` composed, or a run's ``config.yaml`` — into a
frozen :class:`TrainConfig`.  Unknown keys, missing keys, wrong types and out-of-range
values fail here, before any environment or network is built, with one line per problem
naming the key.  ``_target_`` keys are checked against the registries first
(:func:`pyflyt_cli.training.registry.check_targets`).

**Defaults are not written here.**  Every default value lives in ``conf/`` (``train.yaml``,
``eval.yaml``, ``algo/<name>.yaml``); this schema states types, ranges and meanings only,
so the CLI and Python cannot disagree.  A field is either required (the YAML gives its
value) or optional, where ``None`` means "not set": the library's own behaviour (e.g.
``policy_kwargs.net_arch: null`` is SB3's default network).  Every field is documented
where it is declared; ``pyflyt train --help`` and ``docs/cli.md`` show the same.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Annotated, Any, ClassVar, Literal, Union

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    SerializeAsAny,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_validator,
)

from pyflyt_cli.training import registry
from pyflyt_engine import limits
from pyflyt_engine.envs.config import EnvConfig, parse_env_config
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.loading import describe_error, problem_list, problems


class _Strict(BaseModel):
    # no NaN or infinity anywhere: algo.learning_rate=inf trained NaN weights and ended in torch's traceback
    model_config = ConfigDict(extra="forbid", frozen=True, validate_default=True, allow_inf_nan=False)


# ---------------------------------------------------------------------- algorithm


class PolicyConfig(_Strict):
    """``algo.policy_kwargs``: the network (passed to the SB3 policy)."""

    net_arch: list[int] | dict[Literal["pi", "vf", "qf"], list[int]] | None = Field(
        None, description="hidden layer sizes, shared list or per head {pi: [...], vf|qf: [...]}; null: SB3's default"
    )
    activation_fn: Literal["tanh", "relu", "elu", "leaky_relu", "gelu", "silu"] | None = Field(
        None, description="hidden activation by name; null: SB3's default (tanh for PPO/A2C, relu otherwise)"
    )
    # e^10 is 22 026 times the [-1, 1] action range: any larger std is noise only (1e308 was a NaN traceback)
    log_std_init: float | None = Field(
        None, ge=-20, le=10, description="initial log standard deviation of the Gaussian policy, -20 to 10"
    )
    ortho_init: bool | None = Field(None, description="orthogonal initialisation (PPO/A2C)")
    n_critics: int | None = Field(None, ge=1, description="number of Q networks (SAC/TD3/DDPG/TQC/CrossQ)")
    n_quantiles: int | None = Field(None, ge=1, description="quantiles per critic (TQC)")
    lstm_hidden_size: int | None = Field(None, ge=1, description="hidden units per LSTM layer (recurrent_ppo)")
    n_lstm_layers: int | None = Field(None, ge=1, description="LSTM layers (recurrent_ppo)")
    shared_lstm: bool | None = Field(None, description="one LSTM for actor and critic (recurrent_ppo)")
    enable_critic_lstm: bool | None = Field(
        None,
        description="a separate LSTM for the critic (recurrent_ppo; false with shared_lstm: a feed-forward critic)",
    )
    batch_norm_momentum: float | None = Field(
        None, gt=0, le=1, description="momentum of the batch renormalisation layers (CrossQ)"
    )

    @field_validator("net_arch")
    @classmethod
    def _net_size(cls, value: list[int] | dict[str, list[int]] | None) -> Any:
        # a layer of 1e8 units ended in torch's allocation traceback (docs/reproducibility.md, "Bounded numbers")
        heads = value.items() if isinstance(value, dict) else [("", value or [])]
        for head, widths in heads:
            where = f"net_arch{'.' + head if head else ''}"
            limits.check("net.depth", len(widths), name=f"{where} (its length)")
            for width in widths:
                if width < 1:
                    raise ValueError(
                        f"{where} holds a layer of {width} units: give positive layer sizes, e.g. [128, 128]"
                    )
                limits.check("net.width", width, name=f"a {where} layer of")
            weights = sum(a * b for a, b in zip(widths, widths[1:]))
            limits.check("net.parameters", weights, name=f"{where} ({' x '.join(map(str, widths))})")
        return value

    @field_validator("lstm_hidden_size", "n_lstm_layers", "n_critics", "n_quantiles")
    @classmethod
    def _sizes(cls, value: int | None, info: ValidationInfo) -> int | None:
        assert info.field_name is not None  # a field validator's
        key = {
            "lstm_hidden_size": "net.width",
            "n_lstm_layers": "net.depth",
            "n_critics": "net.critics",
            "n_quantiles": "net.quantiles",
        }[info.field_name]
        return value if value is None else limits.check(key, value, name=f"policy_kwargs.{info.field_name}")

    @field_validator("activation_fn", mode="before")
    @classmethod
    def _by_target(cls, value: Any) -> Any:
        # {_target_: torch.nn.ReLU} arrives here as {name: relu} (registry.check_targets)
        if isinstance(value, Mapping) and set(value) == {"name"}:
            return value["name"]
        return value

    def kwargs(self) -> dict[str, Any]:
        """Keyword arguments for SB3's ``policy_kwargs`` (unset entries left out)."""
        out: dict[str, Any] = {}
        for key, value in self.model_dump(exclude_none=True).items():
            out[key] = registry.resolve(registry.ACTIVATIONS, value, "activation") if key == "activation_fn" else value
        return out


class NormalizeConfig(_Strict):
    """``algo.normalize``: running mean/std normalisation (SB3 ``VecNormalize``), saved with every model."""

    observation: bool = Field(description="normalise observations by their running mean and std")
    reward: bool = Field(description="scale rewards by the running std of the discounted return")
    clip_obs: float = Field(gt=0, description="clip normalised observations to [-clip_obs, clip_obs]")

    @property
    def enabled(self) -> bool:
        return self.observation or self.reward


class ActionNoiseConfig(_Strict):
    """``algo.action_noise``: exploration noise added to deterministic off-policy actions (TD3/DDPG)."""

    type: Literal["normal", "ornstein_uhlenbeck"] = Field(description="noise process")
    sigma: float = Field(gt=0, description="standard deviation, in the [-1, 1] rescaled action units")


class _AlgoBase(_Strict):
    policy: str = Field(description="SB3 policy name (observations are flattened to one Box)")
    learning_rate: float = Field(gt=0, description="optimiser step size")
    lr_schedule: Literal["constant", "linear"] = Field(
        description="'linear': decay learning_rate to 0 over train.total_timesteps (zoo's lin_<lr>)"
    )
    gamma: float = Field(gt=0, le=1, description="discount factor")
    normalize: NormalizeConfig = Field(description="running observation / reward normalisation")
    policy_kwargs: PolicyConfig = Field(description="the network")

    _NOT_KWARGS: ClassVar[frozenset[str]] = frozenset(
        {"name", "policy", "lr_schedule", "normalize", "policy_kwargs", "action_noise"}
    )

    #: counts that cost memory or time before anything is reported -> their limit (pyflyt_engine/limits.py)
    _BOUNDED: ClassVar[dict[str, str]] = {
        "n_steps": "algo.rollout",
        "batch_size": "algo.batch_size",
        "n_epochs": "algo.n_epochs",
        "buffer_size": "algo.buffer_size",
        "gradient_steps": "algo.gradient_steps",
        "offline_steps": "algo.offline_steps",
        "n_value_samples": "algo.iterations",
        "cg_max_steps": "algo.iterations",
        "line_search_max_iter": "algo.iterations",
        "n_critic_updates": "algo.iterations",
    }

    @field_validator(*_BOUNDED, check_fields=False)
    @classmethod
    def _bounded(cls, value: int | None, info: ValidationInfo) -> int | None:
        assert info.field_name is not None  # a field validator's
        key = cls._BOUNDED[info.field_name]
        if info.field_name == "n_steps" and "buffer_size" in cls.model_fields:  # off-policy: n-step returns
            key = "algo.n_step_returns"
        return value if value is None else limits.check(key, value, name=f"algo.{info.field_name}")

    @model_validator(mode="after")
    def _policy_fits(self) -> Any:
        name = self.name  # type: ignore[attr-defined]
        policies = registry.ALGORITHMS[name].policies
        if self.policy not in policies:
            raise ValueError(f"policy {self.policy!r} is not one of {name}'s: {', '.join(sorted(policies))}")
        for key, algos in registry.SPECIFIC_POLICY_KEYS.items():
            if getattr(self.policy_kwargs, key) is not None and name not in algos:
                raise ValueError(
                    f"policy_kwargs.{key} applies to {', '.join(sorted(algos))} only, not {name}: leave it null"
                )
        for key in sorted(registry.ALGORITHMS[name].no_policy_keys):
            if getattr(self.policy_kwargs, key) is not None:
                raise ValueError(f"policy_kwargs.{key} is not a setting of {name}'s networks: leave it null")
        return self

    @field_validator("policy")
    @classmethod
    def _known_policy(cls, value: str) -> str:
        if value not in registry.POLICIES:
            raise ValueError(registry.unknown("policy", value, registry.POLICIES))
        return value

    @property
    def off_policy(self) -> bool:
        return self.name in registry.OFF_POLICY  # type: ignore[attr-defined]

    def constructor_kwargs(self) -> dict[str, Any]:
        """Keyword arguments of the SB3 algorithm's constructor set by this config."""
        kwargs = {k: v for k, v in self.model_dump().items() if k not in self._NOT_KWARGS}
        if self.lr_schedule == "linear":
            from stable_baselines3.common.utils import LinearSchedule

            kwargs["learning_rate"] = LinearSchedule(self.learning_rate, 0.0, 1.0)
        kwargs["policy_kwargs"] = self.policy_kwargs.kwargs()
        return kwargs


class _OnPolicy(_AlgoBase):
    n_steps: int = Field(ge=1, description="steps per environment per rollout (rollout = n_steps x n_envs)")
    gae_lambda: float = Field(ge=0, le=1, description="GAE bias/variance trade-off")
    ent_coef: float = Field(ge=0, description="entropy bonus coefficient")
    vf_coef: float = Field(ge=0, description="value loss coefficient")
    max_grad_norm: float = Field(gt=0, description="gradient clipping norm")
    use_sde: bool = Field(description="generalised state-dependent exploration")
    sde_sample_freq: int = Field(ge=-1, description="resample the gSDE noise every n steps (-1: per rollout)")
    normalize_advantage: bool = Field(description="normalise advantages per batch")


class PPOConfig(_OnPolicy):
    """Proximal Policy Optimization (Schulman et al. 2017); SB3 ``PPO``."""

    name: Literal["ppo"]
    batch_size: int = Field(ge=2, description="minibatch size")
    n_epochs: int = Field(ge=1, description="passes over each rollout")
    clip_range: float = Field(gt=0, description="policy ratio clip")
    clip_range_vf: float | None = Field(gt=0, description="value clip (null: none)")
    target_kl: float | None = Field(gt=0, description="stop the epochs early beyond this KL (null: never)")


class A2CConfig(_OnPolicy):
    """Advantage Actor-Critic (Mnih et al. 2016); SB3 ``A2C``."""

    name: Literal["a2c"]
    rms_prop_eps: float = Field(gt=0, description="RMSprop epsilon")
    use_rms_prop: bool = Field(description="RMSprop (true) or Adam (false)")


class _OffPolicy(_AlgoBase):
    buffer_size: int = Field(ge=1, description="replay buffer capacity [transitions]")
    learning_starts: int = Field(ge=0, description="environment steps collected before the first update")
    batch_size: int = Field(ge=1, description="minibatch size")
    tau: float = Field(gt=0, le=1, description="target network soft update coefficient")
    train_freq: int = Field(ge=1, description="update the model every train_freq steps (per environment)")
    gradient_steps: int = Field(ge=-1, description="gradient steps per update (-1: as many as steps collected)")
    action_noise: ActionNoiseConfig | None = Field(description="exploration noise (null: none)")
    n_steps: int | None = Field(
        None,  # runs recorded before the key existed: one-step returns
        ge=1,
        description="n-step returns in the critic's TD target (SB3's NStepReplayBuffer: the next n rewards, "
        "discounted, then the bootstrap; cut at an episode's end); 1: one-step, the algorithms' own; null: 1",
    )

    def constructor_kwargs(self) -> dict[str, Any]:
        kwargs = super().constructor_kwargs()
        kwargs["optimize_memory_usage"] = False
        if kwargs.get("n_steps") in (None, 1):  # the library's default: exactly the one-step algorithm
            kwargs.pop("n_steps", None)
        return kwargs


def _check_ent_coef(value: float | str) -> float | str:
    """An entropy coefficient: a number >= 0, ``auto`` or ``auto_<initial value>`` (SAC, TQC, CrossQ)."""
    if isinstance(value, str):
        if value != "auto" and not value.startswith("auto_"):
            raise ValueError(f"ent_coef must be a number, 'auto' or 'auto_<initial value>', got {value!r}")
        if value.startswith("auto_"):
            try:
                float(value[5:])
            except ValueError:
                raise ValueError(f"ent_coef {value!r}: the part after auto_ must be a number") from None
    elif value < 0:
        raise ValueError("ent_coef must be >= 0")
    return value


class SACConfig(_OffPolicy):
    """Soft Actor-Critic (Haarnoja et al. 2018), the paper's algorithm; SB3 ``SAC``."""

    name: Literal["sac"]
    ent_coef: float | str = Field(description="entropy coefficient: a number, 'auto' or 'auto_<init>'")
    target_update_interval: int = Field(ge=1, description="target network update interval [gradient steps]")
    target_entropy: float | Literal["auto"] = Field(description="entropy target ('auto': -dim(action))")
    use_sde: bool = Field(description="generalised state-dependent exploration")
    sde_sample_freq: int = Field(ge=-1, description="resample the gSDE noise every n steps")

    @field_validator("ent_coef")
    @classmethod
    def _ent_coef(cls, value: float | str) -> float | str:
        return _check_ent_coef(value)


class SACJaxConfig(_OffPolicy):
    """Soft Actor-Critic on JAX: SBX's ``SAC`` (``pip install 'pyflyt-toolkit[jax]'``); see
    :mod:`pyflyt_cli.training.sac_jax` for what it computes differently from ``algo=sac``.

    Its critics' targets move at every gradient step (SBX has no ``target_update_interval``)
    and it has no gSDE (no ``use_sde``): those keys are refused as unknown.  ``policy_delay``:
    the actor and the temperature learn every ``policy_delay`` critic steps (1: SAC's).
    """

    name: Literal["sac_jax"]
    ent_coef: float | str = Field(description="entropy coefficient: a number, 'auto' or 'auto_<init>'")
    target_entropy: float | Literal["auto"] = Field(description="entropy target ('auto': -dim(action))")
    policy_delay: int = Field(ge=1, description="actor and temperature update every policy_delay critic updates")

    @field_validator("ent_coef")
    @classmethod
    def _ent_coef(cls, value: float | str) -> float | str:
        return _check_ent_coef(value)


class CCGEConfig(SACConfig):
    """Critic Confidence Guided Exploration (Tai et al. 2022, arXiv:2208.10533); ours, on SB3's SAC.

    See :mod:`pyflyt_cli.training.ccge`; ``init_from`` names the SAC run whose actor is the oracle.
    """

    name: Literal["ccge"]  # type: ignore[assignment]
    confidence_lambda: float = Field(
        ge=0,
        allow_inf_nan=False,
        description="the oracle acts (and is imitated) where the critic ensemble's normalised gap exceeds it",
    )
    supervise: bool = Field(description="imitate the oracle where the critic is unsure (false: exploration only)")


class TD3Config(_OffPolicy):
    """Twin Delayed DDPG (Fujimoto et al. 2018); SB3 ``TD3``."""

    name: Literal["td3"]
    policy_delay: int = Field(ge=1, description="actor update every policy_delay critic updates")
    target_policy_noise: float = Field(ge=0, description="target policy smoothing noise std")
    target_noise_clip: float = Field(ge=0, description="target policy smoothing noise clip")


class DDPGConfig(_OffPolicy):
    """Deep Deterministic Policy Gradient (Lillicrap et al. 2016); SB3 ``DDPG``."""

    name: Literal["ddpg"]


class AWACConfig(_OffPolicy):
    """Advantage-Weighted Actor-Critic (Nair et al. 2020, arXiv:2006.09359); ours, on SB3's SAC policy.

    See :mod:`pyflyt_cli.training.awac` for the losses; ``init_from`` may name a SAC run.
    """

    name: Literal["awac"]
    beta: float = Field(gt=0, description="temperature lambda of the advantage weights exp(A/lambda)")
    max_weight: float = Field(gt=0, description="clip of the advantage weights exp(A/lambda)")
    n_value_samples: int = Field(ge=1, description="policy samples per state averaged into V(s)")
    ent_coef: float = Field(ge=0, description="alpha of a soft (SAC-style) TD backup; 0: plain TD, the paper's")
    target_update_interval: int = Field(ge=1, description="target network update interval [gradient steps]")
    use_sde: bool = Field(description="generalised state-dependent exploration (as the SAC run to start from)")
    sde_sample_freq: int = Field(ge=-1, description="resample the gSDE noise every n steps")
    offline_buffer: str | None = Field(
        description="replay buffer file to pretrain on and keep filling: .npz (a run's checkpoint), or a "
        "legacy .pkl (SB3 save_replay_buffer) with trust_pickle=true; null: none"
    )
    offline_steps: int = Field(ge=0, description="gradient steps on offline_buffer before any online step")

    @field_validator("offline_buffer")
    @classmethod
    def _buffer_file(cls, value: str | None, info: ValidationInfo) -> str | None:
        if value is None or _recorded(info):  # a run's record: read (if ever) only by a resume, which checks it
            return value
        from pathlib import Path

        path = Path(value).expanduser()
        if not path.is_file():
            raise ValueError(f"offline_buffer: no such file {value!r} (a replay buffer file: .npz, or a legacy .pkl)")
        if path.suffix not in (".npz", ".pkl"):
            raise ValueError(
                f"offline_buffer: {value!r} is not a replay buffer file: give a .npz (a run's checkpoints/) "
                "or a legacy SB3 .pkl"
            )
        return str(path.resolve())

    @model_validator(mode="after")
    def _offline(self) -> AWACConfig:
        if self.offline_steps > 0 and self.offline_buffer is None:
            raise ValueError("offline_steps > 0 needs offline_buffer (a replay buffer file to pretrain on)")
        return self


class TQCConfig(SACConfig):
    """Truncated Quantile Critics (Kuznetsov et al. 2020, arXiv:2005.04269); sb3-contrib ``TQC``:
    SAC's settings plus how many quantiles to drop."""

    name: Literal["tqc"]  # type: ignore[assignment]
    top_quantiles_to_drop_per_net: int = Field(
        ge=0, description="quantiles dropped per critic from the pooled target distribution (over-estimation control)"
    )


class CrossQConfig(_OffPolicy):
    """CrossQ (Bhatt et al. 2024, ICLR, arXiv:1902.05605): SAC without target networks, batch
    renormalisation in actor and critic; sb3-contrib ``CrossQ``."""

    name: Literal["crossq"]
    # a field narrowed to null (pydantic allows it; mypy sees an incompatible override)
    tau: None = Field(description="unused: CrossQ has no target network (null)")  # type: ignore[assignment]
    ent_coef: float | str = Field(description="entropy coefficient: a number, 'auto' or 'auto_<init>'")
    target_entropy: float | Literal["auto"] = Field(description="entropy target ('auto': -dim(action))")
    policy_delay: int = Field(ge=1, description="actor (and entropy) update every policy_delay critic updates")
    use_sde: bool = Field(description="generalised state-dependent exploration")
    sde_sample_freq: int = Field(ge=-1, description="resample the gSDE noise every n steps")

    @field_validator("ent_coef")
    @classmethod
    def _ent_coef(cls, value: float | str) -> float | str:
        return _check_ent_coef(value)

    def constructor_kwargs(self) -> dict[str, Any]:
        kwargs = super().constructor_kwargs()
        kwargs.pop("tau")  # CrossQ has no target network
        return kwargs


class TRPOConfig(_AlgoBase):
    """Trust Region Policy Optimization (Schulman et al. 2015, arXiv:1502.05477); sb3-contrib ``TRPO``."""

    name: Literal["trpo"]
    n_steps: int = Field(ge=1, description="steps per environment per rollout (rollout = n_steps x n_envs)")
    batch_size: int = Field(ge=2, description="minibatch size of the critic updates")
    gae_lambda: float = Field(ge=0, le=1, description="GAE bias/variance trade-off")
    cg_max_steps: int = Field(ge=1, description="conjugate gradient iterations for the natural gradient step")
    cg_damping: float = Field(ge=0, description="damping of the Fisher-vector product")
    line_search_shrinking_factor: float = Field(gt=0, lt=1, description="step shrink per line search iteration")
    line_search_max_iter: int = Field(ge=1, description="line search iterations")
    n_critic_updates: int = Field(ge=1, description="critic epochs per rollout")
    target_kl: float = Field(gt=0, description="KL divergence bound of the trust region")
    sub_sampling_factor: int = Field(ge=1, description="use every k-th sample for the Fisher-vector products")
    normalize_advantage: bool = Field(description="normalise advantages per batch")
    use_sde: bool = Field(description="generalised state-dependent exploration")
    sde_sample_freq: int = Field(ge=-1, description="resample the gSDE noise every n steps (-1: per rollout)")


class RecurrentPPOConfig(_AlgoBase):
    """PPO with an LSTM policy and value function (sb3-contrib ``RecurrentPPO``)."""

    name: Literal["recurrent_ppo"]
    n_steps: int = Field(ge=1, description="steps per environment per rollout (rollout = n_steps x n_envs)")
    batch_size: int = Field(ge=2, description="minibatch size (whole sequences are kept together)")
    n_epochs: int = Field(ge=1, description="passes over each rollout")
    gae_lambda: float = Field(ge=0, le=1, description="GAE bias/variance trade-off")
    clip_range: float = Field(gt=0, description="policy ratio clip")
    clip_range_vf: float | None = Field(gt=0, description="value clip (null: none)")
    normalize_advantage: bool = Field(description="normalise advantages per batch")
    ent_coef: float = Field(ge=0, description="entropy bonus coefficient")
    vf_coef: float = Field(ge=0, description="value loss coefficient")
    max_grad_norm: float = Field(gt=0, description="gradient clipping norm")
    use_sde: bool = Field(description="generalised state-dependent exploration")
    sde_sample_freq: int = Field(ge=-1, description="resample the gSDE noise every n steps (-1: per rollout)")
    target_kl: float | None = Field(gt=0, description="stop the epochs early beyond this KL (null: never)")


#: ``algo:``: one model per algorithm, as the table of algorithms names it, in its order (spelled
#: out so the type checker knows each member; tests/train/test_algorithm_table.py holds it to the table)
AlgoConfig = Annotated[
    Union[  # noqa: UP007 - a type alias pydantic reads at run time
        PPOConfig,
        A2CConfig,
        SACConfig,
        SACJaxConfig,
        TD3Config,
        DDPGConfig,
        AWACConfig,
        CCGEConfig,
        TQCConfig,
        CrossQConfig,
        TRPOConfig,
        RecurrentPPOConfig,
    ],
    Field(discriminator="name"),
]


# ------------------------------------------------------------------------- train


class CurriculumOption(_Strict):
    """``train.curriculum.<option>``: one task option the training envs start at another value."""

    start: float | list[float] = Field(
        description="the option's value for the episodes that start at step 0 (a list for a vector option, "
        "e.g. start_position: moved element by element)"
    )
    steps: int = Field(
        ge=1,
        description="the value moves linearly (in 100 equal stages) from start to the env's configured "
        "value (env.task.<option>) over this many environment steps, and stays there",
    )
    gate: float | None = Field(
        None,
        gt=0.0,
        le=1.0,
        description="null: the schedule follows the step count. A fraction: its steps are counted only while at "
        "least this fraction of the last gate_episodes finished training episodes succeeded (the task's own "
        "success, at the values they flew), so the option waits where the agents do not yet succeed",
    )
    gate_episodes: int | None = Field(
        None,
        ge=1,
        description="with gate (and only with it): how many of the latest finished training episodes it looks at",
    )

    @model_validator(mode="after")
    def _gate_and_its_window(self) -> CurriculumOption:
        if (self.gate is None) != (self.gate_episodes is None):
            given, missing = ("gate", "gate_episodes") if self.gate is not None else ("gate_episodes", "gate")
            raise ValueError(
                f"{given} needs {missing}: a gate counts the schedule's steps while >= gate of the last "
                f"gate_episodes training episodes succeed; set both (e.g. gate: 0.2, gate_episodes: 100) or neither"
            )
        return self


class ImitationOptions(_Strict):
    """``train.imitation``: fit the policy to a scripted oracle by DAgger before learning (docs/cli.md)."""

    oracle: str | None = Field(
        description="a scripted controller of pyflyt_engine/envs/oracles.py (rocket_lander); null: no imitation"
    )
    rounds: int = Field(ge=0, description="DAgger rounds after round 0 (the oracle alone)")
    episodes: int = Field(ge=1, description="episodes flown per round")
    mixing: float = Field(
        ge=0.0,
        le=1.0,
        description="the oracle's share of the actions in round 1, falling linearly to mixing/rounds at the "
        "last round (the policy acts otherwise)",
    )
    epochs: int = Field(ge=1, description="passes over the aggregated data set after every round")
    batch_size: int = Field(ge=1, description="minibatch of the fit")
    learning_rate: float = Field(gt=0.0, description="Adam step size of the fit")
    value_warmup: int | None = Field(
        None,
        ge=0,
        description="PPO, A2C: the first this many learning steps after the stage update the value function "
        "only, the fitted policy held (0 or unset: none)",
    )
    hold_normalizer: bool | None = Field(
        None,
        description="keep the observation normaliser's statistics as the stage left them for the whole run "
        "(the inputs the policy was fitted on); false or unset: they go on updating",
    )

    @field_validator("oracle")
    @classmethod
    def _known(cls, value: str | None) -> str | None:
        from pyflyt_engine.envs.oracles import ORACLES

        if value is not None and value not in ORACLES:
            raise ValueError(f"unknown oracle {value!r}; oracles: {', '.join(sorted(ORACLES))}")
        return value


class TrainOptions(_Strict):
    """``train``: budget, parallelism, evaluation, checkpoints and outputs of a run."""

    total_timesteps: int = Field(ge=1, description="environment steps to train for (summed over n_envs)")
    n_envs: int = Field(ge=1, description="parallel environments (SubprocVecEnv when > 1, unless vec_env=dummy)")
    vec_env: Literal["auto", "dummy", "subproc"] = Field(
        description=(
            "auto: subprocesses when n_envs > 1 (multi-agent envs: in this process); dummy: all in this "
            "process; subproc: one process per env"
        )
    )
    eval_freq: int = Field(ge=0, description="evaluate every this many environment steps (0: never)")
    eval_episodes: int = Field(ge=1, description="episodes per evaluation")
    eval_deterministic: bool = Field(description="evaluate the policy's mean action")
    best_by: Literal["return", "success"] | None = Field(
        None,  # runs recorded before the key existed: return
        description="which evaluation best_model.pt keeps: return, the highest mean return; success, the "
        "highest success rate (ties: the higher return); null: return",
    )
    checkpoint_freq: int = Field(
        ge=0, description="checkpoint every this many environment steps (0: only on interrupt)"
    )
    keep_checkpoints: int = Field(
        ge=0, description="keep the newest k model checkpoints (0: all); one replay buffer is kept"
    )
    save_replay_buffer: bool = Field(
        description="save the replay buffer with checkpoints (off-policy), for exact resume"
    )
    progress_bar: bool | None = Field(description="tqdm bar with steps/s and ETA; null: only on a terminal")
    tensorboard: bool = Field(description="also write TensorBoard logs to <run>/tensorboard (needs tensorboard)")
    output_dir: str = Field(description="root of run directories: <output_dir>/<env>/<algo>/<time>-seed<k>")
    device: Literal["cpu", "cuda", "auto"] = Field(description="torch device")
    torch_threads: int = Field(ge=1, description="torch intra-op threads (1: reproducible and fastest for small MLPs)")
    verbose: int = Field(ge=0, le=2, description="SB3 verbosity (0: silent)")
    curriculum: dict[str, CurriculumOption] | None = Field(
        None,  # runs recorded before the key existed had none
        description="task option -> {start, steps}: training episodes fly the option at start, moving to the "
        "configured value over steps (evaluations always fly the configured task); null: none",
    )
    imitation: ImitationOptions | None = Field(
        None,  # runs recorded before the key existed had none
        description="fit the new policy to a scripted oracle by DAgger before learning (imitation.oracle null: none)",
    )

    @field_validator("total_timesteps", "n_envs", "eval_episodes", "torch_threads")
    @classmethod
    def _bounded(cls, value: int, info: ValidationInfo) -> int:
        return limits.check(f"train.{info.field_name}", value, name=f"train.{info.field_name}")

    @field_validator("imitation")
    @classmethod
    def _no_oracle_is_none(cls, value: ImitationOptions | None) -> ImitationOptions | None:
        # without an oracle the other settings do nothing: the run is the one recorded before the
        # key existed (the same identity, so a benchmark does not see its older runs as changed)
        return None if value is not None and value.oracle is None else value


class CallbackConfig(_Strict):
    """``callbacks[]``: an SB3 callback by registered name, run after every evaluation."""

    name: Literal["stop_on_reward", "stop_on_no_improvement"] = Field(
        description="stop_on_reward: stop once the mean eval return reaches reward_threshold; "
        "stop_on_no_improvement: stop after max_no_improvement_evals evaluations without a new best"
    )
    reward_threshold: float | None = Field(None, description="stop_on_reward: mean evaluation return to reach")
    max_no_improvement_evals: int | None = Field(
        None, ge=1, description="stop_on_no_improvement: patience [evaluations]"
    )
    min_evals: int | None = Field(
        None, ge=0, description="stop_on_no_improvement: evaluations before counting (null: SB3's, from the first)"
    )

    @model_validator(mode="after")
    def _params(self) -> CallbackConfig:
        if self.name == "stop_on_reward" and self.reward_threshold is None:
            raise ValueError("stop_on_reward needs reward_threshold")
        if self.name == "stop_on_no_improvement" and self.max_no_improvement_evals is None:
            raise ValueError("stop_on_no_improvement needs max_no_improvement_evals")
        return self

    def build(self) -> Any:
        cls = registry.resolve(registry.CALLBACKS, self.name, "callback")
        if self.name == "stop_on_reward":
            return cls(reward_threshold=self.reward_threshold, verbose=0)
        optional = {} if self.min_evals is None else {"min_evals": self.min_evals}
        return cls(max_no_improvement_evals=self.max_no_improvement_evals, verbose=0, **optional)


#: keys that widen what loading may do (run code from a pickled file): honoured only from the command
#: line of the current command, never from a file (a run's config.yaml, an experiment, a benchmark
#: plan, a search space), which is the very thing they would trust
OPT_INS = ("trust_pickle",)


class TrainConfig(_Strict):
    """One training run: environment, algorithm, seed, options."""

    seed: int = Field(ge=0, description="seeds everything: env resets, motor noise, network init, action sampling")
    env_name: str = Field(
        description="the name the run is filed and plotted under (runs/<env_name>/...): the env config's, "
        "or a benchmark's task"
    )
    env: SerializeAsAny[EnvConfig] = Field(description="the environment (conf/env, validated by EnvConfig)")
    algo: AlgoConfig = Field(description="algorithm and hyper-parameters (conf/algo, tuned by conf/hparams)")
    train: TrainOptions = Field(description="budget, parallelism, evaluation, checkpoints and outputs")
    callbacks: list[CallbackConfig] = Field(description="extra callbacks run after each evaluation")
    init_from: str | None = Field(
        description="run directory, one of its model files, or <run dir>@<step> (its first checkpoint at or "
        "after that step), whose policy weights start this run (bootstrap); null: from scratch",
    )
    trust_pickle: bool = Field(
        description="load legacy pickled files (SB3 .zip models, .pkl replay buffers/normalisers) named by "
        "init_from, algo.offline_buffer or pyflyt eval: unpickling can run arbitrary code; only for files you "
        "made yourself"
    )
    experiment: str | None = Field(description="name of the experiment file applied, for the record")

    @field_validator("env", mode="before")
    @classmethod
    def _env(cls, value: Any) -> Any:
        if isinstance(value, EnvConfig):
            return value
        return parse_env_config(value, source="env")

    @field_validator("seed")
    @classmethod
    def _seed(cls, value: int) -> int:
        return limits.check("seed", value)

    @field_validator("init_from")
    @classmethod
    def _init_from(cls, value: str | None) -> str | None:
        if value is not None and not value.strip():
            raise ValueError("init_from is empty: give a run directory, a model file or <run dir>@<step> (null: none)")
        split_init_from(value)
        return value

    @field_validator("env_name")
    @classmethod
    def _slug(cls, value: str) -> str:
        if not value or any(c in value for c in "/\\") or value in (".", ".."):
            raise ValueError(f"env_name must be a plain name usable as a directory, got {value!r}")
        return value

    @model_validator(mode="after")
    def _consistent(self, info: ValidationInfo) -> TrainConfig:
        algo, opts = self.algo, self.train
        buffer = algo.offline_buffer if isinstance(algo, AWACConfig) else None
        if buffer is not None and buffer.endswith(".pkl") and not self.trust_pickle and not _recorded(info):
            raise ValueError(
                f"algo.offline_buffer {buffer} is a pickle (.pkl): unpickling can run arbitrary code. Give a .npz "
                "replay buffer (a run's checkpoints/), or set trust_pickle=true if you made that file yourself"
            )
        if isinstance(algo, CCGEConfig) and not self.init_from and not _recorded(info):
            raise ValueError(
                "algo=ccge needs init_from=<a SAC run, policy file or <run dir>@<step>>: that policy's actor is "
                "CCGE's oracle; without one the oracle would be the random initial actor (docs/algorithms.md)"
            )
        backend = getattr(self.env, "backend", "pybullet")
        if backend == "auto":  # resolved here, so the run records the backend it trains on
            from pyflyt_engine.batched import resolve_backend

            backend = resolve_backend(self.env, imitation=opts.imitation is not None)
            object.__setattr__(self, "env", self.env.model_copy(update={"backend": backend}))
        if backend == "batched":
            _check_batched(self.env, opts)
        if opts.curriculum:
            _check_curriculum(self.env, opts.curriculum)
            _check_curriculum_budget(opts.curriculum, opts.total_timesteps)
        if opts.imitation is not None:
            _check_imitation(self.env, algo.name, opts.imitation)
            if opts.imitation.hold_normalizer and not algo.normalize.observation:
                raise ValueError(
                    "train.imitation.hold_normalizer holds the observation normaliser's statistics, and "
                    "algo.normalize.observation is false: set one of them differently"
                )
        if isinstance(algo, (PPOConfig, RecurrentPPOConfig, TRPOConfig)):
            from pyflyt_cli.training.multi_agent import agents_per_env

            agents = agents_per_env(self.env)  # a multi-agent env fills a slot per agent
            rollout = algo.n_steps * opts.n_envs * agents
            size = "n_steps x n_envs" + (f" x {agents} agents" if agents > 1 else "")
            if rollout < 2:
                raise ValueError(f"algo.n_steps x train.n_envs must be at least 2 for {algo.name}")
            limits.check("algo.rollout", rollout, name=f"the rollout {size}")
            if algo.batch_size > rollout:
                raise ValueError(
                    f"algo.batch_size ({algo.batch_size}) exceeds the rollout size {size} = {rollout}; "
                    "lower algo.batch_size or raise algo.n_steps"
                )
        return self


#: algorithms whose policy ``train.imitation.value_warmup`` can hold while the value function learns
#: (one optimiser over the actor and the critic, updated by gradient; TRPO's actor step is not)
VALUE_WARMUP_ALGORITHMS = ("ppo", "a2c")


def _check_imitation(env: EnvConfig, algo: str, imitation: ImitationOptions) -> None:
    """The oracle flies this env, and the algorithm's policy can be fitted state by state."""
    from pyflyt_engine.envs.oracles import ORACLES

    if getattr(env, "multi_agent", False):
        raise ValueError("train.imitation: the multi-agent envs have no oracle; set train.imitation.oracle=null")
    fitted = [name for name, a in registry.ALGORITHMS.items() if a.imitation]
    if algo not in fitted:
        raise ValueError(f"train.imitation cannot fit a {algo} policy; algorithms: {', '.join(fitted)}")
    if imitation.value_warmup and algo not in VALUE_WARMUP_ALGORITHMS:
        raise ValueError(
            f"train.imitation.value_warmup holds the policy of an actor-critic updated from its own rollouts "
            f"({', '.join(VALUE_WARMUP_ALGORITHMS)}), not {algo}; set train.imitation.value_warmup=0"
        )
    assert imitation.oracle is not None  # train.imitation without one is None (TrainOptions._no_oracle_is_none)
    flies = ORACLES[imitation.oracle].env_ids
    if env.id not in flies:
        raise ValueError(f"train.imitation.oracle={imitation.oracle} flies {', '.join(flies)}, not {env.id}")


def _check_batched(env: EnvConfig, opts: TrainOptions) -> None:
    """``env.backend: batched`` simulates this env (else the backend's refusal, by name) and
    the run asks nothing of it that it lacks."""
    from pyflyt_engine.batched import check_supported
    from pyflyt_engine.errors import PyFlytError

    try:
        check_supported(env)
    except PyFlytError as exc:
        raise ValueError(str(exc)) from None
    if opts.imitation is not None:
        raise ValueError(
            "train.imitation flies its oracle in the env one episode at a time: set env.backend=pybullet "
            "(or train.imitation.oracle=null)"
        )


def _check_curriculum(env: EnvConfig, curriculum: Mapping[str, CurriculumOption]) -> None:
    """Every option of ``train.curriculum`` can change per episode, and its start value is valid."""
    from pyflyt_engine.envs.tasks import get_task
    from pyflyt_engine.errors import PyFlytError

    multi_agent = getattr(env, "multi_agent", False)
    if multi_agent:
        from pyflyt_engine.envs.multi_agent.config import get_ma_task

        task_cls: Any = get_ma_task(env.task.name)
    else:
        task_cls = get_task(env.task.name)
    unknown = sorted(set(curriculum) - task_cls.episode_options)
    if unknown:
        allowed = ", ".join(sorted(task_cls.episode_options)) or "none"
        raise ValueError(
            f"train.curriculum: task '{env.task.name}' cannot change {', '.join(unknown)} per episode "
            f"(options a curriculum may move: {allowed})"
        )
    if multi_agent:
        import numpy as np

        agents = env.resolved_agents()  # type: ignore[attr-defined]
        task = task_cls(
            env.task,
            agents,
            np.zeros(len(agents), dtype=bool),
            flight_dome_size=env.flight_dome_size,
            agent_hz=env.agent_hz,
            max_steps=env.max_steps,
        )
    else:
        task = task_cls(env.task, flight_dome_size=env.flight_dome_size, agent_hz=env.agent_hz)
    try:
        task.set_episode_options({name: option.start for name, option in curriculum.items()})
    except ValidationError as exc:  # one line per rejected value, named as the user wrote it
        wrong = "; ".join(
            describe_error(type(env.task), {**e, "loc": (e["loc"][0], "start", *e["loc"][1:])}, "train.curriculum.")
            for e in exc.errors()
        )
        raise ValueError(f"the curriculum's start values are not a valid task: {wrong}") from None
    except (PyFlytError, ValueError) as exc:
        raise ValueError(f"train.curriculum: the start values are not a valid task: {exc}") from None


def _check_curriculum_budget(curriculum: Mapping[str, CurriculumOption], total: int) -> None:
    """Every option of ``train.curriculum`` reaches its configured value within the budget:
    a curriculum that outlasts ``train.total_timesteps`` would end training on an easier task
    than the one every evaluation flies (and ``best_model.pt`` is chosen by)."""
    for name, option in curriculum.items():
        if option.steps > total:
            raise ValueError(
                f"train.curriculum.{name}.steps={option.steps} outlasts train.total_timesteps={total}: training would "
                f"end before {name} reaches the task's configured value, which the evaluations fly; set "
                f"train.curriculum.{name}.steps={total} (or fewer), or train.total_timesteps={option.steps} (or more), "
                "or drop the curriculum with train.curriculum=null"
            )


def split_init_from(value: str | None) -> tuple[str | None, int | None]:
    """``init_from`` as (source, checkpoint step): ``"<run dir>@<step>"`` -> (run dir, step); else (value, None)."""
    if value is None or "@" not in value.replace("\\", "/").rsplit("/", 1)[-1]:
        return value, None
    source, _, step = value.rpartition("@")
    if not source or not step.isdigit():
        raise ValueError("write <run dir>@<step> with a whole number of steps (e.g. runs/a/sac/seed0@7500)")
    return source, int(step)


def _recorded(info: ValidationInfo) -> bool:
    """Whether the config being validated is a run's record (``parse_train_config(recorded=True)``)."""
    return bool(info.context and info.context.get("recorded"))


def parse_train_config(
    data: Mapping[str, Any] | TrainConfig, source: str = "train config", *, recorded: bool = False
) -> TrainConfig:
    """Validate a plain mapping into a :class:`TrainConfig` (raises :class:`ConfigError`).

    ``_target_`` keys are checked against the registries before anything else; an env
    config that fails its own schema reports its problems under ``env.``.  ``recorded``:
    the configuration a run was trained with (its ``config.yaml``), not one to start: the
    files it names to start from (``algo.offline_buffer``) are kept as recorded, not
    checked, and its ``trust_pickle`` is never honoured (see
    :func:`pyflyt_cli.training.rundir.load_run_config`).
    """
    if isinstance(data, TrainConfig):
        return data
    if not isinstance(data, Mapping):
        raise ConfigError(f"{source}: a training config must be a mapping, got {type(data).__name__}")
    tree: Mapping[str, Any] = registry.check_targets(data)
    if "trust_pickle" not in tree:  # a run recorded before the key existed never trusted pickles
        tree = {**tree, "trust_pickle": False}
    algo = tree.get("algo")
    if isinstance(algo, Mapping) and algo.get("name") not in registry.ALGOS:
        raise ConfigError(f"{source}: algo.name: " + registry.unknown("algorithm", algo.get("name"), registry.ALGOS))
    try:
        cfg = TrainConfig.model_validate(tree, context={"recorded": recorded})
    except ValidationError as exc:
        lines = []
        for error in exc.errors():
            loc = tuple(error["loc"])
            if loc and loc[0] == "env" and error["type"] == "value_error":
                # the env's own validator already produced a full message
                lines.append(str(error["msg"]).removeprefix("Value error, "))
            else:  # algo.<key>: the chosen algorithm's model (the union's tag is left out)
                lines.append(describe_error(TrainConfig, error))
        hint = ""
        if any(e["type"] == "missing" for e in exc.errors()):
            hint = (
                "\n  (every key must be given: its default lives in conf/; compose a complete configuration with "
                "pyflyt_cli.training.compose_config(env=..., algo=..., overrides=[...]))"
            )
        raise ConfigError(f"{source}: invalid configuration:\n" + problem_list(lines) + hint) from None
    check_env_references(cfg.env)
    return cfg


def check_env_references(env: EnvConfig) -> None:
    """Load what the env config names — the reward preset and the airframe — so a wrong name fails now."""
    from pyflyt_engine.envs.config import load_reward_preset
    from pyflyt_engine.envs.tasks import get_task
    from pyflyt_engine.errors import PyFlytError
    from pyflyt_engine.spec import load_uav_spec

    if getattr(env, "multi_agent", False):
        from pyflyt_engine.envs.multi_agent.config import check_references

        try:
            check_references(env)  # type: ignore[arg-type]
        except PyFlytError as exc:
            raise ConfigError(f"env: {exc}") from None
        dict_keys = [k for k in ("camera_observation", "range_sensors") if getattr(env, k)]
        if dict_keys:  # the agent slots stack one flat observation row per agent
            raise ConfigError(
                f"env.{dict_keys[0]}: a shared policy trains on flat per-agent observations; a multi-agent env "
                "with camera images or range sensors (a Dict observation) flies, records and replays, but "
                f"cannot be trained with pyflyt train yet: remove env.{dict_keys[0]}"
            )
        return
    try:
        task = get_task(env.task.name)
        load_reward_preset(env.reward_preset_name()).compile(task.provides, task.name)
    except PyFlytError as exc:
        raise ConfigError(f"env.reward: {exc}") from None
    try:
        load_uav_spec(env.uav)
    except PyFlytError as exc:
        raise ConfigError(f"env.uav: {exc}") from None


def _algo_model(name: str) -> type[BaseModel]:
    return globals()[registry.ALGORITHMS[name].config]


# -------------------------------------------------------------------------- eval


class EvalOptions(_Strict):
    """``pyflyt eval <run_dir> [key=value ...]`` (``conf/eval.yaml``)."""

    episodes: int = Field(ge=1, description="episodes to run")
    seed: int | None = Field(ge=0, description="episode i is reset with seed + i (null: the run's seed + 1000)")
    deterministic: bool = Field(description="use the policy's mean action (false: sample)")
    model: Literal["auto", "best", "final", "latest"] = Field(
        description="best: the best model; final: the final model; latest: newest checkpoint; "
        "auto: best, else final, else latest",
    )
    record: bool = Field(description="write each episode to <run_dir>/episodes/ as MCAP")
    video: str | None = Field(
        description="film the first video_episodes episodes to this .gif or .mp4 (the pyflyt replay --video film)"
    )
    video_episodes: int = Field(ge=1, description="episodes included in the video")
    fps: int | None = Field(ge=1, description="video frame rate (null: the env's agent rate)")
    trust_pickle: bool = Field(
        description="load legacy pickled files (SB3 .zip models, .pkl normalisers) of the run: unpickling can "
        "run arbitrary code; only for files you made yourself"
    )

    @field_validator("seed")
    @classmethod
    def _seed(cls, value: int | None) -> int | None:
        return value if value is None else limits.check("seed", value)

    @field_validator("episodes")
    @classmethod
    def _episodes(cls, value: int) -> int:
        return limits.check("eval.episodes", value, name="episodes")

    @field_validator("fps")
    @classmethod
    def _fps(cls, value: int | None) -> int | None:
        return value if value is None else limits.check("video.fps", value, name="fps")

    @field_validator("video")
    @classmethod
    def _video(cls, value: str | None) -> str | None:
        if value is not None and not value.lower().endswith((".gif", ".mp4")):
            raise ValueError(f"must end in .gif or .mp4, got {value!r}: e.g. video=flight.gif or video=flight.mp4")
        return value


def parse_eval_options(data: Mapping[str, Any] | EvalOptions) -> EvalOptions:
    """Validate ``pyflyt eval`` options (raises :class:`ConfigError`); keys left out take ``conf/eval.yaml``'s values."""
    if isinstance(data, EvalOptions):
        return data
    try:
        return EvalOptions.model_validate({**eval_defaults(), **dict(data)})
    except ValidationError as exc:
        raise ConfigError("invalid eval options:\n" + problem_list(problems(EvalOptions, exc))) from None


def eval_defaults() -> dict[str, Any]:
    """``conf/eval.yaml``: the default of every :class:`EvalOptions` field (plain YAML data, no Hydra)."""
    from pyflyt_engine.paths import conf_dir
    from pyflyt_engine.safe_load import load_yaml_file

    data = load_yaml_file(conf_dir() / "eval.yaml")
    if not isinstance(data, dict):  # pragma: no cover - broken install
        raise ConfigError(f"{conf_dir() / 'eval.yaml'}: not a mapping of eval options")
    return data
