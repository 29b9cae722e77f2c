"""What the batched backend simulates of an env config: every other key is refused by name.

:func:`check_keys` is shared by the single-agent envs (:func:`pyflyt_engine.batched.env.check_supported`)
and the multi-agent worlds (:func:`pyflyt_engine.batched.swarm.check_swarm_supported`, which
refuses more), so neither imports the other to ask.
"""

from __future__ import annotations

from pyflyt_engine.batched.model import batched_model, mode_code, refuse
from pyflyt_engine.envs.config import EnvConfig
from pyflyt_engine.batched.randomization import BATCHED_PARAMETERS, MOTOR, unsupported
from pyflyt_engine.batched.terms import batched_ends
from pyflyt_engine.spec import load_uav_spec

#: tasks the batched backend runs
BATCHED_TASKS = ("hover", "waypoints")


#: why range sensors on the waypoints task are refused: the agent's observation would differ
#: between the backends, so a policy trained on one could not be evaluated on the other
WAYPOINT_RANGES = (
    "the PyBullet env hands the agent its waypoints and readings as a Dict, which the batched "
    "backend's flat vector would not match when the policy is evaluated in the PyBullet engine"
)


def check_keys(config: EnvConfig, multi_agent: bool = False) -> None:
    """Refuse, by name, every key of ``config`` the batched backend does not simulate; a
    multi-agent config's task is its caller's to check (``multi_agent``)."""
    if not multi_agent and config.task.name not in BATCHED_TASKS:
        raise refuse(f"the task '{config.task.name}'", f"it runs {', '.join(BATCHED_TASKS)}")
    from pyflyt_engine.atmosphere import load_wind_config

    load_wind_config(config.wind)  # every wind: mean, shear, gust, Dryden turbulence
    refused = unsupported(config.randomize, config.wind)  # domain randomisation: what it draws per env
    if refused is not None:
        name, why = refused
        drawn = ", ".join(BATCHED_PARAMETERS) + ", wind.<path>"
        raise refuse(f"env.randomize.{name} (domain randomisation: {why})", f"it draws {drawn}")
    for key, present in (
        ("downwash", config.downwash),
        ("controller=betaflight (the firmware in the loop)", getattr(config, "controller", "own") == "betaflight"),
        ("payloads", bool(config.payloads)),
        ("obstacles", config.obstacles is not None),
        ("range_sensors in a multi-agent world", multi_agent and bool(config.range_sensors)),
        (
            f"range_sensors on the waypoints task ({WAYPOINT_RANGES})",
            config.task.name == "waypoints" and bool(config.range_sensors),
        ),
        ("camera_observation", config.camera_observation is not None),
    ):
        if present:
            raise refuse(f"env.{key}")
    per_agent = config.physics_hz / config.agent_hz
    per_control = config.physics_hz / config.control_hz
    if (
        abs(per_control - round(per_control)) > 1e-9
        or abs(per_agent / round(per_control) - round(per_agent / round(per_control))) > 1e-9
    ):
        raise refuse(
            f"control ticks out of step with the agent steps (physics_hz {config.physics_hz:g}, control_hz "
            f"{config.control_hz:g}, agent_hz {config.agent_hz:g})",
            "give control_hz a whole multiple of agent_hz that divides physics_hz",
        )
    model = batched_model(load_uav_spec(config.uav), 1.0 / config.physics_hz, 1.0 / config.control_hz, drag=config.drag)
    drawn_motors = [name for name in (config.randomize or {}) if name in MOTOR]
    if model.gimbals.size:  # the gimbals' rows hold the nominal motors, and the latency's history no servo angles
        from pyflyt_engine.batched.latency import declares_latency

        if drawn_motors:
            raise refuse(
                f"env.randomize.{drawn_motors[0]} on an airframe with gimbals (airframe {model.name})",
                "it draws the motors' factors for airframes without gimbals",
            )
        if declares_latency(config):
            raise refuse(f"env.latency on an airframe with gimbals (airframe {model.name})")
    mode_code(config.action.mode, model)
    batched_ends(config.terminations, True)  # a termination term it does not implement, by name


__all__ = ["BATCHED_TASKS", "check_keys"]
