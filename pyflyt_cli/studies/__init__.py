"""Measuring code the learning studies under ``experiments/`` share (``.[rl]``).

``experiments/learn_*.py`` train the shipped tunings and measure them by what the task asks
(waypoints reached, a hover held, a goal reached without contact), not by the return:
:mod:`~pyflyt_cli.studies.probes` (probe functions and the callbacks that fly them during
training), :mod:`~pyflyt_cli.studies.runs` (a seed's run with its probe, a finished run's
checkpoints) and :mod:`~pyflyt_cli.studies.report` (IQM tables and curves).  The scripts
import these from the library, never from each other.
"""
