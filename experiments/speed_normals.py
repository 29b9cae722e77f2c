"""The motors' noise of one batched agent step: numpy's draws against the compiled ones.

Times, in one process and interleaved round by round, ``1 + ratio * eta`` for N envs x 8
physics steps x 4 motors as the batched env computed it with numpy
(``Generator.standard_normal(out=...)``, then multiply and add in place) and as
:func:`pyflyt_engine.batched.normals.noise_factors` computes it in one compiled pass, and
checks that the two give the same numbers bit for bit.  Prints CPU ns per factor (median of
the rounds) and the ratio.

    python experiments/speed_normals.py [--envs 1024] [--rounds 7]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from pyflyt_engine.batched import normals


def _numpy(rng: np.random.Generator, ratio: np.ndarray, out: np.ndarray) -> np.ndarray:
    rng.standard_normal(out=out)
    np.multiply(out, ratio, out=out)
    np.add(out, 1.0, out=out)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--envs", type=int, default=1024)
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--calls", type=int, default=500, help="agent steps' draws per round and way")
    args = parser.parse_args()
    ratio = np.full(4, 0.02)
    shape = (args.envs, 8, 4)
    a, b = np.random.default_rng(0), np.random.default_rng(0)
    same = np.array_equal(_numpy(a, ratio, np.empty(shape)), normals.noise_factors(b, ratio, np.empty(shape)))
    same = same and a.bit_generator.state == b.bit_generator.state
    buf = np.empty(shape)
    times: dict[str, list[float]] = {"numpy": [], "compiled": []}
    for _ in range(args.rounds):
        for name, draw in (("numpy", _numpy), ("compiled", normals.noise_factors)):
            start = time.process_time()
            for _ in range(args.calls):
                draw(a, ratio, buf)
            times[name].append((time.process_time() - start) / args.calls / buf.size * 1e9)
    numpy_ns, compiled_ns = (statistics.median(times[k]) for k in ("numpy", "compiled"))
    print(f"N = {args.envs} envs x 8 physics steps x 4 motors, {args.rounds} rounds, CPU time")
    print(f"numpy:    {numpy_ns:6.2f} ns per factor ({numpy_ns * 32 / 1000:.3f} us per env and agent step)")
    print(f"compiled: {compiled_ns:6.2f} ns per factor ({compiled_ns * 32 / 1000:.3f} us per env and agent step)")
    print(f"numpy / compiled: {numpy_ns / compiled_ns:.2f}x; the same numbers and generator state: {same}")


if __name__ == "__main__":
    main()
