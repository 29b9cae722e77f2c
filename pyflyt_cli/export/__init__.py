"""Export a trained policy for a flight controller: ONNX, or C99 for a microcontroller.

:func:`export_policy` reads a run directory (or a shipped agent, ``zoo:<name>``), lays out
its deterministic policy from the raw observation to the action the env receives
(:func:`.policy.deployed_policy`: the observation normaliser, the actor, the squashing or
clipping, the rescaling to the env's action bounds) and writes it:

* ``format="onnx"``: one ``.onnx`` file (:mod:`.onnx_model`, ``torch.onnx.export``);
* ``format="c"``: ``<name>.c`` and ``<name>.h`` (:mod:`.c_source`): float32 weights and
  ``void policy_forward(const float *obs, float *action)``.

An existing output file is replaced only with ``force``; every file is written to a
temporary name and renamed into place.  ``docs/deploy.md`` describes the interface.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pyflyt_cli.export.policy import ExportError

#: ``format=`` -> the suffix of ``out=``
FORMATS = {"onnx": ".onnx", "c": ".c"}
#: ``model=`` choices (as ``pyflyt eval``)
MODELS = ("auto", "best", "final", "latest")
#: the file names ``format=c`` writes (the source names its header in ``#include "..."``)
C_FILE_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]*")
#: probe observations the ONNX file is checked on after writing
PROBES = 256


@dataclass(frozen=True)
class ExportResult:
    """What :func:`export_policy` wrote."""

    format: str
    #: the files written (ONNX: one; C: source, header)
    files: list[Path]
    #: the exported policy's description (run, env, action, steps): :attr:`.policy.DeployedPolicy.about`
    about: dict[str, Any]
    #: ONNX: the largest difference between onnxruntime's actions and the PyTorch chain's on
    #: :data:`PROBES` probe observations (None without onnxruntime, and for C)
    check: float | None = None


def output_files(fmt: str, out: str | Path | None) -> list[Path]:
    """The files ``format=fmt out=out`` writes (checked: suffix, folder), before anything is read."""
    if fmt not in FORMATS:
        raise ExportError(f"unknown format {fmt!r}: write format=onnx or format=c")
    suffix = FORMATS[fmt]
    path = Path(out).expanduser() if out is not None else Path(f"policy{suffix}")
    if path.suffix.lower() != suffix:
        raise ExportError(f"out={path}: format={fmt} writes a file ending in {suffix} (e.g. out=policy{suffix})")
    if any(c in path.name for c in '"\\\n'):
        raise ExportError(f"out={path}: the file name may not hold quotes, backslashes or line breaks")
    if fmt == "c" and not C_FILE_NAME.fullmatch(path.name):
        # the header's name is written into the source (#include "<name>.h"): letters, digits, '_', '-', '.' only
        raise ExportError(
            f"out={path}: a C file name is made of letters, digits, '_', '-' and '.' only (e.g. out=policy.c)"
        )
    files = [path] if fmt == "onnx" else [path, path.with_suffix(".h")]
    for file in files:
        if file.is_dir():
            raise ExportError(f"out={path}: {file} is a directory; give a file name ending in {suffix}")
    if not path.parent.is_dir():
        raise ExportError(f"out={path}: the directory {path.parent} does not exist; create it first")
    return files


def export_policy(
    source: str | Path, fmt: str, out: str | Path | None = None, *, model: str = "auto", force: bool = False
) -> ExportResult:
    """Export the deterministic policy of ``source`` (a run directory or ``zoo:<name>``).

    Args:
        source: a run directory written by ``pyflyt train``, or ``zoo:<name>``.
        fmt: ``onnx`` or ``c``.
        out: the ``.onnx`` file, or the ``.c`` file (the header goes beside it, ``.h``);
            default ``policy.onnx`` / ``policy.c`` in the working directory.
        model: which policy file of the run (``auto``: best, else final, else latest).
        force: replace output files that exist (never otherwise).

    Raises:
        ExportError: a bad argument, an output that exists (without ``force``), or a policy
            that cannot be exported (recurrent, image observations, an unknown layer).
        RunDirError, ArtifactError: a missing or unreadable run.
    """
    files = output_files(fmt, out)
    if model not in MODELS:
        raise ExportError(f"unknown model {model!r}: write model={' | '.join(MODELS)}")
    existing = [f for f in files if f.exists() or f.is_symlink()]
    if existing and not force:
        raise ExportError(
            f"{' and '.join(str(f) for f in existing)} {'exists' if len(existing) == 1 else 'exist'}: pass --force "
            "to replace, or choose another out="
        )
    from pyflyt_cli.export.policy import deployed_policy

    policy = deployed_policy(source, model)
    check = None
    if fmt == "onnx":
        from pyflyt_cli.export.onnx_model import write_onnx

        write_onnx(policy, files[0])
        check = _check_onnx(policy, files[0])
    else:
        from pyflyt_cli.export.c_source import write_c

        write_c(policy, files[0], files[1])
    return ExportResult(fmt, files, policy.about, check)


def probe_observations(policy: Any, count: int = PROBES, seed: int = 0) -> Any:
    """``count`` observations spread like the training's (the normaliser's mean ± 2 std, where there is
    one; else standard normal), for checking an exported file against the PyTorch chain."""
    import numpy as np

    rng = np.random.default_rng(seed)
    z = rng.normal(size=(count, policy.obs_dim))
    from pyflyt_cli.export.policy import Standardize

    first = policy.network[0]
    if isinstance(first, Standardize):
        return (first.mean.numpy() + 2.0 * z * first.std.numpy()).astype(np.float32)
    return z.astype(np.float32)


def _check_onnx(policy: Any, path: Path) -> float | None:
    import importlib.util

    if importlib.util.find_spec("onnxruntime") is None:
        return None
    import numpy as np

    from pyflyt_cli.export.onnx_model import run_onnx

    obs = probe_observations(policy)
    return float(np.max(np.abs(run_onnx(path, obs) - policy.forward(obs))))


__all__ = ["FORMATS", "PROBES", "ExportError", "ExportResult", "export_policy", "output_files", "probe_observations"]
