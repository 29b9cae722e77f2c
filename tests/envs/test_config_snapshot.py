"""Every shipped env config resolves to the recorded config, both ways it is loaded.

``data/resolved_env_configs.json`` holds, for every env config of ``conf/env``:

* ``engine``: the :class:`~pyflyt_engine.envs.config.EnvConfig` the engine builds from the name
  (``make_env`` / ``gymnasium.make``: the loader's ``defaults`` resolution, the model's
  defaults filled in), as ``model_dump(mode="json")``;
* ``hydra``: the ``env`` section ``pyflyt train env=<name> algo=<algo>`` composes (Hydra's own
  ``defaults`` resolution, before validation: exactly the keys the files give), for the
  default algorithm (``ppo``, ``pyflyt train env=<name>``), for ``a2c`` (no tuning of any env)
  and for every algorithm with a tuning of that env in ``conf/hparams``.

It was recorded while every shipped file still restated every key, before they were
rewritten as deltas of the shared bases (``conf/env/_*.yaml``), so equality here is the
proof that the rewrite changed no env.  Key order is not compared: the engine validates
into a model and a run's digest is taken with sorted keys
(``pyflyt_cli.training.rundir.config_digest``).  Regenerate (only for a deliberate change
of what a shipped env is) with ``python -m tests.envs.test_config_snapshot``.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from pyflyt_engine.loading import available
from pyflyt_engine.paths import conf_dir

SNAPSHOT = Path(__file__).parent / "data" / "resolved_env_configs.json"


def _algos(name: str) -> list[str]:
    """The algorithms an env's composition is recorded for: the default, one without tuning, its tunings."""
    tuned = {p.stem.removeprefix(f"{name}_") for p in (conf_dir() / "hparams").glob(f"{name}_*.yaml")}
    tuned = {
        a for a in tuned if (conf_dir() / "algo" / f"{a}.yaml").is_file()
    }  # not another env's (quadx_gates_state_ppo)
    return sorted({"ppo", "a2c"} | tuned)


def _plain(value: Any) -> Any:
    """``value`` as JSON reads it back (tuples as lists), so a recorded and a fresh one compare equal."""
    return json.loads(json.dumps(value))


def resolved(name: str) -> dict[str, Any]:
    """{"engine": the EnvConfig dump, "hydra": {algo: the composed env section}} of one shipped env config."""
    from pyflyt_cli.training.compose import compose_train_data
    from pyflyt_engine.envs.config import load_env_config

    engine = load_env_config(name).model_dump(mode="json", exclude={"source"})
    hydra = {algo: compose_train_data([f"env={name}", f"algo={algo}"])[0]["env"] for algo in _algos(name)}
    return _plain({"engine": engine, "hydra": hydra})


RECORDED = json.loads(SNAPSHOT.read_text()) if SNAPSHOT.is_file() else {}


def test_the_snapshot_covers_every_shipped_env_config():
    assert sorted(RECORDED) == available("env")


@pytest.mark.parametrize("name", available("env"))
def test_a_shipped_env_config_resolves_as_recorded(name):
    fresh, recorded = resolved(name), RECORDED[name]
    assert sorted(fresh["hydra"]) == sorted(recorded["hydra"])
    assert fresh["engine"] == recorded["engine"]
    for algo, env in recorded["hydra"].items():
        assert fresh["hydra"][algo] == env, algo


if __name__ == "__main__":
    SNAPSHOT.parent.mkdir(exist_ok=True)
    SNAPSHOT.write_text(
        json.dumps({name: resolved(name) for name in available("env")}, indent=1, sort_keys=True) + "\n"
    )
    print(f"wrote {SNAPSHOT}")
