"""`pyflyt replay --verify` checks what it prints: a recording whose rewards, return, termination, end
reason or success differ from the re-simulation fails (exit 1) and says which, NaN counting as differing.

Written from the reproduction: every ``/reward`` raised by 100 and the end event set to ``success: true``
gave "verify OK ... largest reward deviation 100" and exit 0; NaN rewards gave "deviation inf", OK.
"""

from __future__ import annotations

import math

import pytest
from typer.testing import CliRunner

from pyflyt_cli.main import app
from pyflyt_engine.telemetry import load_episode
from tests.telemetry.conftest import record, rewrite_mcap

runner = CliRunner()


@pytest.fixture(scope="module")
def ended(tmp_path_factory):
    """A recorded QuadX-Hover episode that ends (an end event with terminated, reason, success, return)."""
    folder = tmp_path_factory.mktemp("ended")
    env, _ = record("PyFlyt/QuadX-Hover-v0", folder, episodes=1, max_steps=2000, seed=3)
    path = env.paths[0]
    end = load_episode(path).end
    assert end is not None and end["event"] == "end" and end["success"] is False, end
    return path


def verify(path, *extra: str):
    result = runner.invoke(app, ["replay", str(path), "--verify", *extra])
    assert "Traceback" not in result.output and (result.exception is None or isinstance(result.exception, SystemExit))
    return result


def forged(source, tmp_path, change):
    out = tmp_path / "forged.mcap"
    rewrite_mcap(source, out, change)
    return out


def test_an_unaltered_recording_verifies(ended, tmp_path):
    same = forged(ended, tmp_path, lambda topic, data: None)
    result = verify(same, "--tolerance", "0")
    assert result.exit_code == 0, result.output
    assert "verify    OK" in result.output and "largest reward deviation 0" in result.output


def test_rewards_raised_and_success_forged_fail(ended, tmp_path):
    """The reproduction: +100 on every reward (and the running return), success set true."""

    def forge(topic, data):
        if topic == "/reward":
            return {**data, "reward": data["reward"] + 100.0, "return": data["return"] + 100.0 * (data["step"] + 1)}
        if topic == "/episode" and data.get("event") == "end":
            return {**data, "success": True, "return": data["return"] + 100.0 * data["length"]}
        return None

    result = verify(forged(ended, tmp_path, forge))
    assert result.exit_code == 1, result.output
    assert "verify    FAILED" in result.output
    assert "the recorded rewards differ from the re-simulated ones by up to 100" in result.output
    assert "the recorded rewards sum to" in result.output
    assert "says success=True, the re-simulation success=False" in result.output
    assert "end event gives the return" in result.output


def test_a_non_finite_reward_fails(ended, tmp_path):
    """A recorder writes null for a value that is not finite: that reward differs from any re-simulated one."""

    def forge(topic, data):
        return {**data, "reward": None} if topic == "/reward" and data["step"] == 2 else None

    result = verify(forged(ended, tmp_path, forge))
    assert result.exit_code == 1, result.output
    assert "verify    FAILED" in result.output and "NaN or inf counts as differing" in result.output


@pytest.mark.parametrize("bad, name", [(math.nan, "NaN"), (math.inf, "Infinity"), (-math.inf, "-Infinity")])
def test_a_reward_written_as_nan_or_infinity_is_refused_as_not_json(ended, tmp_path, bad, name):
    """NaN and Infinity are not JSON (Python's reader takes them, no recorder writes them): refused at reading."""

    def forge(topic, data):
        return {**data, "reward": bad} if topic == "/reward" and data["step"] == 2 else None

    result = verify(forged(ended, tmp_path, forge))
    assert result.exit_code == 2, result.output
    assert f"a message on /reward: holds {name}, which is not a JSON number" in result.output


@pytest.mark.parametrize(
    "field, value, says",
    [
        ("success", True, "success=True"),
        ("terminated", False, "terminated=False"),
        ("truncated", True, "truncated=True"),
        ("reason", "complete", "the reason 'complete'"),
        ("return", 1e6, "the return 1000000.0"),
        ("return", None, "the return None"),  # what a recorder writes for a return that is not finite
    ],
)
def test_a_forged_end_event_alone_fails_and_says_which(ended, tmp_path, field, value, says):
    end = load_episode(ended).end
    if field in ("terminated", "truncated") and end[field] == value:
        value = not value
        says = f"{field}={value}"

    def forge(topic, data):
        return {**data, field: value} if topic == "/episode" and data.get("event") == "end" else None

    result = verify(forged(ended, tmp_path, forge), "--json")
    assert result.exit_code == 1, result.output
    import json

    report = json.loads(result.output)["verify"]
    assert report["ok"] is False and report["max_deviation"] == 0.0 and report["max_reward_deviation"] == 0.0
    assert any(says in line for line in report["outcome_differences"]), report["outcome_differences"]
