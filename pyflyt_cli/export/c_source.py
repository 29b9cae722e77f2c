"""A :class:`~pyflyt_cli.export.policy.DeployedPolicy` as a dependency-free C99 header and source.

The source holds every weight as a ``static const float`` literal (nine significant digits:
the float32 value exactly) and one function,

    void policy_forward(const float *obs, float *action);

that runs the chain layer by layer: no allocation, no library but ``<math.h>`` (and that
only for the activations that need it: ``tanhf``, ``expf``, ``expm1f``, ``erff``), two
scratch buffers of the widest layer on the stack.  Each linear layer's sums are
compensated (Kahan): a policy fed raw observations of tens of metres has pre-activations
in the hundreds, where a plain float32 running sum over 128 inputs drifts by 1e-5 from
PyTorch's; compensated, it stays within a few 1e-6 (four float operations per weight instead of
two; ``-ffast-math`` would undo it).  It compiles with
``gcc -std=c99 -Wall -Werror -O2`` and on a microcontroller's C99 compiler; the weights go
to flash (``const``).  Written by :func:`write_c`, from a small template of our own.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np
import torch

from pyflyt_cli.export.policy import Affine, Clamp, DeployedPolicy, ExportError, Standardize

#: values per line in the weight arrays
PER_LINE = 6

#: a C99 ``main`` for checking an exported policy on a host: it reads float32 observation
#: rows from one file and writes the policy's action rows to another (tests,
#: ``experiments/export_precision.py``); not part of what a firmware needs
HOST_RUNNER = r"""
#include <stdio.h>
#include "policy.h"

/* argv[1]: float32 observations, POLICY_OBS_DIM per row; argv[2]: the actions written, POLICY_ACT_DIM per row */
int main(int argc, char **argv)
{
    float obs[POLICY_OBS_DIM], act[POLICY_ACT_DIM];
    FILE *in, *out;
    if (argc != 3) return 2;
    in = fopen(argv[1], "rb");
    out = fopen(argv[2], "wb");
    if (in == NULL || out == NULL) return 1;
    while (fread(obs, sizeof(float), POLICY_OBS_DIM, in) == POLICY_OBS_DIM) {
        policy_forward(obs, act);
        if (fwrite(act, sizeof(float), POLICY_ACT_DIM, out) != POLICY_ACT_DIM) return 1;
    }
    fclose(in);
    fclose(out);
    return 0;
}
"""


def literal(value: float) -> str:
    """``value`` as a C float literal that reads back as the same float32 (``1.0f``, ``-2.5e-05f``)."""
    v = float(np.float32(value))
    if not np.isfinite(v):
        raise ExportError(f"a weight or bound is {v}: only finite numbers can be exported")
    text = f"{v:.9g}"
    if not any(c in text for c in ".e"):
        text += ".0"
    return text + "f"


def _array(name: str, values: np.ndarray) -> str:
    flat = [literal(v) for v in np.asarray(values, dtype=np.float64).reshape(-1)]
    lines = [", ".join(flat[i : i + PER_LINE]) for i in range(0, len(flat), PER_LINE)]
    body = ",\n    ".join(lines)
    return f"static const float {name}[{len(flat)}] = {{\n    {body}\n}};\n"


def _guard(header: str) -> str:
    return re.sub(r"[^A-Za-z0-9]", "_", header).upper().lstrip("_0123456789") or "POLICY_H"


#: characters free text (a path, an env id, an action's name or unit) keeps in a generated C comment;
#: every other character is written as ``%XX``, one per byte of its UTF-8 form (:func:`comment_text`).
#: Left out: the backslash (one before a line break splices the next line into the comment's),
#: ``?`` (the trigraph ``??/`` is a backslash in C99), ``%`` (the escape itself), every control
#: character and line break, and everything outside ASCII.  ``*`` is kept only where it cannot
#: open or close a comment (see :func:`comment_text`).
COMMENT_SAFE = frozenset(
    "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789 !\"#$&'()+,-./:;<=>@[]^_`{|}~*"
)


def _percent(char: str) -> str:
    return "".join(f"%{b:02X}" for b in char.encode("utf-8", "surrogatepass"))


def comment_text(value: object) -> str:
    """``value`` (free text from a run's files or the command line) as text that is inert inside a
    C comment: the one escaping function every such text in a generated file goes through.

    Keeps the characters of :data:`COMMENT_SAFE`, writes any other as ``%XX`` (its UTF-8 bytes;
    ``%`` itself as ``%25``, so the escape is reversible); a ``*`` next to a ``/``, or at either
    end of the text (where the template's neighbour could be a ``/``), is written ``%2A``.  The
    result is printable ASCII with no backslash, no ``?`` and no ``*/`` or ``/*``, whatever the
    input, and it never ends a comment or splices a line.
    """
    text = str(value)
    out: list[str] = []
    last = len(text) - 1
    for i, char in enumerate(text):
        if char not in COMMENT_SAFE:
            out.append(_percent(char))
        elif char == "*" and (i == 0 or i == last or text[i - 1] == "/" or text[i + 1] == "/"):
            out.append("%2A")
        else:
            out.append(char)
    return "".join(out)


#: what a line of a generated comment may not hold, however it was made (:func:`_comment` checks)
_UNSAFE_IN_COMMENT = re.compile(r"[^\x20-\x7e]|\\|\?|\*/|/\*")


def _comment(lines: list[str]) -> str:
    """A C comment of ``lines`` (the template's text, with free text already through :func:`comment_text`).

    Every line is checked again before it is written: a line that could end the comment, splice a
    line or hold a trigraph is refused (an exporter bug, never a file written).
    """
    for line in lines:
        if _UNSAFE_IN_COMMENT.search(line):
            raise ExportError(f"refusing to write a header comment line that is not inert C text: {line!r}")
    return "/*\n" + "".join(f" * {line}".rstrip() + "\n" for line in lines) + " */\n"


def describe(policy: DeployedPolicy) -> list[str]:
    """The header comment: where the policy came from, its interface and what the function includes.

    Numbers are formatted here; every text from the run (its path, env id, algorithm, the action's
    names, units and mode, ...) goes through :func:`comment_text`."""
    a = policy.about
    act = a["action"]
    t = comment_text
    hz = float(a["agent_hz"])
    lines = [
        "Policy exported by `pyflyt export` (see docs/deploy.md).",
        "",
        f"run:        {t(a['run'])}",
        f"policy:     {t(a['model'])} ({t(a['which'])}), algo {t(a['algo'])}, step {int(a['step'])}",
        f"env:        {t(a['env_id'])} (env={t(a['env_name'])}), one action per {1.0 / hz:.6g} s ({hz:g} Hz)",
        "",
        f"obs[{int(policy.obs_dim)}]:    the env's observation, raw, in the env's units and frames",
        f"            (attitude {t(a['observation']['angle_representation'])}; layout in docs/environments.md)",
        f"action[{int(policy.act_dim)}]: what the env receives (flight mode {t(act['mode'])}):",
    ]
    for i, (name, unit, lo, hi) in enumerate(zip(act["names"], act["units"], act["low"], act["high"])):
        unit = "dimensionless" if unit in ("", "1") else unit
        lines.append(f"  [{i}] {t(name)} ({t(unit)}) in [{float(lo):.9g}, {float(hi):.9g}]")
    lines += ["", "policy_forward computes, in float32:"]
    lines += [f"  {i + 1}. {t(step)}" for i, step in enumerate(a["steps"])]
    lines += [
        "",
        "Not included: the flight mode's controller (the action is its setpoint), building the",
        "observation from sensors, the agent rate, and any check of the observation: feed finite values.",
    ]
    return lines


def _step_code(layer: Any, index: int, width: int, src: str, dst: str) -> tuple[str, str, int, set[str]]:
    """(arrays, code, output width, math functions) of one layer, reading ``src`` and writing ``dst``
    (element-wise layers write ``src`` in place and ignore ``dst``)."""
    kind = type(layer).__name__
    math: set[str] = set()
    n = width
    if isinstance(layer, Standardize):
        mean, std = layer.mean.numpy(), layer.std.numpy()
        arrays = _array(f"norm{index}_mean", mean) + _array(f"norm{index}_std", std)
        c = literal(layer.clip)
        code = (
            f"    /* {index}: observation normaliser: clip((x - mean) / std, -{c}, {c}) */\n"
            f"    for (i = 0; i < {n}; ++i) {{\n"
            f"        float z = ({src}[i] - norm{index}_mean[i]) / norm{index}_std[i];\n"
            f"        {src}[i] = z < -{c} ? -{c} : (z > {c} ? {c} : z);\n"
            f"    }}\n"
        )
        return arrays, code, n, math
    if isinstance(layer, torch.nn.Linear):
        w = layer.weight.detach().numpy()
        out, inp = w.shape
        if inp != width:
            raise ExportError(f"layer {index}: Linear takes {inp} inputs, the layer before gives {width}")
        b = layer.bias.detach().numpy() if layer.bias is not None else np.zeros(out)
        arrays = _array(f"layer{index}_weight", w) + _array(f"layer{index}_bias", b)
        code = (
            f"    /* {index}: linear {inp} -> {out} (weight row-major [{out}][{inp}]), compensated sum */\n"
            f"    for (j = 0; j < {out}; ++j) {{\n"
            f"        const float *row = layer{index}_weight + j * {inp};\n"
            f"        float s = layer{index}_bias[j], c = 0.0f;\n"
            f"        for (i = 0; i < {inp}; ++i) {{\n"
            f"            float y = row[i] * {src}[i] - c;\n"
            f"            float t = s + y;\n"
            f"            c = (t - s) - y;\n"
            f"            s = t;\n"
            f"        }}\n"
            f"        {dst}[j] = s;\n"
            f"    }}\n"
        )
        return arrays, code, out, math
    if isinstance(layer, Affine):
        arrays = _array(f"affine{index}_scale", layer.scale.numpy()) + _array(
            f"affine{index}_offset", layer.offset.numpy()
        )
        code = (
            f"    /* {index}: rescale: x * scale + offset */\n"
            f"    for (i = 0; i < {n}; ++i) {src}[i] = {src}[i] * affine{index}_scale[i] + affine{index}_offset[i];\n"
        )
        return arrays, code, n, math
    if isinstance(layer, Clamp):
        arrays = _array(f"clamp{index}_low", layer.low.numpy()) + _array(f"clamp{index}_high", layer.high.numpy())
        code = (
            f"    /* {index}: clip to [low, high] */\n"
            f"    for (i = 0; i < {n}; ++i) {{\n"
            f"        float v = {src}[i] < clamp{index}_low[i] ? clamp{index}_low[i] : {src}[i];\n"
            f"        {src}[i] = v > clamp{index}_high[i] ? clamp{index}_high[i] : v;\n"
            f"    }}\n"
        )
        return arrays, code, n, math
    x = f"{src}[i]"
    if kind == "ReLU":
        expr = f"{x} > 0.0f ? {x} : 0.0f"
    elif kind == "Tanh":
        expr, math = f"tanhf({x})", {"tanhf"}
    elif kind == "Sigmoid":
        expr, math = f"1.0f / (1.0f + expf(-{x}))", {"expf"}
    elif kind == "SiLU":
        expr, math = f"{x} / (1.0f + expf(-{x}))", {"expf"}
    elif kind == "ELU":
        expr, math = f"{x} > 0.0f ? {x} : {literal(layer.alpha)} * expm1f({x})", {"expm1f"}
    elif kind == "LeakyReLU":
        expr = f"{x} > 0.0f ? {x} : {literal(layer.negative_slope)} * {x}"
    elif kind == "Hardtanh":
        lo, hi = literal(layer.min_val), literal(layer.max_val)
        expr = f"{x} < {lo} ? {lo} : ({x} > {hi} ? {hi} : {x})"
    elif kind == "GELU" and layer.approximate == "tanh":
        k = literal(np.sqrt(2.0 / np.pi))
        expr = f"0.5f * {x} * (1.0f + tanhf({k} * ({x} + 0.044715f * {x} * {x} * {x})))"
        math = {"tanhf"}
    elif kind == "GELU":
        expr, math = f"0.5f * {x} * (1.0f + erff({x} * {literal(np.sqrt(0.5))}))", {"erff"}
    else:
        raise ExportError(f"layer {index}: {kind} is not written by the C exporter")
    code = f"    /* {index}: {kind.lower()} */\n    for (i = 0; i < {n}; ++i) {src}[i] = {expr};\n"
    return "", code, n, math


def c_files(policy: DeployedPolicy, header_name: str) -> tuple[str, str]:
    """(header text, source text); the source includes the header as ``header_name``."""
    layers = list(policy.network)
    width = policy.obs_dim
    widths = [width]
    arrays: list[str] = []
    body: list[str] = []
    math: set[str] = set()
    buffers = ("buf0", "buf1")
    cur = 0
    for index, layer in enumerate(layers):
        src, dst = buffers[cur], buffers[1 - cur]
        a, code, out, used = _step_code(layer, index, width, src, dst)
        arrays.append(a)
        body.append(code)
        math |= used
        if isinstance(layer, torch.nn.Linear):
            cur = 1 - cur
        width = out
        widths.append(width)
    if width != policy.act_dim:
        raise ExportError(f"the chain ends with {width} values, the action has {policy.act_dim}")
    widest = max(widths)
    comment = _comment(describe(policy))
    guard = _guard(header_name)
    header = (
        comment
        + f"#ifndef {guard}\n#define {guard}\n\n"
        + '#ifdef __cplusplus\nextern "C" {\n#endif\n\n'
        + "/* entries of the observation and of the action */\n"
        + f"#define POLICY_OBS_DIM {policy.obs_dim}\n#define POLICY_ACT_DIM {policy.act_dim}\n\n"
        + "/* obs: POLICY_OBS_DIM floats, the env's raw observation; action: POLICY_ACT_DIM floats written,\n"
        + f" * in the env's units. Reentrant; uses {2 * widest * 4} bytes of stack, no heap. */\n"
        + "void policy_forward(const float *obs, float *action);\n\n"
        + "#ifdef __cplusplus\n}\n#endif\n\n"
        + f"#endif /* {guard} */\n"
    )
    includes = f'#include "{header_name}"\n' + ("#include <math.h>\n" if math else "")
    source = (
        comment
        + "\n"
        + includes
        + "\n"
        + "".join(arrays)
        + "\n"
        + "void policy_forward(const float *obs, float *action)\n{\n"
        + f"    float buf0[{widest}], buf1[{widest}];\n"
        + "    int i, j;\n"
        + f"    for (i = 0; i < {policy.obs_dim}; ++i) buf0[i] = obs[i];\n"
        + "".join(body)
        + f"    for (i = 0; i < {policy.act_dim}; ++i) action[i] = {buffers[cur]}[i];\n"
        + ("    (void)buf1;\n" if not any(isinstance(layer, torch.nn.Linear) for layer in layers) else "")
        + ("    (void)j;\n" if not any(isinstance(layer, torch.nn.Linear) for layer in layers) else "")
        + "}\n"
    )
    return header, source


def write_c(policy: DeployedPolicy, source_path: Path, header_path: Path) -> None:
    """Write the two files (each through a temporary file renamed into place)."""
    from pyflyt_cli.outputs import atomic_output

    header, source = c_files(policy, header_path.name)
    for path, text in ((header_path, header), (source_path, source)):
        with atomic_output(path, "out=") as tmp:
            tmp.write_text(text)
