"""The largest values accepted where a number from a file or the command line costs time or memory.

A run directory, a recording or an override may come from someone else (docs/reproducibility.md,
"Safe to share"), and some numbers decide how much work a command does before it can report
anything: ``env.physics_hz: 3e9`` made ``pyflyt eval`` allocate gigabytes before its first step,
``env.render.resolution: [100000, 100000]`` asked the renderer for 40 GB, ``pyflyt fly rows=1e9``
built a table of a billion rows.  Each such number is checked against this one table when the
config holding it is validated (env configs, airframe cameras, ``pyflyt fly`` options), so the
refusal is one line naming the key, the value and the limit, before any work starts.

Every limit is far above what any shipped config, experiment or test uses (the largest in
``conf/``: physics 240 Hz, 120 s episodes, 480 x 480 images), so no real use meets it; the table
is printed in docs/reproducibility.md and each limit has a test in ``tests/engine/test_limits.py``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TypeVar

#: a checked count or quantity, returned as given
Number = TypeVar("Number", int, float)


@dataclass(frozen=True)
class Limit:
    """The largest value of one kind of key, its unit and what it bounds."""

    high: float
    unit: str
    why: str


#: key -> limit.  The keys name the config field (or the family of fields) they apply to.
LIMITS: dict[str, Limit] = {
    "physics_hz": Limit(10_000.0, "Hz", "physics steps per simulated second (the paper: 240)"),
    "control_hz": Limit(10_000.0, "Hz", "controller updates per simulated second (the paper: 120)"),
    "agent_hz": Limit(10_000.0, "Hz", "agent steps per simulated second (the paper: 30)"),
    "max_duration_seconds": Limit(86_400.0, "s", "simulated length of one episode (one day)"),
    # physics_hz x max_duration_seconds: the physics steps of one episode (about ten minutes of CPU)
    "episode_physics_steps": Limit(1e7, "steps", "physics steps of one episode (physics_hz x max_duration_seconds)"),
    "image_side": Limit(4096.0, "px", "height or width of a rendered or camera image"),
    "flight_dome_size": Limit(100_000.0, "m", "radius of the flight dome (its square must stay a finite number)"),
    # NumPy's legacy seeding, which SB3 uses, takes 32 bits; half of that range leaves room for the
    # offsets derived from a seed (an env per vector slot, evaluation episodes from seed + 1000 + i)
    "seed": Limit(2**31 - 1, "", "a run's or an evaluation's seed"),
    "eval.episodes": Limit(
        1_000_000.0, "episodes", "episodes `pyflyt eval` flies (seeds seed ... seed + episodes - 1)"
    ),
    # physical values that overflowed or flew a NaN trajectory with exit 0 (max_rpm 1e200, noise_ratio
    # 1e10, wind 1e300): far above any real machine (hobby motors: tens of thousands of RPM)
    "max_rpm": Limit(1e7, "RPM", "a motor's speed at full throttle"),
    # a body of 1e30 kg fell through the ground (PyBullet's contact gives way): 100 t is past any UAV
    "mass": Limit(100_000.0, "kg", "an airframe's body mass"),
    "noise_ratio": Limit(1.0, "", "the std of a motor's multiplicative throttle noise (1: 100 %)"),
    "wind_speed": Limit(1000.0, "m/s", "a wind, gust or turbulence speed (three times the speed of sound)"),
    # fps=1e9 kept one frame of a GIF (and ended in Pillow's TypeError)
    "video.fps": Limit(1000.0, "frames/s", "frame rate of a video `pyflyt eval video=` writes"),
    "fly.rows": Limit(10_000.0, "rows", "rows of the table `pyflyt fly` prints"),
    "fly.duration": Limit(86_400.0, "s", "simulated seconds `pyflyt fly` flies"),
    # a setpoint or spawn position of 1e308 flew a NaN trajectory with exit 0 (or printed a 300-digit altitude)
    "fly.magnitude": Limit(
        100_000.0, "", "each value of a `pyflyt fly` setpoint, spawn position or attitude (as the flight dome)"
    ),
    # counts of a training run (a run's config.yaml, an experiment, a benchmark plan, the command line):
    # `train.n_envs=1e8` or `algo.n_steps=1e9` ended in a NumPy MemoryError traceback, a layer of 1e8
    # units in torch's, `train.eval_episodes=1e9` evaluated for ever before the first report.  The largest
    # shipped: 4.5 M steps, 256 envs, rollouts of 16 384 samples, minibatches of 4 096, a 1 M replay
    # buffer (the paper's), 20 epochs, [400, 300] networks
    "train.total_timesteps": Limit(1e12, "steps", "environment steps of one run (years of CPU time)"),
    "train.n_envs": Limit(65_536.0, "envs", "environments of one run (PyBullet envs, or the batched backend's arrays)"),
    "train.eval_episodes": Limit(10_000.0, "episodes", "episodes of each evaluation during training"),
    "train.torch_threads": Limit(1024.0, "threads", "torch's intra-op threads"),
    "algo.rollout": Limit(
        1e7, "samples", "an on-policy rollout, n_steps x n_envs (x agents): every sample's observation is kept"
    ),
    # NStepReplayBuffer reads n transitions per sampled one: a minibatch of 256 at n = 1e7 is 2.6e9 reads
    "algo.n_step_returns": Limit(1000.0, "steps", "rewards summed in an off-policy n-step return (algo.n_steps)"),
    "algo.batch_size": Limit(1_048_576.0, "samples", "a minibatch of one gradient step"),
    "algo.n_epochs": Limit(10_000.0, "epochs", "passes over each on-policy rollout"),
    "algo.buffer_size": Limit(
        1e7, "transitions", "the replay buffer, allocated whole when training starts (the paper: 1e6)"
    ),
    "algo.gradient_steps": Limit(100_000.0, "steps", "gradient steps of one off-policy update"),
    "algo.offline_steps": Limit(1e8, "steps", "gradient steps on an offline buffer before the first online step"),
    "algo.iterations": Limit(
        10_000.0,
        "iterations",
        "iterations of an inner loop of one update (samples of V(s), conjugate gradient, line search, critic epochs)",
    ),
    "net.width": Limit(65_536.0, "units", "units of one hidden layer (net_arch, lstm_hidden_size)"),
    "net.depth": Limit(1000.0, "layers", "hidden layers of one network (net_arch, n_lstm_layers)"),
    "net.parameters": Limit(1e8, "weights", "weights between the hidden layers of one network (400 MB as float32)"),
    "net.critics": Limit(100.0, "networks", "Q networks of one critic (n_critics)"),
    "net.quantiles": Limit(10_000.0, "quantiles", "quantiles of each TQC critic"),
    # counts of the commands that run many trainings or measurements
    "jobs": Limit(1024.0, "processes", "runs or trials trained at once on this machine (`benchmark`, `tune`)"),
    "benchmark.seeds": Limit(10_000.0, "seeds", "seeds of one benchmark group (the paper: 50)"),
    "benchmark.random_episodes": Limit(
        10_000.0, "episodes", "episodes of the random policy per task (a benchmark's score 0)"
    ),
    "tune.trials": Limit(100_000.0, "trials", "finished trials a study should hold"),
    "speed.repeats": Limit(1000.0, "runs", "runs per figure of `pyflyt speed`"),
    "speed.vehicles": Limit(4096.0, "vehicles", "vehicles of one PyBullet world `pyflyt speed --vehicles` builds"),
    "plot.reps": Limit(1_000_000.0, "replicates", "bootstrap replicates per statistic of `pyflyt plot --reps`"),
    # lists read from a recording (``pyflyt replay``, ``--verify``, ``--plot``, ``--video``): a 3 M-value
    # state list hung replay; shipped recordings hold rows of a few dozen values
    "recording.row_values": Limit(
        10_000.0, "values", "values in one recorded row of unfixed width (aux state, sensors)"
    ),
    # the largest a recorder writes: an OBJ mesh at its limits, 100 000 vertices and 200 000 triangles
    # (600 000 indices), drawn as one triangle list
    "recording.scene_items": Limit(
        1_000_000.0, "items", "items of one list in a /scene record: entities, an entity's shapes, a shape's points"
    ),
}


def problem(key: str, value: float, *, name: str | None = None) -> str | None:
    """Why ``value`` of ``key`` (shown as ``name``) is above its limit; None when it is within.

    ``value`` is a number the schema already took (finite, positive where it must be)."""
    limit = LIMITS[key]
    if value <= limit.high:
        return None
    unit = f" {limit.unit}" if limit.unit else ""
    return (
        f"{name or key} {number(value)} is above the limit of {number(limit.high)}{unit} ({limit.why}); "
        "give a smaller value (the limits: docs/reproducibility.md, 'Bounded numbers')"
    )


def number(value: float) -> str:
    """``value`` as a message shows it: a whole number of up to 12 digits exactly, anything else ``:g``."""
    if float(value).is_integer() and abs(value) < 1e12:
        return str(int(value))
    return f"{value:g}"


def check(key: str, value: Number, *, name: str | None = None) -> Number:
    """``value`` if it is within the limit of ``key``, else ``ValueError`` (for a pydantic validator)."""
    why = problem(key, value, name=name)
    if why is not None:
        raise ValueError(why)
    return value


__all__ = ["LIMITS", "Limit", "check", "number", "problem"]
