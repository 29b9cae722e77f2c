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


def test_the_config_union_and_the_views_agree_with_the_table():
    # the union is spelled out (for the type checker): it must list the table's models, in its order
    members = typing.get_args(typing.get_args(AlgoConfig)[0])
    assert [m.__name__ for m in members] == [a.config for a in registry.ALGORITHMS.values()]
    assert list(members) == [_algo_model(name) for name in registry.ALGORITHMS]
    assert set(registry.ALGOS) == set(registry.ALGORITHMS)
    assert registry.OFF_POLICY == {"sac", "sac_jax", "td3", "ddpg", "awac", "ccge", "tqc", "crossq"}
    assert registry.INIT_FROM == {"awac": {"sac"}, "ccge": {"sac"}}
    assert registry.SPECIFIC_POLICY_KEYS["n_quantiles"] == {"tqc"}
    assert registry.SPECIFIC_POLICY_KEYS["shared_lstm"] == {"recurrent_ppo"}


def test_the_policy_keys_only_some_algorithms_take_are_refused_for_the_others():
    from pyflyt_cli.training.schema import PolicyConfig

    assert set(registry.SPECIFIC_POLICY_KEYS) <= set(PolicyConfig.model_fields)
    with pytest.raises(ValueError, match="policy_kwargs.n_quantiles applies to tqc only, not sac"):
        _algo_model("sac").model_validate(
            {**_defaults("sac"), "policy_kwargs": {**_defaults("sac")["policy_kwargs"], "n_quantiles": 5}}
        )


def _defaults(name):
    from pyflyt_engine.safe_load import load_yaml_file

    return load_yaml_file(conf_dir() / "algo" / f"{name}.yaml")
