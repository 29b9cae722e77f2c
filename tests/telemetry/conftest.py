"""Helpers for the telemetry tests: record short episodes, rewrite MCAP files, validate schemas."""

from __future__ import annotations

import json
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium
import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.writer import Writer

import pyflyt_engine  # noqa: F401  (registers the ids)
from pyflyt_engine.envs import ENVS
from pyflyt_engine.telemetry import RecordEpisode

ENV_IDS = list(ENVS)


def make_env(env_id: str, **kwargs: Any) -> gymnasium.Env:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return gymnasium.make(env_id, **kwargs)


def policy(env: gymnasium.Env, rng: np.random.Generator) -> np.ndarray:
    """Random actions around hover for multirotors (so episodes last), uniform otherwise."""
    space = env.action_space
    a = rng.uniform(space.low, space.high)
    base = env.unwrapped
    if base.config.action.names[-1:] == ["thrust"] and base.config.action.mode == "rates_thrust":
        a[:3] *= 0.15
        a[3] = 0.13 + 0.02 * rng.standard_normal()
    return a


def hover_action(state: Any) -> np.ndarray:
    """A rates_thrust action holding a QuadX level at 1 m (it drifts sideways slowly)."""
    roll, pitch, _ = state.ang_pos
    p, q, r = state.ang_vel
    z, vz = state.lin_pos[2], state.lin_vel_ground[2]
    return np.array([-2 * roll - 0.3 * p, -2 * pitch - 0.3 * q, -r, 0.125 + 0.1 * (1 - z) - 0.05 * vz])


def record(
    env_id: str, directory: Path, episodes: int = 1, max_steps: int = 120, seed: int | None = 0, **kwargs: Any
) -> tuple[RecordEpisode, list[list[Any]]]:
    """Record ``episodes`` episodes (the first reset seeded, the rest continuing the RNG);
    returns the wrapper and, per episode, the env's (state, aux) after the reset and each step."""
    env = RecordEpisode(make_env(env_id), directory, **kwargs)
    rng = np.random.default_rng(123)
    seen = []
    for ep in range(episodes):
        env.reset(seed=seed if ep == 0 else None)
        base = env.unwrapped
        states = [[(v.state, v.aux_state.copy()) for v in base.world.vehicles]]
        for _ in range(max_steps):
            _, _, terminated, truncated, _ = env.step(policy(env, rng))
            states.append([(v.state, v.aux_state.copy()) for v in base.world.vehicles])
            if terminated or truncated:
                break
        seen.append(states)
    env.close()
    return env, seen


def iter_official(path: Path):
    """(schema, channel, message) of a file through the official reader, CRCs validated."""
    with open(path, "rb") as f:
        reader = make_reader(f, validate_crcs=True)
        yield from reader.iter_messages(log_time_order=False)


def chunk_spans(path: Path) -> list[tuple[int, int]]:
    """(start offset, length) of each chunk record of a complete file, from its summary."""
    with open(path, "rb") as f:
        indexes = make_reader(f).get_summary().chunk_indexes
    return [(c.chunk_start_offset, c.chunk_length) for c in indexes]


def flip_byte(path: Path, offset: int) -> None:
    """Damage ``path`` in place: change one bit of the byte at ``offset``."""
    data = bytearray(path.read_bytes())
    data[offset] ^= 0x10
    path.write_bytes(bytes(data))


def rewrite_mcap(
    src: Path,
    dst: Path,
    transform: Callable[[str, dict], dict | bytes | None],
    metadata: Callable[[str, dict[str, str]], dict[str, str]] | None = None,
    attachments: Callable[[str, bytes], bytes] | None = None,
) -> None:
    """Copy ``src`` to ``dst`` (a new file) passing every JSON message through ``transform(topic, data)``
    (a dict: the new message; bytes: its raw payload; None: unchanged),
    every metadata record through ``metadata(name, record)`` and every attachment's bytes through
    ``attachments(name, data)``."""
    with open(src, "rb") as f:
        reader = make_reader(f, validate_crcs=True)
        summary = reader.get_summary()
        records = list(reader.iter_metadata())
        stored = list(reader.iter_attachments())
        messages = list(reader.iter_messages(log_time_order=False))
    with open(dst, "xb") as out:
        writer = Writer(out)
        writer.start()
        for m in records:
            writer.add_metadata(m.name, metadata(m.name, dict(m.metadata)) if metadata else m.metadata)
        for a in stored:
            data = attachments(a.name, a.data) if attachments else a.data
            writer.add_attachment(a.create_time, a.log_time, a.name, a.media_type, data)
        schema_ids = {sid: writer.register_schema(s.name, s.encoding, s.data) for sid, s in summary.schemas.items()}
        channel_ids = {
            cid: writer.register_channel(c.topic, c.message_encoding, schema_ids[c.schema_id], c.metadata)
            for cid, c in summary.channels.items()
        }
        for _, channel, message in messages:
            data = transform(channel.topic, json.loads(message.data))
            payload = (
                data if isinstance(data, bytes) else json.dumps(data).encode() if data is not None else message.data
            )
            writer.add_message(
                channel_ids[channel.id], message.log_time, payload, message.publish_time, message.sequence
            )
        writer.finish()


@pytest.fixture(scope="module")
def recorded(tmp_path_factory) -> dict[str, Path]:
    """One recorded episode (seeded reset) per registered env id."""
    out = {}
    for env_id in ENV_IDS:
        folder = tmp_path_factory.mktemp(env_id.replace("/", "_"))
        env, _ = record(env_id, folder, episodes=1, max_steps=90, seed=5)
        out[env_id] = env.paths[0]
    return out
