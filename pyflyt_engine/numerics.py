"""The numeric platform: one set of floating-point kernels on every x86_64 CPU with AVX2.

NumPy, its OpenBLAS, PyTorch and the MKL inside PyTorch each choose their kernels by CPU
when they load (OpenBLAS's ``DYNAMIC_ARCH``, NumPy's SIMD dispatch, ATen's CPU capability,
MKL's code branches).  Two CPUs then round some results differently in the last bit, and
training, which is chaotic, grows that bit into another run.  To give the same numbers
on every machine, :func:`pin` asks each library for one kernel set, through the
environment variables each reads when it loads:

============================  ===================  ======================================
variable                      pinned value         what it selects
============================  ===================  ======================================
``OPENBLAS_CORETYPE``         ``Haswell``          OpenBLAS (NumPy's, SciPy's): its AVX2 kernels
``NPY_DISABLE_CPU_FEATURES``  the AVX-512 groups   NumPy: no AVX-512 code paths (its SVML maths)
``ATEN_CPU_CAPABILITY``       ``avx2``             PyTorch's vectorised CPU kernels
``MKL_CBWR``                  ``COMPATIBLE,STRICT``  MKL (PyTorch's BLAS): Intel's branch that
                                                   gives the same results on Intel and
                                                   compatible (AMD) processors
``ONEDNN_MAX_CPU_ISA``        ``AVX2``             oneDNN (convolutions); see also
                                                   :func:`apply_torch`
``XLA_FLAGS``                 ``--xla_cpu_max_isa  XLA (JAX, ``algo=sac_jax``): code generated
                              =AVX2``              for AVX2, not the CPU's widest set
============================  ===================  ======================================

In both modes XLA's Eigen kernels (its matrix products) are also kept single-threaded
(:data:`XLA_THREADS`, added to ``XLA_FLAGS`` unless they set that flag themselves), as
``train.torch_threads: 1`` keeps torch's: a product split over threads sums in an order that
depends on their number.  XLA's thread pool itself still has a thread per CPU the process
may use, and runs independent operations of an update side by side
(``experiments/results/sac_update_cost.md``).  XLA reads ``XLA_FLAGS`` once, when JAX
creates its CPU backend, so they are set here, before anything imports JAX.

``import pyflyt_engine`` (and so the ``pyflyt`` command) calls :func:`pin` before
anything imports NumPy or PyTorch.  A library that was loaded earlier keeps the kernels
it chose: :func:`platform_info` reports what is in force, and a run records it in
``run.yaml`` and in its MCAP files.  The physics does not depend on any of this: the
simulated path uses no BLAS and none of NumPy's CPU-dispatched maths
(``docs/reproducibility.md``).

``PYFLYT_NUMERICS=native`` leaves every library to choose for the CPU (faster SAC updates
on wide networks; the same numbers only on the same kind of CPU).  Pinning applies on
x86_64 Linux CPUs with AVX2 and FMA; elsewhere the libraries choose, and
:func:`platform_info` says so.

This module imports nothing heavy at import time: it runs before NumPy loads.
"""

from __future__ import annotations

import importlib
import os
import platform
import sys
from typing import Any

#: the environment variable that selects the mode
MODE_VARIABLE = "PYFLYT_NUMERICS"
#: ``pinned`` (the default): one kernel set on every AVX2 CPU; ``native``: the libraries choose
MODES = ("pinned", "native")

#: NumPy's AVX-512 dispatch targets, by both naming schemes (NumPy >= 2.4 groups them as
#: X86_V4; older versions name each); names a version does not know are ignored by it
_NUMPY_AVX512 = "X86_V4 AVX512F AVX512CD AVX512_KNL AVX512_KNM AVX512_SKX AVX512_CLX AVX512_CNL AVX512_ICL AVX512_SPR"

#: what :func:`pin` sets, in the pinned mode
PINNED: dict[str, str] = {
    "OPENBLAS_CORETYPE": "Haswell",
    "NPY_DISABLE_CPU_FEATURES": _NUMPY_AVX512,
    "ATEN_CPU_CAPABILITY": "avx2",
    "MKL_CBWR": "COMPATIBLE,STRICT",
    "ONEDNN_MAX_CPU_ISA": "AVX2",
}

#: XLA's instruction-set cap, in the pinned mode (one ``XLA_FLAGS`` token)
XLA_PINNED = "--xla_cpu_max_isa=AVX2"
#: XLA's Eigen kernels on one thread (``XLA_FLAGS`` tokens), in both modes
XLA_THREADS = ("--xla_cpu_multi_thread_eigen=false",)

#: MKL's CBWR branch codes (Intel's ``mkl_cbwr.h``), for reporting what is in force
_MKL_BRANCHES = {0: "OFF", 1: "BRANCH_OFF", 2: "AUTO", 3: "COMPATIBLE", 4: "SSE2", 6: "SSSE3", 7: "SSE4_1",
                 8: "SSE4_2", 9: "AVX", 10: "AVX2", 12: "AVX512", 14: "AVX512_E1"}  # fmt: skip
_MKL_STRICT = 0x10000

#: set by :func:`pin`: the mode asked for, whether the pins were applied, and which of the
#: libraries they steer were already loaded when they were
_state: dict[str, Any] = {"mode": None, "applied": False, "loaded_before": (), "invalid": None}


def _cpu_flags() -> set[str]:
    try:
        with open("/proc/cpuinfo", encoding="ascii", errors="replace") as f:
            for line in f:
                if line.startswith("flags"):
                    return set(line.split(":", 1)[1].split())
    except OSError:
        pass
    return set()


def _cpu_model() -> str:
    try:
        with open("/proc/cpuinfo", encoding="ascii", errors="replace") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def pinnable() -> tuple[bool, str]:
    """Whether this machine can run the pinned kernel set, and if not, why."""
    if platform.system() != "Linux" or platform.machine() not in ("x86_64", "AMD64"):
        return False, f"pinning covers x86_64 Linux; this is {platform.machine()} {platform.system()}"
    flags = _cpu_flags()
    missing = [f for f in ("avx2", "fma") if f not in flags]
    if missing:
        return False, f"this CPU lacks {' and '.join(missing).upper()}, which the pinned kernels need"
    return True, ""


def requested_mode() -> str:
    """The mode ``PYFLYT_NUMERICS`` asks for (``pinned`` when unset or not understood)."""
    value = os.environ.get(MODE_VARIABLE, "").strip().lower()
    return value if value in MODES else "pinned"


def check_mode() -> None:
    """Raise ``ValueError`` naming the variable when ``PYFLYT_NUMERICS`` holds something
    other than a mode (the command line turns it into a one-line error)."""
    value = os.environ.get(MODE_VARIABLE, "").strip().lower()
    if value and value not in MODES:
        raise ValueError(
            f"{MODE_VARIABLE}={os.environ[MODE_VARIABLE]!r} is not a numerics mode: use "
            f"{MODE_VARIABLE}=pinned (the same numbers on every AVX2 CPU, the default) or "
            f"{MODE_VARIABLE}=native (each library picks kernels for this CPU)"
        )


def _flag_name(token: str) -> str:
    return token.lstrip("-").split("=", 1)[0]


def xla_flags(current: str, *, pinned: bool) -> str:
    """``XLA_FLAGS`` with the toolkit's: :data:`XLA_THREADS` added unless ``current`` sets them
    itself, and in the pinned mode the instruction-set cap in place of any other."""
    tokens = current.split()
    named = {_flag_name(t) for t in tokens}
    if pinned:
        tokens = [t for t in tokens if _flag_name(t) != _flag_name(XLA_PINNED)] + [XLA_PINNED]
    tokens += [t for t in XLA_THREADS if _flag_name(t) not in named]
    return " ".join(tokens)


def pin() -> None:
    """Apply the pinned kernel set (once per process; see the module docstring)."""
    if _state["mode"] is not None:
        return
    mode = requested_mode()
    _state["mode"] = mode
    if os.environ.get(MODE_VARIABLE, "").strip().lower() not in ("", *MODES):
        _state["invalid"] = os.environ[MODE_VARIABLE]
    _state["loaded_before"] = tuple(m for m in ("numpy", "torch", "jax") if m in sys.modules)
    pinned = mode == "pinned" and pinnable()[0]
    os.environ["XLA_FLAGS"] = xla_flags(os.environ.get("XLA_FLAGS", ""), pinned=pinned)
    if not pinned:
        return
    os.environ.update(PINNED)
    _state["applied"] = True


def apply_torch() -> None:
    """Settings PyTorch reads at run time rather than at load: in the pinned mode, its own
    convolutions instead of oneDNN's, whose kernels are generated for the CPU's caches."""
    if _state["applied"]:
        import torch

        # torch's stubs type the module flag as its ContextProp descriptor; a bool is what it takes
        torch.backends.mkldnn.enabled = False  # type: ignore[assignment]


def _openblas() -> list[dict[str, str]]:
    if "numpy" not in sys.modules:
        return []
    try:
        from threadpoolctl import threadpool_info
    except ImportError:  # pragma: no cover - a declared dependency
        return [{"kernels": "unknown (threadpoolctl is not installed)"}]
    return [
        {"library": os.path.basename(i.get("filepath", "?")), "version": str(i.get("version")),
         "kernels": str(i.get("architecture"))}
        for i in threadpool_info()
        if i.get("internal_api") == "openblas"
    ]  # fmt: skip


def _numpy_simd() -> str:
    if "numpy" not in sys.modules:
        return "not loaded"
    # NumPy 2, then NumPy < 2; imported by name, as NumPy's stubs leave out this private module
    for module in ("numpy._core._multiarray_umath", "numpy.core._multiarray_umath"):
        try:
            umath = importlib.import_module(module)
            dispatch, features = umath.__cpu_dispatch__, umath.__cpu_features__
            break
        except (ImportError, AttributeError):
            continue
    else:
        return "unknown"
    enabled = [name for name in dispatch if features.get(name)]
    return " ".join(enabled) or "baseline only"


def _mkl_branch() -> str:
    """MKL's CBWR setting in force, read from the MKL linked into PyTorch."""
    import ctypes

    import torch

    lib = os.path.join(os.path.dirname(torch.__file__), "lib", "libtorch_cpu.so")
    try:
        get = ctypes.CDLL(lib).mkl_serv_cbwr_get
    except (OSError, AttributeError):
        return "unknown"
    get.restype, get.argtypes = ctypes.c_int, [ctypes.c_int]
    code = get(-1)
    name = _MKL_BRANCHES.get(code & 0xFFFF, str(code & 0xFFFF))
    return name + (",STRICT" if code & _MKL_STRICT else "")


def _torch() -> dict[str, str]:
    if "torch" not in sys.modules:
        return {}
    import torch

    return {
        "capability": str(torch.backends.cpu.get_cpu_capability()),
        "mkl_cbwr": _mkl_branch(),
        "onednn": "off" if not torch.backends.mkldnn.enabled else os.environ.get("ONEDNN_MAX_CPU_ISA", "default"),
    }


def _xla() -> dict[str, str]:
    """JAX's XLA flags (once JAX is loaded; ``algo=sac_jax``)."""
    if "jax" not in sys.modules:
        return {}
    return {"flags": os.environ.get("XLA_FLAGS", "")}


def _versions() -> dict[str, str]:
    """Versions of the numeric libraries: another version may round differently."""
    from importlib import metadata

    out = {}
    jax_stack = ("jax", "jaxlib", "flax", "optax", "sbx-rl")
    for name in ("numpy", "scipy", "pybullet", "torch", *jax_stack):
        if name == "torch" and "torch" not in sys.modules:
            continue
        if name in jax_stack and "jax" not in sys.modules:  # only in a process that runs JAX
            continue
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "not installed"
    return out


def kernels() -> dict[str, Any]:
    """The kernel sets in force in this process, for the libraries loaded so far."""
    out: dict[str, Any] = {"openblas": _openblas(), "numpy_simd": _numpy_simd()}
    torch_info = _torch()
    if torch_info:
        out["torch"] = torch_info
    xla = _xla()
    if xla:
        out["xla"] = xla
    return out


def pins_in_force() -> bool:
    """Whether every loaded library runs the pinned kernel set."""
    if not _state["applied"]:
        return False
    k = kernels()
    if any(b.get("kernels") != PINNED["OPENBLAS_CORETYPE"] for b in k["openblas"]):
        return False
    if k["numpy_simd"] not in ("not loaded", "unknown") and "X86_V4" in k["numpy_simd"].split():
        return False
    t = k.get("torch")
    if t and (t["capability"] != "AVX2" or t["mkl_cbwr"] not in ("COMPATIBLE,STRICT", "unknown")):
        return False
    x = k.get("xla")
    if x and ("jax" in _state["loaded_before"] or XLA_PINNED not in x["flags"].split()):
        return False
    return True


def platform_info() -> dict[str, Any]:
    """What decides the last bits of this process's numbers: for ``run.yaml`` and MCAP metadata.

    ``key`` is the part two processes must share to compute the same numbers: in the
    pinned mode, with every pin in force, it does not name the CPU; otherwise it does.
    """
    libc, libc_version = platform.libc_ver()
    ok, why = pinnable()
    mode = _state["mode"] or requested_mode()
    in_force = pins_in_force()
    if mode == "native":
        note = f"{MODE_VARIABLE}=native: each library chose kernels for this CPU"
    elif not ok:
        note = f"not pinned: {why}"
    elif not in_force:
        early = _state["loaded_before"]
        who = f"{' and '.join(early)} {'were' if len(early) > 1 else 'was'}" if early else "a library was"
        note = f"not all pinned: {who} loaded before pyflyt_engine, with kernels chosen for this CPU"
    else:
        note = "pinned: the same kernels on every x86_64 CPU with AVX2"
    key: dict[str, Any] = {
        "machine": platform.machine(),
        "libc": f"{libc} {libc_version}".strip(),
        "numerics": "pinned" if in_force else "native",
    }
    if not in_force:
        key["cpu"] = _cpu_model()
        key["kernels"] = kernels()
    key["versions"] = _versions()
    return {
        "mode": mode,
        "status": note,
        "cpu": _cpu_model(),
        "kernels": kernels(),
        "key": key,
    }


def describe_difference(recorded: dict[str, Any] | None, current: dict[str, Any] | None = None) -> str | None:
    """One line saying how ``recorded`` (a ``platform_info()["key"]``) differs from this
    process's, or None when they agree (or nothing was recorded)."""
    if not recorded:
        return None
    current = current if current is not None else platform_info()["key"]
    if recorded == current:
        return None
    parts = []
    for name in sorted(set(recorded) | set(current)):
        if recorded.get(name) != current.get(name):
            was, now = recorded.get(name, "-"), current.get(name, "-")
            if isinstance(was, dict) or isinstance(now, dict):
                parts.append(f"{name} differ")
            else:
                parts.append(f"{name} {was} -> {now}")
    return "; ".join(parts)


#: the MCAP metadata record that holds :func:`mcap_record`
MCAP_RECORD = "numerics"


def mcap_record() -> dict[str, str]:
    """:func:`platform_info` as an MCAP metadata record (string values; JSON where nested)."""
    import json

    info = platform_info()
    return {
        "mode": info["mode"],
        "status": info["status"],
        "cpu": info["cpu"],
        "kernels": json.dumps(info["kernels"], sort_keys=True),
        "key": json.dumps(info["key"], sort_keys=True),
    }
