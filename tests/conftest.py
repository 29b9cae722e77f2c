"""Shared fixtures: small worlds and spec variants built from the shipped airframes; hostile-input helpers."""

from __future__ import annotations

import copy
import gc
import os
import resource

import pytest
import yaml

from pyflyt_engine.paths import uav_dir
from pyflyt_engine.spec import UAVSpec, parse_uav_spec


@pytest.fixture(autouse=True, scope="session")
def _sb3_logs_in_the_test_folder(tmp_path_factory):
    """A model a test builds with SB3 directly (not through the training library, which gives
    it a logger without a folder) makes an empty ``SB3-<date>`` folder at every ``learn()``:
    in one folder of the session's temporary tree (``SB3_LOGDIR``), not the system's."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("SB3_LOGDIR", str(tmp_path_factory.mktemp("sb3-logs")))
        yield


@pytest.fixture(autouse=True, scope="module")
def _unreferenced_worlds_disconnected():
    """After each test module, collect what it left unreferenced: an env a test built and did
    not close is freed, and its world's ``__del__`` disconnects its PyBullet client.  Without
    it, envs held in reference cycles wait for the cyclic collector, and a worker process of
    the suite can reach PyBullet's limit of simultaneous clients, after which every new
    world's connection fails ("Not connected to physics server")."""
    yield
    gc.collect()


def default_subset(values, keep) -> list:
    """``values`` as the parameters of a test family: the ones ``keep(value)`` accepts run in
    the default suite, the others are marked ``long`` (CI runs them after it: ``pytest -m
    long``).  A tuple value is a tuple of arguments."""
    out = []
    for value in values:
        args = value if isinstance(value, tuple) else (value,)
        out.append(pytest.param(*args) if keep(value) else pytest.param(*args, marks=pytest.mark.long))
    return out


def pyflyt_forked(args: list[str], timeout: float = 120, memory: int = 2 << 30) -> tuple[int, str]:
    """``pyflyt <args>`` (in-process CLI) in a forked child: (exit code, output).

    For input built to hang, exhaust memory or crash the process: the child may grow by
    ``memory`` bytes at most, and a child that does not answer within ``timeout`` seconds
    (a hang detector only: the commands tested answer in well under a second) or dies
    (an abort) fails the test.  Forking skips the seconds a new interpreter spends on imports.
    """
    import multiprocessing

    from typer.testing import CliRunner

    from pyflyt_cli.main import app

    context = multiprocessing.get_context("fork")
    receive, send = context.Pipe(duplex=False)

    def target() -> None:
        if os.path.exists("/proc/self/statm"):
            with open("/proc/self/statm") as statm:  # the address space in use now, in pages
                used = int(statm.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
            resource.setrlimit(resource.RLIMIT_AS, (used + memory, used + memory))
        result = CliRunner().invoke(app, args)
        send.send(
            (
                result.exit_code,
                result.output
                + (
                    ""
                    if result.exception is None or isinstance(result.exception, SystemExit)
                    else f"\nTraceback (in the child): {result.exception!r}"
                ),
            )
        )

    child = context.Process(target=target)
    child.start()
    send.close()
    try:
        if not receive.poll(timeout):
            pytest.fail(f"pyflyt {' '.join(args)} did not answer within {timeout} s (it hangs)")
        try:
            return receive.recv()
        except EOFError:
            child.join()
            pytest.fail(f"pyflyt {' '.join(args)} crashed (exit code {child.exitcode})")
    finally:
        child.kill()
        child.join()


def billion_laughs(levels: int = 9, key: str = "a") -> str:
    """A few hundred bytes of YAML whose aliases expand to 10**levels values (``<key><levels-1>`` holds them all)."""
    lines = [f"{key}0: &{key}0 [lol, lol, lol, lol, lol, lol, lol, lol, lol, lol]"]
    for i in range(1, levels):
        lines.append(f"{key}{i}: &{key}{i} [" + ", ".join([f"*{key}{i - 1}"] * 10) + "]")
    return "\n".join(lines) + "\n"


def spec_dict(name: str = "quadx_cf2x") -> dict:
    """The raw YAML mapping of a shipped airframe (a fresh copy)."""
    return copy.deepcopy(yaml.safe_load((uav_dir() / f"{name}.yaml").read_text()))


def spec_variant(name: str = "quadx_cf2x", **changes: object) -> UAVSpec:
    """A shipped airframe with dotted-path changes, e.g. ``**{"motors.noise_ratio": 0.0}``."""
    data = spec_dict(name)
    for path, value in changes.items():
        node = data
        *parents, leaf = path.split(".")
        for key in parents:
            node = node.setdefault(key, {})
        node[leaf] = value
    return parse_uav_spec(data, source=f"{name} (test variant)")


@pytest.fixture
def quiet_cf2x() -> UAVSpec:
    """The cf2x with motor noise and drag removed: for analytic oracles."""
    return spec_variant(
        "quadx_cf2x",
        **{"motors.noise_ratio": 0.0, "drag.coefficients": [0.0, 0.0, 0.0], "drag.angular_damping": 0.0},
    )
