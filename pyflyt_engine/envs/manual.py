"""Env manuals, written from an env's loaded config and its built env's spaces.

An env's manual (``pyflyt envs <id or config>``, and the generated sections of
docs/environments.md) states what its config and its built env say, nothing restated by
hand: the id, config file and description; the vehicle and the loop rates; the action
table (``config.action``); the observation layout (the parts the task declares,
:meth:`UAVEnv.observation_layout <pyflyt_engine.envs.env.UAVEnv.observation_layout>`, whose
sizes a test checks against the built space); the reward presets with their terms, weights
and conditions (``conf/reward``); the task options and spawn; the episode end (the
configured terminations, the time limit, the flight dome); and the arguments of
``gymnasium.make``.  What a number cannot say -- what the task is for, why it is built as
it is -- is the prose of the env class's docstring and of docs/environments.md.

* :func:`env_manual` -- one env's manual (Markdown) by Gymnasium id, multi-agent name or
  env config name; :func:`resolve_env` -- that name's env config, or a ConfigError listing
  the known names;
* :func:`manuals_markdown`, :func:`replace_embedded_manuals` -- every registered env's
  manual, as embedded between :data:`BEGIN_MARKER` and :data:`END_MARKER` in
  docs/environments.md (``python -m pyflyt_cli.commands.env_manuals docs/environments.md``
  regenerates it).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np
from gymnasium import spaces

from pyflyt_engine.envs import ENVS
from pyflyt_engine.envs.config import EnvConfig, MultiAgentEnvConfig, RewardPreset, load_env_config, load_reward_preset
from pyflyt_engine.envs.observe import FLAT, ObservationLayout, ObservationPart
from pyflyt_engine.envs.rewards import TERMS, resolve_condition
from pyflyt_engine.envs.terminations import TERMINATIONS
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.loading import available
from pyflyt_engine.suggest import did_you_mean

BEGIN_MARKER = "<!-- BEGIN GENERATED ENV MANUALS (python -m pyflyt_cli.commands.env_manuals docs/environments.md) -->"
END_MARKER = "<!-- END GENERATED ENV MANUALS -->"

#: the top-level config keys ``gymnasium.make`` takes as plain values (the sections -- action,
#: terminations, payloads, obstacles, sensors ... -- are taken as mappings)
_PLAIN_ARGUMENTS = (
    "uav",
    "physics_hz",
    "control_hz",
    "agent_hz",
    "max_duration_seconds",
    "flight_dome_size",
    "angle_representation",
    "reward",
    "drag",
    "wind",
    "ground_effect",
    "downwash",
    "controller",
    "backend",
)


# ------------------------------------------------------------------------ names


def _multi_agent_envs() -> dict[str, Any]:
    from pyflyt_engine.envs.multi_agent import MA_ENVS

    return dict(MA_ENVS)


def known_names() -> list[str]:
    """Every name :func:`resolve_env` takes: the registered Gymnasium ids, the multi-agent
    env names and the shipped env configs (``conf/env``, the bases left out)."""
    return [*ENVS, *_multi_agent_envs(), *available("env")]


def resolve_env(name: str) -> str:
    """The shipped env config that ``name`` names: a Gymnasium id (``PyFlyt/QuadX-Hover-v0``,
    or without its ``PyFlyt/``), a multi-agent env (``ma_quadx_hover_v0``) or a config
    (``quadx_hover_sensors``).

    Raises:
        ConfigError: no such env, naming the closest and listing the known ones.
    """
    if name in ENVS:
        return ENVS[name].config
    if f"PyFlyt/{name}" in ENVS:
        return ENVS[f"PyFlyt/{name}"].config
    ma = _multi_agent_envs()
    if name in ma:
        return str(ma[name].config)
    if name in available("env"):
        return name
    known = known_names()
    raise ConfigError(
        f"unknown environment '{name}'.{did_you_mean(name, known)} Known: {', '.join(known)} (pyflyt envs lists them)"
    )


# --------------------------------------------------------------------- building


def _build(cfg: EnvConfig) -> Any:
    """The env ``cfg`` describes, headless: a :class:`UAVEnv` or a multi-agent parallel env."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if getattr(cfg, "multi_agent", False):
            from pyflyt_engine.envs.multi_agent import env_class

            return env_class(cfg.task.name)(cfg)
        from pyflyt_engine.envs import make_env

        return make_env(cfg)


def _registration(name: str, cfg: EnvConfig) -> tuple[str, str, str]:
    """(title, how it is made, what it is): the registered id or multi-agent name of config
    ``name``, the call that makes it, and a line naming its class or the env it varies."""
    for ma_name, entry in _multi_agent_envs().items():
        if entry.config == name:
            cls = entry.entry_point.partition(":")[2]
            module = entry.module.rpartition(".")[2]
            return ma_name, f"`{module}.parallel_env(**kwargs)` (`{entry.module}`)", f"class `{cls}` (PettingZoo)"
    for env_id, entry in ENVS.items():
        if entry.config == name:
            cls = entry.entry_point.partition(":")[2]
            return env_id, f'`gymnasium.make("{env_id}", **kwargs)`', f"class `{cls}`"
    of = f"a variant of `{cfg.id}`" if cfg.id else "an env config"
    return name, f'`make_env("{name}", **kwargs)` (`pyflyt_engine.envs.make_env`)', f"{of} (`pyflyt train env={name}`)"


# ------------------------------------------------------------------- formatting


def _num(value: float) -> str:
    """A number as read: multiples of pi by name (``-pi``, ``pi/2``), else ``%g``."""
    value = round(float(value), 12) + 0.0  # a layout's 6e-17 is the 0 it means; no -0
    for k, text in ((1.0, "pi"), (0.5, "pi/2"), (2.0, "2 pi"), (0.25, "pi/4")):
        for sign, prefix in ((1.0, ""), (-1.0, "-")):
            if abs(value - sign * k * math.pi) < 1e-12:
                return prefix + text
    return f"{value:g}"


def _value(value: Any) -> str:
    """A config value as written in a manual."""
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, (int, float)):
        return _num(value)
    if isinstance(value, (tuple, list)):
        return "(" + ", ".join(_value(v) for v in value) + ")" if value else "()"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k}: {_value(v)}" for k, v in value.items()) + "}" if value else "{}"
    return str(value)


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def _table(header: Sequence[str], rows: Iterable[Sequence[str]]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(_cell(c) for c in row) + " |" for row in rows]
    return lines


def describe_space(space: spaces.Space) -> str:
    """A one-line summary of a Gymnasium space (``Box(21,)``, ``Box(64, 64, 3) uint8``, ``Dict(...)``)."""
    if isinstance(space, spaces.Box):
        shape = ", ".join(str(n) for n in space.shape) + ("," if len(space.shape) == 1 else "")
        dtype = "" if space.dtype == np.float64 else f" {space.dtype}"
        return f"Box({shape}){dtype}"
    if isinstance(space, spaces.Sequence):
        return f"Sequence({describe_space(space.feature_space)})"
    if isinstance(space, spaces.Dict):
        return "Dict(" + ", ".join(f"{k}: {describe_space(v)}" for k, v in space.spaces.items()) + ")"
    return repr(space)


# ---------------------------------------------------------------------- sections


def _loop_section(cfg: EnvConfig, env: Any) -> list[str]:
    steps = int(round(cfg.physics_hz / cfg.agent_hz))
    rows = [
        ("vehicle", f"`{cfg.uav}`"),
        ("flight mode", f"`{cfg.action.mode}` (controller: {cfg.controller})"),
        ("physics", f"{_num(cfg.physics_hz)} Hz"),
        ("control", f"{_num(cfg.control_hz)} Hz"),
        ("agent", f"{_num(cfg.agent_hz)} Hz: one agent step = {steps} physics steps ({1 / cfg.agent_hz:.4g} s)"),
        (
            "air",
            f"wind {_value(cfg.wind)}, drag {_value(cfg.drag)}, ground effect {_value(cfg.ground_effect)}, "
            f"downwash {_value(cfg.downwash)}",
        ),  # fmt: skip
    ]
    if getattr(cfg, "multi_agent", False):
        teams = sorted(set(env.teams.tolist()))
        airframes = ", ".join(sorted({v.spec.name for v in env.vehicles}))
        rows.insert(0, ("agents", f"{len(env.possible_agents)} ({', '.join(env.possible_agents)}); airframes "
                                  f"{airframes}; teams {teams}"))  # fmt: skip
    return ["**Vehicle and loop rates**", "", *_table(("", ""), rows)]


def _action_section(cfg: EnvConfig, space: spaces.Box, multi: bool) -> list[str]:
    a = cfg.action
    units = a.units or [""] * len(a.names)
    per = " per agent" if multi else ""
    return [
        f"**Action** `{describe_space(space)}`{per}, {space.dtype}, clipped to its bounds: the setpoint of flight "
        f"mode `{a.mode}` (`pyflyt modes`)",
        "",
        *_table(
            ("index", "name", "unit", "low", "high"),
            (
                (str(i), f"`{n}`", u, _num(lo), _num(hi))
                for i, (n, u, lo, hi) in enumerate(zip(a.names, units, a.low, a.high))
            ),
        ),
    ]


def _parts_table(parts: Sequence[ObservationPart]) -> list[str]:
    rows, start = [], 0
    for p in parts:
        rows.append((f"{start}:{start + p.size}", str(p.size), f"`{p.name}`", p.meaning, p.unit))
        start += p.size
    return _table(("slice", "size", "part", "meaning", "frame / unit"), rows)


def _observation_section(
    cfg: EnvConfig, space: spaces.Space, layout: ObservationLayout, other: ObservationLayout
) -> list[str]:
    multi = getattr(cfg, "multi_agent", False)
    per = " per agent" if multi else ""
    other_name = "euler" if cfg.angle_representation == "quaternion" else "quaternion"
    sizes = {key: sum(p.size for p in parts) for key, parts in other.items()}
    changed = ", ".join(
        f"{'' if key == FLAT else f'`{key}` '}{n} entries"
        for key, n in sizes.items()
        if n != sum(p.size for p in layout[key])
    )
    lines = [
        f"**Observation** `{describe_space(space)}`{per} (angle_representation {cfg.angle_representation}; "
        f"with {other_name}: {changed or 'the same sizes'})",
        "",
    ]
    entries = space.spaces if isinstance(space, spaces.Dict) else {FLAT: space}
    for key, sub in entries.items():
        if key != FLAT:
            rows = " (one row each, `(n, 3)` stacked)" if isinstance(sub, spaces.Sequence) else ""
            lines += [f"`{key}`: `{describe_space(sub)}`{rows}", ""]
        lines += [*_parts_table(layout[key]), ""]
    return lines[:-1]


def _term_text(name: str) -> str:
    term = TERMS.get(name)
    return f"`{name}`: {term.description.rstrip('.')}" if term is not None else f"`{name}`"


def _preset_rows(preset: RewardPreset) -> list[tuple[str, ...]]:
    rows: list[tuple[str, ...]] = []
    for entry, t in preset.terms.items():
        when = [t.when] if isinstance(t.when, str) else list(t.when)
        params = ", ".join(f"{k}={_value(v)}" for k, v in t.params.items())
        rows.append(
            (f"`{entry}`", _num(t.weight), _term_text(t.term or entry), ", ".join(f"`{w}`" for w in when), params)
        )
    return rows


def _presets_of(cfg: EnvConfig) -> list[tuple[str, str]]:
    """(preset, how it is selected) for the presets of this env: the configured dense and
    sparse ones, the configured ``reward`` if it is another, and the other shipped presets of
    the same family (``quadx_waypoints_dense_rate`` beside ``quadx_waypoints_dense``)."""
    out: list[tuple[str, str]] = []
    for kind, name in cfg.reward_presets.items():
        how = f'reward="{kind}"' + (", sparse_reward=True" if kind == "sparse" else "")
        out.append((name, how))
    names = {n for n, _ in out}
    if isinstance(cfg.reward, str) and cfg.reward not in cfg.reward_presets and cfg.reward not in names:
        out.append((cfg.reward, f'reward="{cfg.reward}"'))
        names.add(cfg.reward)
    stem = cfg.reward_presets["dense"].rpartition("_dense")[0]
    if stem:
        for name in available("reward"):
            if name.startswith(stem + "_") and name not in names:
                out.append((name, f'reward="{name}"'))
    return out


def _reward_section(cfg: EnvConfig) -> list[str]:
    default = cfg.reward if isinstance(cfg.reward, str) else "an inline preset"
    lines = [
        f'**Reward** (default `reward="{default}"`): the weighted sum of each preset\'s entries whose conditions all '
        'hold at the step; `info["reward_terms"]` has each entry',
        "",
    ]
    used: list[str] = []
    for name, how in _presets_of(cfg):
        preset = load_reward_preset(name)
        lines += [f"`{name}` ({how}): {preset.description}", ""]
        lines += [*_table(("entry", "weight", "term", "when", "params"), _preset_rows(preset)), ""]
        for t in preset.terms.values():
            for w in [t.when] if isinstance(t.when, str) else t.when:
                if w not in used and w != "always":
                    used.append(w)
    if isinstance(cfg.reward, dict):
        lines += ["The configured reward is an inline preset (the config's `reward` mapping).", ""]
    if used:
        described = []
        for w in used:
            condition, negated = resolve_condition(w)
            text = f"the negation of `{w[4:]}`" if negated else condition.description.rstrip(".")
            described.append(f"`{w}`: {text}")
        lines += ["Conditions: " + "; ".join(described) + ".", ""]
    return lines[:-1]


def _start_section(cfg: EnvConfig, env: Any) -> list[str]:
    task = env.task
    fields = type(cfg.task).model_fields
    rows = []
    for key, value in cfg.task.model_dump().items():
        if key == "name":
            continue
        field = fields.get(key)
        meaning = field.description or "" if field is not None else ""
        if field is not None and "fraction of the flight dome" in meaning:
            value_text = f"{_value(value)} (= {_num(value * cfg.flight_dome_size)} m)"
        else:
            value_text = _value(value)
        rows.append((f"`{key}`", value_text, "yes" if key in task.episode_options else "", meaning))
    lines = [
        f"**Task and starting state**: task `{cfg.task.name}` (options: `task:` of the config, or by their own "
        'name as arguments; *per episode*: `reset(options={"task": {...}})` may change it)',
        "",
        *_table(("option", "value", "per episode", "meaning"), rows),
    ]
    if isinstance(cfg, MultiAgentEnvConfig):
        spawn_rows = [
            (f"`{a.name}`", f"`{a.uav}`", str(a.team), _value(a.spawn.position), _num(a.spawn.position_noise),
             _value(a.spawn.orientation), _num(a.spawn.orientation_noise), _value(a.hover_point))
            for a in cfg.resolved_agents()
        ]  # fmt: skip
        lines += [
            "",
            "Agents (spawned at position + U(-noise, noise) per axis [m], attitude + U(-noise, noise) per Euler angle "
            "[rad], drawn from the env's seeded RNG):",
            "",
            *_table(("agent", "uav", "team", "position", "noise", "attitude", "noise", "point / slot"), spawn_rows),
        ]
    extras = []
    if cfg.payloads:
        extras.append(
            "payloads: "
            + ", ".join(f"`{p.name}` ({p.mass():.3g} kg, {p.attach.joint} to the {p.attach.to})" for p in cfg.payloads)
        )
    if cfg.obstacles is not None:
        extras.append("obstacles: declared in the config's `obstacles` (docs/obstacles_and_sensors.md)")
    if cfg.randomize:
        extras.append("randomised at every reset: " + ", ".join(f"`{k}`" for k in cfg.randomize))
    if cfg.latency is not None:
        extras.append(
            f"latency: action {_num(cfg.latency.action_delay)} s, observation {_num(cfg.latency.observation_delay)} s"
        )
    if cfg.sensors is not None:
        extras.append(
            f"sensors: observed {_value(cfg.sensors.observe)}, estimator {cfg.sensors.estimator.type} "
            '(docs/environments.md, "Sensor observation")'
        )
    if extras:
        lines += ["", *(f"* {e}" for e in extras)]
    return lines


def _end_section(cfg: EnvConfig, env: Any) -> list[str]:
    task = env.task
    rows = []
    for entry, t in cfg.terminations.items():
        if t is None:
            rows.append((f"`{entry}`", "off", "", "switched off by this config"))
            continue
        term = TERMINATIONS[t.term or entry]
        params = ", ".join(f"{k}={_value(v)}" for k, v in t.params.items())
        rows.append((f"`{entry}`", term.kind, params, term.description))
    survival = "counts as a success (a survival task)" if task.succeeds_at_time_limit else "is no success by itself"
    contact = (
        "any contact of the vehicle is a crash"
        if task.crash_on_contact
        else "a contact is no crash by itself (the task judges it)"
    )
    return [
        f"**Episode end**: truncated after `max_duration_seconds` = {_num(cfg.max_duration_seconds)} s = "
        f"{cfg.max_steps} agent steps, which {survival}; flight dome: a sphere of radius `flight_dome_size` = "
        f"{_num(cfg.flight_dome_size)} m about the origin; {contact}.  Terminations, in order:",
        "",
        *_table(("entry", "kind", "params", "meaning"), rows),
    ]


def _argument(cfg: EnvConfig, key: str) -> str:
    value = getattr(cfg, key)
    if key == "agents" and isinstance(value, list):
        return f"{len(value)} listed"
    return _value(value)


def _arguments_section(cfg: EnvConfig, call: str) -> list[str]:
    keys = ("agents", *_PLAIN_ARGUMENTS) if getattr(cfg, "multi_agent", False) else _PLAIN_ARGUMENTS
    values = ", ".join(f"`{k}` ({_argument(cfg, k)})" for k in keys)
    return [
        f"**Arguments** of {call}: `sparse_reward` (bool: the sparse or dense preset), `render_mode` (None, "
        f'"rgb_array", "human"), any task option above by its name, and any key of the env config, here: {values}; '
        "sections (`action`, `terminations`, `payloads`, `obstacles`, `range_sensors`, `camera_observation`, "
        "`sensors`, `latency`, `randomize`) as mappings.",
    ]


def _variants(name: str, cfg: EnvConfig) -> list[str]:
    if not cfg.id:
        return []
    out = []
    for other in available("env"):
        if other == name:
            continue
        other_cfg = load_env_config(other)
        if other_cfg.id == cfg.id:
            out.append(f"`{other}` ({other_cfg.description}; `pyflyt envs {other}`)")
    return [f"**Other configs declaring `{cfg.id}`**: " + "; ".join(out)] if out else []


def _entry_sizes(space: spaces.Space) -> dict[str, int]:
    """Entry key -> values per entry (per row of a Sequence) of an observation space."""

    def size(s: spaces.Space) -> int:
        return size(s.feature_space) if isinstance(s, spaces.Sequence) else int(np.prod(s.shape or (1,)))

    entries = space.spaces if isinstance(space, spaces.Dict) else {FLAT: space}
    return {key: size(sub) for key, sub in entries.items()}


def _check_layout(cfg: EnvConfig, layout: ObservationLayout, space: spaces.Space) -> None:
    """ConfigError unless the declared parts make up ``space`` (a task that changed its
    ``observation_space`` without declaring the change in ``observation_parts``)."""
    declared = {key: sum(p.size for p in parts) for key, parts in layout.items()}
    built = _entry_sizes(space)
    if declared != built:
        raise ConfigError(
            f"task '{cfg.task.name}': its declared observation parts ({declared}) do not make up its observation "
            f"space ({built}); declare in the task's observation_parts what its observation_space adds"
        )


def env_manual(name: str, heading: str = "###") -> str:
    """The manual of the env ``name`` names (:func:`resolve_env`), as Markdown: built once,
    headless, to read its spaces.

    Raises:
        ConfigError: no such env (the message lists the known names).
    """
    config = resolve_env(name)
    cfg = load_env_config(config)
    env = _build(cfg)
    try:
        multi = getattr(cfg, "multi_agent", False)
        if multi:
            first = env.possible_agents[0]
            observation_space, action_space = env.observation_space(first), env.action_space(first)
        else:
            observation_space, action_space = env.observation_space, env.action_space
        quaternion = cfg.angle_representation == "quaternion"
        layout = env.observation_layout()
        _check_layout(cfg, layout, observation_space)
        other = env.observation_layout(quaternion=not quaternion)
        title, call, what = _registration(config, cfg)
        source = f"conf/env/{config}.yaml"
        lines = [
            f"{heading} `{title}`",
            "",
            f"{cfg.description}.  Config `{source}`; {what}; `pyflyt envs {title}` prints this.",
            "",
            *_loop_section(cfg, env),
            "",
            *_action_section(cfg, action_space, multi),
            "",
            *_observation_section(cfg, observation_space, layout, other),
            "",
            *_reward_section(cfg),
            "",
            *_start_section(cfg, env),
            "",
            *_end_section(cfg, env),
            "",
            *_arguments_section(cfg, call),
        ]
        variants = _variants(config, cfg)  # the configs also declaring this id
        if variants:
            lines += ["", *variants]
        return "\n".join(lines) + "\n"
    finally:
        env.close()


# ----------------------------------------------------------- the embedded manuals


def _index_row(name: str) -> tuple[str, ...]:
    config = resolve_env(name)
    cfg = load_env_config(config)
    env = _build(cfg)
    try:
        if getattr(cfg, "multi_agent", False):
            first = env.possible_agents[0]
            observation, action = env.observation_space(first), env.action_space(first)
        else:
            observation, action = env.observation_space, env.action_space
        return (f"`{name}`", f"`conf/env/{config}.yaml`", f"`{describe_space(observation)}`",
                f"`{describe_space(action)}` {cfg.action.mode}")  # fmt: skip
    finally:
        env.close()


def manuals_markdown() -> str:
    """The manual of every registered env (Gymnasium ids, then the multi-agent envs) after
    an index table, as embedded in docs/environments.md."""
    names = [*ENVS, *_multi_agent_envs()]
    index = _table(("env", "config", "observation (quaternion)", "action"), (_index_row(n) for n in names))
    return "\n".join(["\n".join(index) + "\n", *(env_manual(name) for name in names)])


def embedded_manuals(markdown: str) -> str | None:
    """The text between the markers of ``markdown`` (None without them)."""
    start, end = markdown.find(BEGIN_MARKER), markdown.find(END_MARKER)
    if start < 0 or end < start:
        return None
    return markdown[start + len(BEGIN_MARKER) : end].strip("\n") + "\n"


def replace_embedded_manuals(markdown: str, manuals: str | None = None) -> str:
    """``markdown`` with the section between the markers regenerated.

    Raises:
        ValueError: the document has no such section.
    """
    start, end = markdown.find(BEGIN_MARKER), markdown.find(END_MARKER)
    if start < 0 or end < start:
        raise ValueError(f"the document has no {BEGIN_MARKER} ... {END_MARKER} section")
    text = manuals_markdown() if manuals is None else manuals
    return markdown[: start + len(BEGIN_MARKER)] + "\n\n" + text + "\n" + markdown[end:]
