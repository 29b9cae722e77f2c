"""What is registered, as ``pyflyt envs`` and ``pyflyt modes`` list it (one env's full
manual, ``pyflyt envs <id>``, is :func:`pyflyt_engine.envs.manual.env_manual`).

:func:`list_envs`: every Gymnasium environment, its spaces, reward presets and defaults,
then the multi-agent (PettingZoo) ones (:func:`list_multi_agent_envs`);
:func:`list_modes`: the flight modes (multirotor, with their PyFlyt numbers; fixed-wing; rocket) and setpoint layouts.
"""

from __future__ import annotations

import warnings
from typing import Any

from pyflyt_engine.envs.manual import describe_space  # one summary of a space, as the env manuals write it


def list_envs() -> str:
    """A table of every registered environment (builds each once, headless, to read its spaces)."""
    from pyflyt_engine.envs import ENVS, make_env
    from pyflyt_engine.envs.config import load_reward_preset
    from pyflyt_engine.envs.rewards import CONDITIONS, TERMS
    from pyflyt_engine.envs.terminations import TERMINATIONS

    lines = []
    for env_id, entry in ENVS.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            env = make_env(entry.config)
        try:
            cfg = env.config
            action = cfg.action
            bounds = ", ".join(f"{n} [{lo:g}, {hi:g}]" for n, lo, hi in zip(action.names, action.low, action.high))
            presets = ", ".join(f"{kind}={name}" for kind, name in cfg.reward_presets.items())
            task_defaults = {
                k: v
                for k, v in cfg.task.model_dump().items()
                if k not in ("name", "start_orientation", "start_orientation_noise")
            }
            lines += [
                f"{env_id}  (config: {entry.config}, class: {type(env).__name__})",
                f"  {cfg.description}",
                f"  observation: {describe_space(env.observation_space)}  [{cfg.angle_representation}]",
                f"  action:      Box({len(action.names)},) -> mode {action.mode}: {bounds}",
                f"  rewards:     {presets} (default: {cfg.reward})",
                f"               dense: {load_reward_preset(cfg.reward_presets['dense']).description}",
                f"  defaults:    uav={cfg.uav}, rates {cfg.physics_hz:g}/{cfg.control_hz:g}/{cfg.agent_hz:g} Hz, "
                f"episode {cfg.max_duration_seconds:g} s ({cfg.max_steps} steps), dome {cfg.flight_dome_size:g} m",
                f"  task:        {cfg.task.name}: "
                + ", ".join(_task_value(cfg, k, v) for k, v in task_defaults.items()),
            ]
            if cfg.payloads:
                lines.append(
                    "  payloads:    "
                    + ", ".join(
                        f"{pl.name} ({pl.mass():.3g} kg, {pl.attach.joint} to {pl.attach.to})" for pl in cfg.payloads
                    )
                )
            lines += [f"  variant:     {line}" for line in _variants(env_id, entry.config)]
            lines.append("")
        finally:
            env.close()
    lines += list_multi_agent_envs()
    lines.append("reward terms: " + ", ".join(TERMS))
    lines.append("conditions:   " + ", ".join(CONDITIONS) + " (each also as not_<name>)")
    lines.append("terminations: " + ", ".join(f"{name} ({term.kind})" for name, term in TERMINATIONS.items()))
    lines.append(
        "make one: gymnasium.make(id, sparse_reward=True, angle_representation='euler', ...) after import pyflyt_engine"
    )
    return "\n".join(lines)


def _variants(env_id: str, registered: str) -> list[str]:
    """The other env configs of ``conf/env`` declaring ``env_id`` (e.g. another flight mode or
    observation of the same task): ``name: description; observation, action mode`` each, for
    ``pyflyt train env=<name>``."""
    from pyflyt_engine.envs import make_env
    from pyflyt_engine.envs.config import load_env_config
    from pyflyt_engine.loading import available

    out = []
    for name in available("env"):  # the bases (conf/env/_*.yaml) are no envs
        if name == registered:
            continue
        cfg = load_env_config(name)
        if cfg.id != env_id:
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            env = make_env(cfg)
        try:
            out.append(
                f"{name}: {cfg.description}; observation {describe_space(env.observation_space)}, "
                f"action mode {cfg.action.mode} (pyflyt train env={name})"
            )
        finally:
            env.close()
    return out


def _task_value(cfg: Any, key: str, value: Any) -> str:
    """``key=value``; a fraction of the flight dome also in metres (``max_target_distance=0.9 x dome = 4.5 m``)."""
    field = type(cfg.task).model_fields.get(key)
    if field is not None and "fraction of the flight dome" in (field.description or ""):
        return f"{key}={value:g} x dome = {value * cfg.flight_dome_size:g} m"
    return f"{key}={value}"


def list_multi_agent_envs() -> list[str]:
    """Lines describing every multi-agent (PettingZoo) environment (builds each once, headless)."""
    import importlib

    from pyflyt_engine.envs.config import load_reward_preset
    from pyflyt_engine.envs.multi_agent import MA_ENVS

    lines = ["multi-agent environments (PettingZoo; train one shared policy with pyflyt train env=<config>):", ""]
    for entry in MA_ENVS.values():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            env = importlib.import_module(entry.module).parallel_env()
        try:
            cfg = env.config
            first = env.possible_agents[0]
            action = cfg.action
            bounds = ", ".join(f"{n} [{lo:g}, {hi:g}]" for n, lo, hi in zip(action.names, action.low, action.high))
            presets = ", ".join(f"{kind}={preset}" for kind, preset in cfg.reward_presets.items())
            teams = sorted(set(env.teams.tolist()))
            task = {k: v for k, v in cfg.task.model_dump().items() if k != "name"}
            lines += [
                f"{entry.module}  (config: {entry.config}, class: {type(env).__name__})",
                f"  {cfg.description}",
                (
                    f"  agents:      {len(env.possible_agents)} ({', '.join(env.possible_agents)}), "
                    f"airframes {', '.join(sorted({v.spec.name for v in env.vehicles}))}, teams {teams}"
                ),
                f"  observation: {describe_space(env.observation_space(first))} per agent  [{cfg.angle_representation}]",
                f"  action:      Box({len(action.names)},) per agent -> mode {action.mode}: {bounds}",
                f"  rewards:     {presets} (default: {cfg.reward})",
                f"               dense: {load_reward_preset(cfg.reward_presets['dense']).description}",
                (
                    f"  defaults:    rates {cfg.physics_hz:g}/{cfg.control_hz:g}/{cfg.agent_hz:g} Hz, "
                    f"episode {cfg.max_duration_seconds:g} s ({cfg.max_steps} steps), dome {cfg.flight_dome_size:g} m"
                ),
                f"  task:        {cfg.task.name}: " + ", ".join(f"{k}={v}" for k, v in task.items()),
                "",
            ]
        finally:
            env.close()
    return lines


def list_modes() -> str:
    """A table of the flight modes: the multirotor modes (name, PyFlyt number, setpoint layout,
    meaning) and their aliases, then the fixed-wing and rocket autopilots' modes."""
    from pyflyt_engine.control.fixedwing import FIXEDWING_MODES
    from pyflyt_engine.control.modes import MODE_ALIASES, MULTIROTOR_MODES
    from pyflyt_engine.control.rocket import ROCKET_MODES

    lines = ["multirotors (control.type multirotor):", f"{'mode':<22}{'PyFlyt':>7}  setpoint"]
    for mode in MULTIROTOR_MODES.values():
        pid = "" if mode.pyflyt_id is None else str(mode.pyflyt_id)
        layout = "one throttle per motor" if mode.name == "motors" else ", ".join(mode.setpoint)
        lines.append(f"{mode.name:<22}{pid:>7}  [{layout}]  {mode.description}")
    lines.append("aliases (multirotors): " + ", ".join(f"{k} -> {v}" for k, v in MODE_ALIASES.items()))
    for title, table in (
        ("fixed-wing airframes (control.type fixedwing):", FIXEDWING_MODES),
        ("airframes with a gimballed booster (a rocket; any control.type but multirotor):", ROCKET_MODES),
    ):
        lines += ["", title]
        for mode in table.values():
            layout = "one value per channel" if mode.name == "channels" else ", ".join(mode.setpoint)
            lines.append(f"{mode.name:<22}{'':>7}  [{layout}]  {mode.description}")
    return "\n".join(lines)
