"""The one table of algorithms (``pyflyt_cli.training.registry.ALGORITHMS``) tells the truth."""

from __future__ import annotations

import typing

import pytest

from pyflyt_cli.training import registry
from pyflyt_cli.training.schema import AlgoConfig, _algo_model
from pyflyt_engine.paths import conf_dir


@pytest.mark.parametrize("name", sorted(registry.ALGORITHMS))
def test_each_row_matches_its_class_config_model_and_defaults(name):
    from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm

    row = registry.ALGORITHMS[name]
    cls = registry.resolve(registry.ALGOS, name, "algorithm")
    assert issubclass(cls, OffPolicyAlgorithm) == row.off_policy
    model = _algo_model(name)
    assert typing.get_args(model.model_fields["name"].annotation) == (name,)
    assert (conf_dir() / "algo" / f"{name}.yaml").is_file()
    assert row.policies <= set(cls.policy_aliases)
    assert row.init_from <= set(registry.ALGORITHMS) - {name}


def test_the_config_union_and_the_views_come_from_the_table():
    members = typing.get_args(typing.get_args(AlgoConfig)[0])
    assert [m.__name__ for m in members] == [a.config for a in registry.ALGORITHMS.values()]
    assert set(registry.ALGOS) == set(registry.ALGORITHMS)
    assert registry.OFF_POLICY == {"sac", "td3", "ddpg", "awac", "ccge", "tqc", "crossq"}
    assert registry.INIT_FROM == {"awac": {"sac"}, "ccge": {"sac"}}
