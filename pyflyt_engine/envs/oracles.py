"""Scripted controllers ("oracles"): hand-written policies over an environment's observation.

An oracle is a callable ``oracle(observation) -> action`` built for one environment
(``make_oracle(name, env)``) from that environment's parameters, with no state carried
between calls: the action is a function of the observation alone, so it can label any
state a learner visits (imitation by DAgger, ``train.imitation`` in ``pyflyt train``)
and serve as a baseline, flown, recorded and filmed like a trained run by ``pyflyt eval
oracle:<name>`` (``experiments/rocket_scripted_landing.py`` compares it with a free fall).

Oracles:

* ``rocket_lander`` (``PyFlyt/Rocket-Landing-v0``, raw channels): :class:`RocketLander`;
* ``rocket_velocity_lander`` (``PyFlyt/Rocket-Landing-Velocity-v0``, the rocket
  autopilot's ``velocity`` mode): :class:`RocketVelocityLander`;
* ``rocket_descent_lander`` (``PyFlyt/Rocket-Landing-Descent-v0``, the rocket autopilot's
  ``descent`` mode): :class:`RocketDescentLander`;
* ``quadx_forest_navigator`` (``PyFlyt/QuadX-Obstacles-v0``, from the LiDAR):
  :class:`QuadXForestNavigator`;
* ``quadx_gate_racer`` (``PyFlyt/QuadX-Gates-v0`` with ``task.observation: corners``,
  ``conf/env/quadx_gates_state.yaml``): :class:`QuadXGateRacer`.

The two QuadX oracles fly ``rates_thrust`` through :class:`QuadXVelocityPilot`, a stateless
velocity-to-body-rates law (:mod:`pyflyt_engine.envs.tasks.pilot`);
``experiments/quadx_scripted.py`` measures them (``experiments/results/quadx_scripted.md``).

Each oracle lives in the module of the task it flies (the rocket landers in
:mod:`pyflyt_engine.envs.tasks.landing`, the forest navigator in
:mod:`pyflyt_engine.envs.tasks.goal`, the gate racer in :mod:`pyflyt_engine.envs.tasks.gates`)
and is registered with that task (``register_task(..., oracles=(...))``,
:mod:`pyflyt_engine.envs.task_registry`).  An oracle class has a ``name``, the ``env_ids`` it
flies, and is built on the env.  :data:`ORACLES` is the registry's view of them all.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from pyflyt_engine.envs.task_registry import OracleTable
from pyflyt_engine.envs.tasks.gates import QuadXGateRacer
from pyflyt_engine.envs.tasks.goal import QuadXForestNavigator
from pyflyt_engine.envs.tasks.landing import (
    IGNITION_LIT,
    IGNITION_SCALE,
    ROCKET_STANDING_HEIGHT,
    RocketDescentLander,
    RocketLander,
    RocketVelocityLander,
)
from pyflyt_engine.envs.tasks.pilot import QuadXVelocityPilot
from pyflyt_engine.errors import ConfigError

#: oracle name -> oracle class (each names the env ids it flies in ``env_ids``): a live view
#: of the oracles registered with their tasks
ORACLES: OracleTable = OracleTable()


def make_oracle(name: str, env: Any) -> Callable[[np.ndarray], np.ndarray]:
    """The oracle ``name`` built for ``env`` (a gymnasium env of one of its ``env_ids``)."""
    if name not in ORACLES:
        from pyflyt_engine.suggest import did_you_mean

        raise ConfigError(
            f"unknown oracle {name!r}.{did_you_mean(name, ORACLES)} Oracles: {', '.join(sorted(ORACLES))}"
        )
    cls = ORACLES[name]
    env_id = getattr(getattr(env, "spec", None), "id", None) or getattr(env.unwrapped.config, "id", None)
    if env_id not in cls.env_ids:
        raise ConfigError(f"oracle {name} flies {', '.join(cls.env_ids)}, not {env_id}")
    return cls(env)


__all__ = [
    "IGNITION_LIT",
    "IGNITION_SCALE",
    "ORACLES",
    "ROCKET_STANDING_HEIGHT",
    "QuadXForestNavigator",
    "QuadXGateRacer",
    "QuadXVelocityPilot",
    "RocketDescentLander",
    "RocketLander",
    "RocketVelocityLander",
    "make_oracle",
]
