"""The episode core's building blocks, by concern (this module only gathers their names).

The single-agent loop (:class:`~pyflyt_engine.envs.env.UAVEnv`) and the multi-agent loop
(:class:`~pyflyt_engine.envs.multi_agent.base.MultiAgentUAVEnv`) share, through the
episode core (:mod:`pyflyt_engine.envs.episode`):

* :mod:`pyflyt_engine.envs.build` -- the config, what an episode flies and how it starts
  (:func:`load_config`, :func:`build_episode`, :func:`reset_episode`, :func:`task_changes`);
* :mod:`pyflyt_engine.envs.step` -- the action clipping and the reward context of a step;
* :mod:`pyflyt_engine.envs.terminations` -- how a step ends an agent's episode;
* :mod:`pyflyt_engine.envs.observe` -- the observation layout, the sensors' and estimator's
  view of the state, camera images and range sensors;
* :mod:`pyflyt_engine.envs.guard` -- the never-NaN guard and its report;
* :mod:`pyflyt_engine.envs.recordable` -- what an env shows of itself to the recorder.
"""

from __future__ import annotations

from pyflyt_engine.envs.build import (
    EpisodeParts,
    build_episode,
    check_render_mode,
    load_config,
    reset_episode,
    task_changes,
)
from pyflyt_engine.envs.guard import all_finite, divergence_error
from pyflyt_engine.envs.observe import (
    attitude_size,
    attitude_vector,
    estimated_state,
    sensed_state,
    with_image_space,
    with_observation_camera,
    with_range_sensors,
    with_range_spaces,
    with_readings,
    with_sensors,
)
from pyflyt_engine.envs.recordable import RECORDABLE, RecordableEnv
from pyflyt_engine.envs.step import clip_action, step_context
from pyflyt_engine.envs.terminations import outside_dome

__all__ = [
    "RECORDABLE",
    "EpisodeParts",
    "RecordableEnv",
    "all_finite",
    "attitude_size",
    "attitude_vector",
    "build_episode",
    "check_render_mode",
    "clip_action",
    "divergence_error",
    "estimated_state",
    "load_config",
    "outside_dome",
    "reset_episode",
    "sensed_state",
    "step_context",
    "task_changes",
    "with_image_space",
    "with_observation_camera",
    "with_range_sensors",
    "with_range_spaces",
    "with_readings",
    "with_sensors",
]
