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
from pyflyt_engine.safe_load import json_data
from pyflyt_engine.telemetry.episode import ESTIMATE_FIELDS, STATE_FIELDS, Episode
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
    """The recorded episode's environment, built from the file's content alone.

    A recording is shared data: nothing in it names a file this process opens.  The
    recorded reward preset, atmosphere and airframe specs are flown as they are (validated
    like any config; the agents of a multi-agent env each fly their vehicle's recorded
    spec); an airframe given by its own URDF flies the URDF the recording holds
    (``uav_<i>.urdf``), checked before PyBullet parses it (:func:`pyflyt_engine.urdf.urdf_problem`).
    A mesh obstacle flies the copy of its OBJ file the recording holds, checked against its
    recorded digest and read as any mesh file (:func:`_recorded_meshes`).  A recording whose
    airframes or payloads draw mesh files, or whose config names a wind or randomisation
    file, is refused: it cannot be re-simulated from its content.  Nothing is written but
    the checked URDF and mesh copies, to the private cache.  ``overrides`` go to the env
    constructor (e.g. ``render_mode``).
    """
    from pyflyt_engine.envs import make_env

    config = json.loads(json.dumps(episode.config))
    config["reward"] = episode.reward_preset
    recorded_wind = episode.env_info.get("wind")
    if recorded_wind:  # the resolved atmosphere, not a preset name that may have changed since
        config["wind"] = _wind_as_recorded(
            json_data(recorded_wind, source=f"{episode.path}: metadata 'wind'", error=TelemetryError)
        )
    _check_named_files(episode, config)
    specs = [s if isinstance(s, dict) else {} for s in episode.uav_specs]
    flown = [i for i, s in enumerate(specs) if s == episode.airframe_spec]
    airframe = _recorded_airframe(episode, episode.airframe_spec, flown[0] if flown else 0)
    if "agents" in config:  # each agent's airframe by the name it gives: its vehicle's recorded spec
        from pyflyt_engine.envs.config import MultiAgentEnvConfig, parse_env_config

        try:
            parsed = parse_env_config(config, source=f"{episode.path} (recorded config)")
            assert isinstance(parsed, MultiAgentEnvConfig)  # a config with agents parses as one
            agents = parsed.resolved_agents()
        except PyFlytError as exc:
            raise TelemetryError(
                f"{episode.path}: cannot rebuild the environment from the recorded config: {exc}"
            ) from None
        airframes: dict[str, Any] = {}
        for i, agent in enumerate(agents[: len(specs)]):
            if agent.uav not in airframes:
                airframes[agent.uav] = _recorded_airframe(episode, specs[i], i)
        overrides = {**overrides, "airframes": airframes}
    try:
        return make_env(config, airframe=airframe, **overrides)
    except PyFlytError as exc:
        raise TelemetryError(
            f"{episode.path}: cannot rebuild the environment from the recorded config: {exc}"
        ) from None


def _wind_as_recorded(wind: Any) -> Any:
    """The recorded atmosphere with the defaults of the version that recorded it.

    ``turbulence.rotary_min_span`` (no rotary gusts below that span, default 1 m) came
    later than the first recordings: a recorded turbulence without it flew the rotary
    gusts on every vehicle, which is ``rotary_min_span: 0``.
    """
    if isinstance(wind, dict) and isinstance(wind.get("turbulence"), dict):
        wind["turbulence"].setdefault("rotary_min_span", 0.0)
    return wind


def _cannot_replay(episode: Episode, why: str) -> TelemetryError:
    return TelemetryError(
        f"{episode.path}: {why}; a recording is re-simulated from its own content only, never from files it "
        "names (its summary and --plot still work)"
    )


def _check_named_files(episode: Episode, config: dict[str, Any]) -> None:
    """Refuse a recorded config that names a file (only shipped preset names and inline data may be flown)."""
    from pyflyt_engine.safe_load import plain_name

    wind = config.get("wind")
    base = wind.get("preset") if isinstance(wind, dict) else wind
    if base is not None and not plain_name(base):
        raise _cannot_replay(episode, f"its wind config names {base!r}, not a shipped preset")
    randomize = config.get("randomize")
    if isinstance(randomize, str) and not plain_name(randomize):
        raise _cannot_replay(episode, f"its randomisation names {randomize!r}, not a shipped preset")
    _recorded_meshes(episode, config)
    for payload in config.get("payloads") or []:
        shapes = ((payload.get("body") or {}).get("shapes") or []) if isinstance(payload, dict) else []
        if any(isinstance(s, dict) and s.get("type") == "mesh" for s in shapes):
            raise _cannot_replay(episode, "a payload draws a mesh file, which the recording does not hold")


def _recorded_meshes(episode: Episode, config: dict[str, Any]) -> None:
    """Point every mesh obstacle of the recorded ``config`` at the recording's copy of its file.

    The recording names each mesh file's attachment and the sha256 of its content (``env``
    metadata ``obstacle_meshes``); the copy is used only if it is there and has that digest,
    is read as a Wavefront OBJ by the same checks as a file at load
    (:func:`pyflyt_engine.obstacles.parse_obj`) and names no material library by a path,
    and is written, named by its digest, to the
    private cache (:func:`pyflyt_engine.urdf.cached_file`): the file the config names is never
    opened.
    """
    import hashlib

    from pyflyt_engine.obstacles import parse_obj
    from pyflyt_engine.urdf import cached_file

    obstacles = config.get("obstacles")
    items = (obstacles.get("items") or []) if isinstance(obstacles, dict) else []
    meshes = [o for o in items if isinstance(o, dict) and o.get("type") == "mesh"]
    if not meshes:
        return
    source = f"{episode.path}: metadata 'obstacle_meshes'"
    raw = episode.env_info.get("obstacle_meshes")
    try:
        table = json_data(raw, source=source, error=TelemetryError) if raw is not None else []
    except ValueError as exc:
        raise TelemetryError(f"{source} is not JSON ({exc})") from None
    if not isinstance(table, list) or not all(
        isinstance(e, dict) and all(isinstance(e.get(k), str) for k in ("file", "attachment", "sha256")) for e in table
    ):
        raise TelemetryError(f"{source} is not a list of {{file, attachment, sha256}} entries")
    entries = {e["file"]: e for e in table}
    for item in meshes:
        name = item.get("file")
        entry = entries.get(name) if isinstance(name, str) else None
        if entry is None:
            raise _cannot_replay(
                episode, f"an obstacle draws the mesh file {name!r} and the recording holds no copy of it"
            )
        copies = [a for a in episode.contents.attachments if a.name == entry["attachment"]]
        if not copies:
            raise _cannot_replay(
                episode,
                f"the copy of the obstacle mesh file {name!r} (attachment {entry['attachment']!r}) is missing",
            )
        data = copies[-1].data
        if hashlib.sha256(data).hexdigest() != entry["sha256"]:
            raise TelemetryError(
                f"{episode.path}: the copy of the obstacle mesh file {name!r} (attachment {entry['attachment']!r}) "
                "does not match its recorded sha256: the recording was altered or damaged, and is not re-simulated"
            )
        try:
            parse_obj(data, f"{entry['attachment']} (the recorded copy of {name})")
        except ValueError as exc:
            raise TelemetryError(f"{episode.path}: the recorded obstacle mesh is refused: {exc}") from None
        # PyBullet opens a material library an OBJ names from the OBJ's folder (the private
        # cache, which holds none): a name with a path could reach a file outside it
        for line in data.decode("utf-8", errors="replace").splitlines():
            fields = line.split()
            if fields[:1] == ["mtllib"] and any("/" in f or "\\" in f for f in fields[1:]):
                raise TelemetryError(
                    f"{episode.path}: the recorded obstacle mesh ({entry['attachment']}, the copy of {name!r}) is "
                    f"refused: its {line.strip()!r} names a file by a path, and a file is not part of the recording"
                )
        item["file"] = str(cached_file(data, ".obj"))


def _recorded_airframe(episode: Episode, recorded: dict[str, Any], index: int) -> Any:
    """A recorded airframe spec (vehicle ``index``'s), validated; its own URDF, if it names one,
    swapped for the recording's checked copy (``uav_<index>.urdf``)."""
    from pyflyt_engine.spec import parse_uav_spec
    from pyflyt_engine.urdf import cached_urdf, urdf_problem

    spec = json.loads(json.dumps(recorded))
    body = spec.get("body")
    if isinstance(body, dict):  # otherwise the spec's validation says what is wrong
        shapes = body["shapes"] if isinstance(body.get("shapes"), list) else []
        if body.get("urdf") is None:
            if any(isinstance(s, dict) and s.get("type") == "mesh" for s in shapes):
                raise _cannot_replay(episode, "its airframe draws mesh files, which the recording does not hold")
        else:
            name = f"uav_{index}.urdf"
            copies = [a for a in episode.contents.attachments if a.name == name]
            if not copies:
                raise _cannot_replay(
                    episode, f"its airframe names the URDF file {body['urdf']!r} and the recording holds no copy"
                )
            refused = f"{episode.path}: the recorded URDF ({name}) is refused"
            try:
                text = copies[-1].data.decode("utf-8")
            except UnicodeDecodeError:
                raise TelemetryError(f"{refused}: it is not UTF-8 text") from None
            problem = urdf_problem(text)
            if problem is not None:
                raise TelemetryError(f"{refused}: {problem}")
            body["urdf"] = str(cached_urdf(text))
    try:
        return parse_uav_spec(spec, source=f"{episode.path} (recorded airframe)")
    except PyFlytError as exc:
        raise TelemetryError(f"{episode.path}: the recorded airframe spec is invalid for this version: {exc}") from None


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
    #: what the recording says of the outcome that the re-simulation does not reproduce: the
    #: return, termination, truncation, end reason, success (each a sentence; empty: all agree)
    outcome_differences: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """Every state and every reward within the tolerance (a NaN counts as differing), the
        episode ends where and as the recording says, with the same return and success."""
        return (
            self.max_deviation <= self.tolerance
            and self.max_reward_deviation <= self.tolerance
            and not self.diverged_termination
            and not self.outcome_differences
        )


def _differs(recorded: Any, resimulated: float, tolerance: float) -> bool:
    """Whether a recorded number differs from the re-simulated one by more than ``tolerance``
    (a value that is not a finite number always differs)."""
    try:
        value = float(recorded)
    except (TypeError, ValueError):
        return True
    return not (np.isfinite(value) and abs(value - resimulated) <= tolerance)


def outcome_differences(
    episode: Episode, rewards: list[float], terminated: bool, truncated: bool, info: dict[str, Any], tolerance: float
) -> list[str]:
    """What the recording claims of the episode's outcome that the re-simulation (its ``rewards``,
    last flags and info) does not give: the return (the recorded rewards' sum, and the end event's),
    within ``tolerance`` per step; the end event's terminated, truncated, reason and success."""
    from pyflyt_engine.telemetry.recorder import end_reason

    out: list[str] = []
    total = 0.0
    for reward in rewards:  # in the recorder's order (a running sum), so equal rewards give an equal sum
        total += reward
    allowed = tolerance * max(1, len(rewards))
    recorded_sum = 0.0
    for reward in episode.rewards[: len(rewards)]:
        recorded_sum += float(reward)
    if _differs(recorded_sum, total, allowed):
        out.append(f"the recorded rewards sum to {recorded_sum:.6g}, the re-simulated ones to {total:.6g}")
    end = episode.end
    if end is None or end.get("event") != "end":
        return out
    if "return" in end and _differs(end.get("return"), total, allowed):
        out.append(f"the recording's end event gives the return {end.get('return')!r}, the re-simulation {total:.6g}")
    for name, value in (("terminated", terminated), ("truncated", truncated)):
        if name in end and end.get(name) is not bool(value):
            out.append(
                f"the recording's end event says {name}={end.get(name)!r}, the re-simulation {name}={bool(value)}"
            )
    reason = end_reason(terminated, truncated, info)
    if "reason" in end and end.get("reason") != reason:
        out.append(f"the recording's end event gives the reason {end.get('reason')!r}, the re-simulation {reason!r}")
    success = bool(info.get("success", False))
    if "success" in end and end.get("success") is not success:
        out.append(
            f"the recording's end event says success={end.get('success')!r}, the re-simulation success={success}"
        )
    return out


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
        per_field = {k: 0.0 for k in (*STATE_FIELDS, "aux", "wind", "sensors")}
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
                if step < len(track.sensors):  # the noisy sensors' readings (components/sensors.py)
                    values = np.asarray(vehicle.sensors.values() if vehicle.sensors is not None else [])
                    same = values.shape == track.sensors[step].shape
                    d = _deviation("sensors", values, track.sensors[step]) if same else float("inf")
                    per_field["sensors"] = max(per_field["sensors"], d)
                    if d > worst[0]:
                        worst = (d, step, f"uav {i} sensors")
                if track.estimate and step < len(track.estimate["lin_pos"]):  # the state estimate
                    est = vehicle.sensors.estimator if vehicle.sensors is not None else None
                    values = np.asarray(est.values() if est is not None else [])
                    recorded = np.concatenate([track.estimate[k][step] for k in ESTIMATE_FIELDS])
                    same = values.shape == recorded.shape
                    d = _deviation("estimate", values, recorded) if same else float("inf")
                    per_field["estimate"] = max(per_field.get("estimate", 0.0), d)
                    if d > worst[0]:
                        worst = (d, step, f"uav {i} estimate")

        compare(0)
        rewards: list[float] = []
        terminated = truncated = False
        info: dict[str, Any] = {}
        for k in range(n):
            _, reward, terminated, truncated, info = env.step(episode.actions[k])
            if k < len(episode.rewards):
                rewards.append(float(reward))
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
            outcome_differences=[]
            if diverged
            else outcome_differences(
                episode, rewards, bool(terminated), bool(truncated), info if isinstance(info, dict) else {}, tolerance
            ),
        )
    finally:
        env.close()
