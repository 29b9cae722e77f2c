#!/usr/bin/env bash
# The reproducibility-sensitive tests under emulated other CPUs.
#
# Each library that chooses floating-point kernels by CPU reads a variable that makes it
# choose as another CPU would: OpenBLAS's core type, NumPy's SIMD targets, PyTorch's CPU
# capability, MKL's code branch, oneDNN's instruction set and the CPU numba compiles the
# batched backend's laws for.  Under each emulation below
# the golden trajectories (the batched backend's too), the physics' independence of those
# kernels, determinism across processes, exact resume and the zoo's recorded returns must
# hold exactly as on this CPU
# (docs/reproducibility.md, "What is exact, where").
#
#   bash experiments/emulated_cpus.sh            # both emulations (~10 min on 2 cores)
#   bash experiments/emulated_cpus.sh -x -q      # extra pytest arguments
set -euo pipefail
cd "$(dirname "$0")/.."

TESTS=(
    tests/engine/test_golden_trajectories.py
    tests/engine/test_numeric_kernels.py
    tests/engine/test_determinism.py
    tests/envs/test_determinism.py
    tests/train/test_resume.py
    tests/train/test_zoo.py
    tests/batched/test_golden.py
    tests/batched/test_training.py
    tests/batched/test_randomization.py
    tests/batched/test_motor_models.py
    tests/batched/test_sensors.py
    tests/batched/test_combined.py
)
EMULATIONS=(
    # an SSE3-only core for BLAS, NumPy without AVX2, PyTorch's baseline kernels, MKL's SSE2 branch,
    # the batched backend's laws compiled for baseline x86-64 (numba; its own cache, so it compiles)
    "OPENBLAS_CORETYPE=Prescott NPY_DISABLE_CPU_FEATURES=X86_V3 ATEN_CPU_CAPABILITY=default MKL_CBWR=COMPATIBLE ONEDNN_MAX_CPU_ISA=AVX2 NUMBA_CPU_NAME=x86-64 NUMBA_CACHE_DIR=${TMPDIR:-/tmp}/pyflyt-numba-x86-64"
    # an AVX (no AVX2) core for BLAS, MKL choosing its branch itself, oneDNN without AVX,
    # the batched backend's laws compiled for an AVX-only core
    "OPENBLAS_CORETYPE=Sandybridge ATEN_CPU_CAPABILITY=default MKL_CBWR=AUTO ONEDNN_MAX_CPU_ISA=SSE41 NUMBA_CPU_NAME=sandybridge NUMBA_CACHE_DIR=${TMPDIR:-/tmp}/pyflyt-numba-sandybridge"
)
status=0
for emulation in "${EMULATIONS[@]}"; do
    echo "+ $emulation pytest ${TESTS[*]} $*"
    # every test of these files, the ones marked long included
    env $emulation python -m pytest -p no:cacheprovider -q -m "not slow" "${TESTS[@]}" "$@" || status=1
done
exit "$status"
