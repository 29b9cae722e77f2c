"""Replaying a recorded episode: summary, rebuild of its environment, and re-simulation check.

* :func:`summarize` — vehicles, duration, return, success, per-term reward totals.
* :func:`rebuild_env` — the environment the recording came from, from its metadata alone.
* :func:`verify` — re-apply the recorded actions from the recorded reset and report the
  largest deviation between recorded and re-simulated states (0.0 for the same package
  versions on the same platform: the simulation is deterministic).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pyflyt_engine.errors import PyFlytError, TelemetryError
from pyflyt_engine.telemetry.episode import STATE_FIELDS, Episode
from pyflyt_engine.telemetry.recorder import package_versions


def summarize(episode: Episode) -> dict[str, Any]:
    """Plain-data summary of an episode (what ``pyflyt replay FILE`` prints)."""
    end = episode.end or {}
    totals = {k: float(np.nansum(v)) for k, v in episode.reward_terms.items()}
    return {
        "file": str(episode.path),
        "env": episode.env_info.get("gym_id") or episode.env_info.get("config_id") or "(custom config)",
        "vehicles": [v.name for v in episode.vehicles],
        "steps": episode.length,
        "duration_s": episode.duration,
        "return": float(np.nansum(episode.rewards)),
        "success": bool(end.get("success", False)) if end else None,
        "end": end.get("reason") if end else None,
        "terminated": bool(end.get("terminated", False)) if end else None,
        "truncated": bool(end.get("truncated", False)) if end else None,
        "seed": episode.seed,
        "reward_terms": totals,
        "file_truncated": episode.truncated,
        "recorded_with": {
            k: episode.versions.get(k, "") for k in ("pyflyt_engine", "pybullet", "numpy", "python", "platform")
        },
    }


def format_summary(summary: dict[str, Any]) -> str:
    lines = [
        f"file      {summary['file']}"
        + ("  [TRUNCATED: read up to its last complete chunk]" if summary["file_truncated"] else ""),
        f"env       {summary['env']}",
        f"vehicles  {len(summary['vehicles'])}: {', '.join(summary['vehicles'])}",
        f"duration  {summary['duration_s']:.3f} s ({summary['steps']} steps)",
        f"seed      {summary['seed'] if summary['seed'] is not None else '(none: RNG state recorded)'}",
        f"return    {summary['return']:.6g}",
    ]
    if summary["end"] is None:
        lines.append("end       (not recorded: the file ends before the episode did)")
    else:
        lines.append(f"end       {summary['end']}  success={summary['success']}")
    if summary["reward_terms"]:
        lines.append("reward terms (totals):")
        width = max(len(k) for k in summary["reward_terms"])
        for k, v in summary["reward_terms"].items():
            lines.append(f"  {k:<{width}}  {v:.6g}")
    return "\n".join(lines)


def rebuild_env(episode: Episode, **overrides: Any) -> Any:
    """The recorded episode's environment, built from the file's metadata alone.

    The recorded reward preset is inlined, and the recorded airframe spec is flown when the
    airframe named in the config has changed or is missing.  Nothing is written: the
    recorded spec is validated like any airframe file and handed to the env as it is.
    ``overrides`` go to the env constructor (e.g. ``render_mode``).
    """
    from pyflyt_engine.envs import make_env
    from pyflyt_engine.spec import load_uav_spec, parse_uav_spec

    config = json.loads(json.dumps(episode.config))
    config["reward"] = episode.reward_preset
    recorded_wind = episode.env_info.get("wind")
    if recorded_wind:  # the resolved atmosphere, not a preset name that may have changed since
        try:
            config["wind"] = json.loads(recorded_wind)
        except json.JSONDecodeError:
            raise TelemetryError(f"{episode.path}: the recorded wind config is not valid JSON") from None
    recorded_spec = episode.airframe_spec
    airframe = None
    named = config.get("uav")
    if isinstance(named, str) and named:
        try:
            airframe = load_uav_spec(named)
        except PyFlytError:
            pass
    # order matters (channels, surfaces ...): compare the JSON texts, not the dicts
    if airframe is None or json.dumps(airframe.model_dump(mode="json")) != json.dumps(recorded_spec):
        try:
            airframe = parse_uav_spec(recorded_spec, source=f"{episode.path} (recorded airframe)")
        except PyFlytError as exc:
            raise TelemetryError(
                f"{episode.path}: the recorded airframe spec is invalid for this version: {exc}"
            ) from None
    try:
        return make_env(config, airframe=airframe, **overrides)
    except PyFlytError as exc:
        raise TelemetryError(
            f"{episode.path}: cannot rebuild the environment from the recorded config: {exc}"
        ) from None


@dataclass
class VerifyResult:
    """Outcome of :func:`verify`."""

    steps: int
    max_deviation: float
    #: step of the largest deviation and the state field it was in
    worst_step: int
    worst_field: str
    max_reward_deviation: float
    tolerance: float
    #: per-field largest deviation
    per_field: dict[str, float] = field(default_factory=dict)
    same_versions: bool = True
    version_notes: list[str] = field(default_factory=list)
    diverged_termination: str = ""

    @property
    def ok(self) -> bool:
        return self.max_deviation <= self.tolerance and not self.diverged_termination


def _deviation(name: str, a: np.ndarray, b: np.ndarray) -> float:
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    if a.shape != b.shape:
        return float("inf")
    d = np.abs(a - b)
    if name == "ang_pos":  # wrap angle differences into [0, pi]
        d = np.minimum(d, 2 * np.pi - d)
    d = np.where(np.isnan(d), np.inf, d)
    worst = float(d.max()) if d.size else 0.0
    if name == "quaternion":  # q and -q are the same attitude
        flipped = np.abs(a + b)
        worst = min(worst, float(np.where(np.isnan(flipped), np.inf, flipped).max()))
    return worst


def verify(episode: Episode, tolerance: float = 1e-6) -> VerifyResult:
    """Re-simulate the episode from its metadata and recorded actions; compare every state.

    The environment is rebuilt (:func:`rebuild_env`), reset once (so resets take the same
    restore-snapshot path as in any run), its RNG streams put where the recording found them
    (or reseeded with the recorded seed), reset with the recorded options, and stepped with the
    recorded applied actions.  The deviation is the largest absolute difference over every
    step, vehicle and state field (positions m, velocities m/s, angles rad, aux state).
    """
    env = rebuild_env(episode)
    try:
        if episode.seed is None:
            env.reset(seed=0)
            try:
                env.np_random.bit_generator.state = episode.rng_state["env"]
                env.world.set_rng_state(episode.rng_state["world"])
            except (KeyError, TypeError, ValueError, PyFlytError) as exc:
                raise TelemetryError(f"{episode.path}: the recorded RNG state cannot be restored ({exc})") from None
            env.reset(seed=None, options=episode.options)
        else:
            env.reset(seed=0)
            env.reset(seed=episode.seed, options=episode.options)
        n = episode.length
        per_field = {k: 0.0 for k in (*STATE_FIELDS, "aux", "wind")}
        worst = (0.0, 0, "")
        reward_dev = 0.0
        diverged = ""
        end = episode.end

        def compare(step: int) -> None:
            nonlocal worst
            for i, track in enumerate(episode.vehicles):
                if step >= len(track.time):
                    continue
                vehicle = env.world.vehicles[i]
                s = vehicle.state
                for name in STATE_FIELDS:
                    d = _deviation(name, getattr(s, name), track.states[name][step])
                    per_field[name] = max(per_field[name], d)
                    if d > worst[0]:
                        worst = (d, step, f"uav {i} {name}")
                aux = vehicle.aux_state
                if track.aux.shape[1:] == aux.shape:
                    d = _deviation("aux", aux, track.aux[step])
                else:
                    d = float("inf")
                per_field["aux"] = max(per_field["aux"], d)
                if d > worst[0]:
                    worst = (d, step, f"uav {i} aux")
                if step < len(track.wind):  # the recorded wind, sampled again at the re-simulated position
                    d = _deviation("wind", np.asarray(env.world.wind_at(i)), track.wind[step])
                    per_field["wind"] = max(per_field["wind"], d)
                    if d > worst[0]:
                        worst = (d, step, f"uav {i} wind")

        compare(0)
        for k in range(n):
            _, reward, terminated, truncated, _ = env.step(episode.actions[k])
            if k < len(episode.rewards):
                reward_dev = max(
                    reward_dev,
                    abs(float(reward) - float(episode.rewards[k])) if np.isfinite(episode.rewards[k]) else float("inf"),
                )
            compare(k + 1)
            last = k == n - 1
            if (terminated or truncated) and not last:
                diverged = f"the re-simulated episode ended at step {k + 1}, the recording went on to step {n}"
                break
            if last and end is not None and end.get("event") == "end" and not (terminated or truncated):
                diverged = f"the recording ended ({end.get('reason')}) at step {n}; the re-simulation did not"
        current = package_versions()
        notes = [
            f"{k}: recorded {episode.versions.get(k)!r}, now {current.get(k)!r}"
            for k in ("pyflyt_engine", "pybullet", "numpy", "python", "machine")
            if episode.versions.get(k) != current.get(k)
        ]
        return VerifyResult(
            steps=n,
            max_deviation=worst[0],
            worst_step=worst[1],
            worst_field=worst[2],
            max_reward_deviation=reward_dev,
            tolerance=tolerance,
            per_field=per_field,
            same_versions=not notes,
            version_notes=notes,
            diverged_termination=diverged,
        )
    finally:
        env.close()
