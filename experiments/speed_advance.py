"""The batched physics of one agent step (``kernels.advance``) with and without what makes it fast.

Builds QuadX-Hover as the batched backend runs it (N envs, 8 physics steps and 4 control
ticks per agent step), records the arguments of a real step's ``kernels.advance`` call after
a few steps of small random actions, and times that call from the same state, interleaved
call by call, in four forms that give the same numbers bit for bit (checked here):

* ``as shipped``: the kernel as the env calls it;
* ``python errors``: the same source compiled with numba's Python error model (a zero test
  and a branch on each division's divisor, ``ZeroDivisionError``), which the batched backend
  does not use (:mod:`pyflyt_engine.batched.compiled`);
* ``wind tested``: ``wind_on=True``, so every env's wind switch is read and tested in its
  physics steps though no env has wind (as the kernel did before the switch became a type);
* ``both``: the two together;
* ``one by one``: vehicle by vehicle, all of a vehicle's physics steps before the next
  vehicle's (blocks of one vehicle), instead of each physics step for a block of
  ``kernels._BLOCK`` vehicles (which lets the processor overlap independent vehicles' steps).

Prints CPU ns per agent-step (the 10th percentile and the median of the calls: the VM is
shared, the low percentile is the least disturbed) and each form's ratio to ``as shipped``.

    python experiments/speed_advance.py [--envs 1024] [--calls 2000]
"""

from __future__ import annotations

import argparse
import time
import types

import numba
import numpy as np

from pyflyt_engine.batched import kernels, normals
from pyflyt_engine.envs import make_batched_env

#: the arguments the call changes (state, motors, rate loop, contact), restored before each call
_CHANGED = (0, 1, 2, 3, 4, 5, 6, 7, 8, 27)
_WIND_ON = -1  # advance's last argument


def _recorded_call(n: int) -> list:
    """The arguments of ``kernels.advance`` for the next agent step of QuadX-Hover after a few
    steps of small random actions, as the env builds them (its one-call step passes the same
    tuple to ``bookkeeping.plain_step``), the motor noise drawn into its factors."""
    env = make_batched_env("PyFlyt/QuadX-Hover-v0", n_envs=n)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    for _ in range(5):
        env.step(rng.uniform(-0.1, 0.1, size=(n, *env.single_action_space.shape)).astype(np.float32))
    e = env.unwrapped if hasattr(env, "unwrapped") else env
    if e.motor_noise:
        normals.noise_factors(e.noise_rng, e._noise_ratio, e._noise_buffer)
    factors = e._noise_buffer if e.motor_noise else e._ones
    start = int(e.physics_steps[0]) % e.per_control
    e._normals = e.turbulence_normals()
    call = list(e._advance_args(e.actions, factors, start, e.per_agent, *e._span(start, e.per_agent)))
    env.close()
    return call


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--envs", type=int, default=1024)
    parser.add_argument("--calls", type=int, default=2000, help="timed calls per form")
    args = parser.parse_args()
    n = args.envs
    call = _recorded_call(n)
    assert call[_WIND_ON] is None, "QuadX-Hover flies in calm air"
    saved = [np.copy(call[i]) for i in _CHANGED]
    python_errors = numba.njit(error_model="python")(kernels.advance.py_func)
    shipped = kernels.advance.py_func  # the same source with blocks of one vehicle
    one_by_one = numba.njit(error_model="numpy")(
        types.FunctionType(shipped.__code__, {**shipped.__globals__, "_BLOCK": 1}, "advance_one_by_one")
    )
    tested = call.copy()
    tested[_WIND_ON] = True
    forms = {
        "as shipped": (kernels.advance, call),
        "python errors": (python_errors, call),
        "wind tested": (kernels.advance, tested),
        "both": (python_errors, tested),
        "one by one": (one_by_one, call),
    }

    def once(fn, fn_args) -> float:
        for i, value in zip(_CHANGED, saved):
            np.copyto(fn_args[i], value)
        start = time.process_time_ns()
        fn(*fn_args)
        return (time.process_time_ns() - start) / n

    results = {}
    for name, (fn, fn_args) in forms.items():
        once(fn, fn_args)  # compiles
        results[name] = [np.copy(fn_args[i]) for i in _CHANGED]
    same = all(all(np.array_equal(a, b) for a, b in zip(results["as shipped"], results[name])) for name in forms)
    times: dict[str, list[float]] = {name: [] for name in forms}
    for _ in range(args.calls):
        for name, (fn, fn_args) in forms.items():
            times[name].append(once(fn, fn_args))
    base = np.percentile(times["as shipped"], 10)
    print(f"QuadX-Hover, N = {n}: one agent step's kernels.advance, {args.calls} calls per form, interleaved")
    print(f"same numbers in every form: {same}")
    print(f"{'form':<14} {'p10 ns/agent-step':>18} {'median':>8} {'p10 / as shipped':>17}")
    for name, t in times.items():
        p10 = np.percentile(t, 10)
        print(f"{name:<14} {p10:>18.1f} {np.median(t):>8.1f} {p10 / base:>17.3f}")


if __name__ == "__main__":
    main()
