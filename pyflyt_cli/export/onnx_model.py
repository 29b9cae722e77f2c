"""A :class:`~pyflyt_cli.export.policy.DeployedPolicy` as an ONNX file (``torch.onnx.export``).

One input ``observation`` (float32, ``[batch, obs_dim]``) and one output ``action``
(float32, ``[batch, act_dim]``); the batch size is free.  The file's metadata
(``metadata_props``) holds the run, the env, the action names, units and bounds and the
steps of the chain (JSON under ``pyflyt``).  Needs the ``[export]`` extra (``onnx``,
``onnxscript``; ``onnxruntime`` to run it).
"""

from __future__ import annotations

import contextlib
import io
import json
import logging
import warnings
from pathlib import Path

import numpy as np
import torch

from pyflyt_cli.export.policy import DeployedPolicy, ExportError

INPUT, OUTPUT = "observation", "action"


def _need(module: str) -> None:
    import importlib.util

    if importlib.util.find_spec(module) is None:
        raise ExportError(f"format=onnx needs {module}: pip install 'pyflyt-toolkit[export]'")


def write_onnx(policy: DeployedPolicy, path: Path) -> None:
    """Export the chain with PyTorch's ONNX exporter and write it to ``path`` (through a temporary file)."""
    _need("onnx")
    _need("onnxscript")
    import onnx

    from pyflyt_cli.outputs import atomic_output

    example = torch.zeros((2, policy.obs_dim), dtype=torch.float32)
    batch = torch.export.Dim("batch")
    quiet = logging.getLogger("torch.onnx")
    level = quiet.level
    quiet.setLevel(logging.ERROR)
    try:
        with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()):
            warnings.simplefilter("ignore")
            program = torch.onnx.export(
                policy.network,
                (example,),
                dynamo=True,
                verbose=False,
                input_names=[INPUT],
                output_names=[OUTPUT],
                dynamic_shapes=({0: batch},),
                external_data=False,
            )
    except Exception as exc:  # noqa: BLE001 - any failure of the exporter is reported, not raised
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ExportError(
            f"out={path}: PyTorch's ONNX exporter failed ({first}); format=c writes the same chain"
        ) from None
    finally:
        quiet.setLevel(level)
    if program is None:  # pragma: no cover - the dynamo exporter always returns its program
        raise ExportError("torch.onnx.export returned no program")
    model = program.model_proto
    onnx.helper.set_model_props(model, {"pyflyt": json.dumps(policy.about, sort_keys=True)})
    model.doc_string = "pyflyt policy: " + "; ".join(policy.about["steps"])
    onnx.checker.check_model(model)
    with atomic_output(path, "out=") as tmp:
        onnx.save_model(model, str(tmp))


def run_onnx(path: Path, obs: np.ndarray) -> np.ndarray:
    """The actions an ONNX file written by :func:`write_onnx` gives for ``obs`` (onnxruntime, CPU)."""
    _need("onnxruntime")
    import onnxruntime

    options = onnxruntime.SessionOptions()
    options.intra_op_num_threads = 1
    options.inter_op_num_threads = 1
    session = onnxruntime.InferenceSession(str(path), options, providers=["CPUExecutionProvider"])
    return session.run([OUTPUT], {INPUT: np.asarray(obs, dtype=np.float32)})[0]
