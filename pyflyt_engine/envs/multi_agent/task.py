"""The multi-agent task interface moved to :mod:`pyflyt_engine.envs.tasks.multi`, beside the
tasks; this module keeps the old import path working."""

from __future__ import annotations

from pyflyt_engine.envs.tasks.multi import MA_TASK_CLASSES, AgentSignals, MultiAgentTask, register_ma_task

__all__ = ["MA_TASK_CLASSES", "AgentSignals", "MultiAgentTask", "register_ma_task"]
