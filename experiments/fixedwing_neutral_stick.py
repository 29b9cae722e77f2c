"""The fixed-wing at neutral stick and half thrust, beside the reference PyFlyt 0.29.0, and why.

    python experiments/fixedwing_neutral_stick.py [--reference-python /work/refvenv/bin/python]
                                                  [--seeds 5]
                                                  [--out experiments/results/fixedwing_neutral_stick.md]

The constant action [0, 0, 0, 0.5] (aileron, elevator, rudder, thrust) is flown to the end
of the episode, per seed, on

* the reference's ``PyFlyt/Fixedwing-Waypoints-v3`` (its own interpreter,
  ``--reference-python``, default $PYFLYT_REFERENCE_PYTHON or /work/refvenv/bin/python; it
  pins numpy < 2, so it runs in a subprocess fed the job as JSON and nothing of this
  project is imported there; without it the reference columns say so);
* the compat ``PyFlyt/Fixedwing-Waypoints-v3`` (``pyflyt_engine.compat``: the reference's
  episode, spawn at (0, 0, 10) flying 20 m/s, thrust entry ``T`` to ``T / 2 + 0.5``), the
  native airframe;
* the native ``PyFlyt/Fixedwing-Waypoints-v0`` (spawn 20 m up at 14 m/s, thrust entry
  as given), on the PyBullet engine per seed and on the batched backend (one batch of as
  many copies, its seed the first one; the ``seed`` column is then the copy).

Per episode: its length and ending, the largest body rates |p|, |q|, |r| before the last
step and on it (the step of a ground contact), the mean roll rate over the first second
(the propeller's torque roll), the roll and pitch ranges, the final airspeed and the
largest normalised flap deflection of any surface.

Then the static oracles of tests/vehicles/aero.py for the native airframe: the pitch-plane
trim (:func:`level_trim`) at the reference spawn speed and at the native one, and the
six-equation straight trim (:func:`straight_trim`), with the propeller's reaction torque,
at 14 m/s; and two 10 s flights from that trim: with its aileron and rudder, and with
them at neutral (the neutral stick).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import subprocess
import time
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_REFERENCE = os.environ.get("PYFLYT_REFERENCE_PYTHON", "/work/refvenv/bin/python")
ACTION = [0.0, 0.0, 0.0, 0.5]
#: label -> env kwargs: the ids as registered, and a dome and duration large enough to see
#: how each flight goes on after the registered 100 m dome would have ended it
CASES: dict[str, dict[str, float]] = {
    "dome 100 m": {},
    "dome 5 km, 40 s": {"flight_dome_size": 5000.0, "max_duration_seconds": 40.0},
}

#: run in the reference's interpreter: reads {"seeds", "action", "cases"} on stdin, prints
#: "RESULT <json>"; imports only the reference package
REFERENCE_SCRIPT = r"""
import json, sys, warnings
warnings.filterwarnings("ignore")
import numpy as np, gymnasium
import PyFlyt.gym_envs  # noqa: F401


def episode(kwargs, seed, action):
    env = gymnasium.make("PyFlyt/Fixedwing-Waypoints-v3", **kwargs)
    env.reset(seed=seed)
    u = env.unwrapped
    rows, term, trunc, info = [], False, False, {}
    while not (term or trunc):
        _, _, term, trunc, info = env.step(np.array(action, dtype=np.float64))
        s = u.env.state(0)
        aux = np.asarray(u.env.aux_state(0))
        # the reference's aux: left aileron, right aileron, horizontal tail, vertical tail,
        # main wing (normalised deflections), then the motor
        rows.append([*s[0], *s[1], *s[2], float(np.abs(aux[:5]).max())])
    env.close()
    return {"seed": seed, "rows": rows, "terminated": bool(term), "truncated": bool(trunc),
            "info": {k: bool(v) for k, v in info.items() if isinstance(v, (bool, np.bool_))}}


job = json.loads(sys.stdin.read())
out = {label: [episode(kwargs, seed, job["action"]) for seed in job["seeds"]] for label, kwargs in job["cases"].items()}
print("RESULT " + json.dumps(out))
"""


def summarise(rows: list[list[float]], agent_hz: int) -> dict[str, Any]:
    """rows: per step p, q, r, roll, pitch, yaw, u, v, w, max |flap deflection| (normalised)."""
    a = np.asarray(rows, dtype=float)
    before = a[:-1] if len(a) > 1 else a
    first = a[:agent_hz]
    return {
        "steps": len(a),
        "max_rates_before_last": np.abs(before[:, 0:3]).max(axis=0).tolist(),
        "rates_last": a[-1, 0:3].tolist(),
        "mean_roll_rate_first_s": float(first[:, 0].mean()),
        "roll_range": [float(a[:, 3].min()), float(a[:, 3].max())],
        "pitch_range": [float(a[:, 4].min()), float(a[:, 4].max())],
        "final_airspeed": float(np.linalg.norm(a[-1, 6:9])),
        "max_flap": float(a[:, 9].max()),
    }


def ending(run: dict[str, Any]) -> str:
    flags = [k for k, v in run["info"].items() if v and k in ("collision", "out_of_bounds", "env_complete")]
    return ", ".join(flags) or ("truncated" if run["truncated"] else "terminated")


def run_compat(seeds: list[int], kwargs: dict[str, float]) -> list[dict[str, Any]]:
    import gymnasium

    import pyflyt_engine.compat.gym_envs  # noqa: F401

    runs = []
    for seed in seeds:
        env = gymnasium.make("PyFlyt/Fixedwing-Waypoints-v3", **kwargs)
        env.reset(seed=seed)
        u = env.unwrapped
        rows, term, trunc, info = [], False, False, {}
        while not (term or trunc):
            _, _, term, trunc, info = env.step(np.array(ACTION, dtype=np.float64))
            s = np.asarray(u.env.state(0))
            aux = np.asarray(u.env.aux_state(0))  # ours: the motor, then the five surfaces
            rows.append([*s[0], *s[1], *s[2], float(np.abs(aux[1:6]).max())])
        runs.append(
            {
                "seed": seed,
                "rows": rows,
                "terminated": bool(term),
                "truncated": bool(trunc),
                "info": {k: bool(v) for k, v in info.items() if isinstance(v, (bool, np.bool_))},
            }
        )
        env.close()
    return runs


def run_native(seeds: list[int], kwargs: dict[str, float]) -> list[dict[str, Any]]:
    from pyflyt_engine.envs import make_env

    runs = []
    for seed in seeds:
        env = make_env(ROOT / "conf" / "env" / "fixedwing_waypoints.yaml", **kwargs)
        env.reset(seed=seed)
        vehicle = env.vehicle
        rows, term, trunc, info = [], False, False, {}
        while not (term or trunc):
            _, _, term, trunc, info = env.step(np.array(ACTION, dtype=np.float32))
            s = vehicle.state
            rows.append([*s.ang_vel, *s.ang_pos, *s.lin_vel, float(np.abs(vehicle.surface_command).max())])
        runs.append(
            {
                "seed": seed,
                "rows": rows,
                "terminated": bool(term),
                "truncated": bool(trunc),
                "info": {k: bool(v) for k, v in info.items() if isinstance(v, (bool, np.bool_))},
            }
        )
        env.close()
    return runs


def run_batched(seeds: list[int], kwargs: dict[str, float]) -> list[dict[str, Any]]:
    """The native -v0 on the batched backend: one batch of ``len(seeds)`` copies, seeded with
    the first seed (its spawn noise comes from the batch's own streams, not the PyBullet
    env's per-seed ones).  Read from the observations (Euler angles): body rates,
    attitude, body velocity, and the surfaces' aux entries (deflection over its limit);
    an ending copy's last row is its ``final_obs`` (same-step autoreset)."""
    from pyflyt_engine.envs import make_batched_env

    n = len(seeds)
    env = make_batched_env(
        "PyFlyt/Fixedwing-Waypoints-v0", n_envs=n, seed=seeds[0], angle_representation="euler", **kwargs
    )
    env.reset(seed=seeds[0])
    rows: list[list[list[float]]] = [[] for _ in range(n)]
    runs: list[dict[str, Any] | None] = [None] * n
    action = np.tile(np.array(ACTION, dtype=np.float64), (n, 1))
    while any(r is None for r in runs):
        obs, _, term, trunc, info = env.step(action)
        seen = np.where((term | trunc)[:, None], info.get("final_obs", obs), obs)
        for i in range(n):
            if runs[i] is not None:
                continue
            o = seen[i]
            rows[i].append([*o[0:9], float(np.abs(o[17:22]).max())])
            if term[i] or trunc[i]:
                flags = {k: bool(info[k][i]) for k in ("collision", "out_of_bounds", "env_complete")}
                runs[i] = {
                    "seed": i,
                    "rows": rows[i],
                    "terminated": bool(term[i]),
                    "truncated": bool(trunc[i]),
                    "info": flags,
                }
    env.close()
    return runs  # type: ignore[return-value]


def trims_and_flights() -> dict[str, Any]:
    from pyflyt_engine.spec import load_uav_spec
    from pyflyt_engine.world import VehicleConfig, World
    from tests.vehicles.aero import level_trim, straight_trim

    spec = load_uav_spec("fixedwing")
    out: dict[str, Any] = {"level_trim": {v: level_trim(spec, v) for v in (14.0, 20.0)}}
    trim = straight_trim(spec, 14.0)
    out["straight_trim_14"] = trim
    flights = {}
    for label, roll, yaw in (
        ("trimmed", trim["roll_channel"], trim["yaw_channel"]),
        ("neutral aileron and rudder", 0.0, 0.0),
    ):
        world = World([VehicleConfig(spec, (0.0, 0.0, 200.0), (0.0, trim["pitch"], 0.0), mode="channels")], seed=0)
        world.vehicles[0].reset(lin_vel=trim["velocity_body"])
        world.set_setpoint(0, [roll, trim["pitch_channel"], yaw, trim["thrust_channel"]])
        states = []
        for _ in range(round(10 * world.agent_hz)):
            world.step()
            states.append(world.state(0))
        world.close()
        att = np.array([s.ang_pos for s in states])
        rates = np.array([s.ang_vel for s in states])
        z = np.array([s.lin_pos[2] for s in states])
        flights[label] = {
            "max_abs_roll_deg": math.degrees(float(np.abs(att[:, 0]).max())),
            "heading_change_deg": math.degrees(float(np.unwrap(att[:, 2])[-1] - att[0, 2])),
            "altitude_range": [float(z.min()), float(z.max())],
            "max_rates": np.abs(rates).max(axis=0).tolist(),
        }
    out["flights_10s"] = flights
    return out


def run_reference(python: str, seeds: list[int]) -> dict[str, Any] | None:
    if not python or not Path(python).exists():
        return None
    result = subprocess.run(
        [python, "-c", REFERENCE_SCRIPT],
        check=False,
        input=json.dumps({"seeds": seeds, "action": ACTION, "cases": CASES}),
        capture_output=True,
        text=True,
        cwd="/",
    )
    for line in reversed(result.stdout.splitlines()):
        if line.startswith("RESULT "):
            return json.loads(line[len("RESULT ") :])
    raise RuntimeError(f"the reference run failed:\n{result.stderr[-3000:]}")


def git_commit() -> str:
    try:
        return subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"], check=False, cwd=ROOT, capture_output=True, text=True
        ).stdout.strip()
    except OSError:
        return "?"


def row(name: str, run: dict[str, Any], hz: int) -> str:
    s = summarise(run["rows"], hz)
    m = s["max_rates_before_last"]
    last = s["rates_last"]
    return (
        f"| {name} | {run['seed']} | {s['steps']} | {ending(run)} | {m[0]:.2f} / {m[1]:.2f} / {m[2]:.2f} | "
        f"{abs(last[0]):.2f} / {abs(last[1]):.2f} / {abs(last[2]):.2f} | {s['mean_roll_rate_first_s']:+.3f} | "
        f"{s['roll_range'][0]:+.2f} .. {s['roll_range'][1]:+.2f} | {s['pitch_range'][0]:+.2f} .. {s['pitch_range'][1]:+.2f} | "
        f"{s['final_airspeed']:.1f} | {s['max_flap']:.3f} |"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--reference-python", default=DEFAULT_REFERENCE)
    parser.add_argument("--seeds", type=int, default=5, help="seeds 0 .. N-1 per env (1 to 50)")
    parser.add_argument("--out", type=Path, default=ROOT / "experiments" / "results" / "fixedwing_neutral_stick.md")
    args = parser.parse_args()
    if not 1 <= args.seeds <= 50:
        parser.error(f"--seeds {args.seeds}: give a count from 1 to 50")
    seeds = list(range(args.seeds))

    t0 = time.perf_counter()
    ref = run_reference(args.reference_python, seeds)
    compat = {label: run_compat(seeds, kwargs) for label, kwargs in CASES.items()}
    native = {label: run_native(seeds, kwargs) for label, kwargs in CASES.items()}
    batched = {label: run_batched(seeds, kwargs) for label, kwargs in CASES.items()}
    oracle = trims_and_flights()
    seconds = time.perf_counter() - t0

    header = (
        "| env | seed | steps | ending | max abs p / q / r before the last step [rad/s] | abs p / q / r on the last step | "
        "mean p, first 1 s [rad/s] | roll [rad] | pitch [rad] | final airspeed [m/s] | max abs flap |"
    )
    lines = [
        "# The fixed-wing at neutral stick and half thrust, beside the reference PyFlyt 0.29.0",
        "",
        (
            f"`python experiments/fixedwing_neutral_stick.py` at commit {git_commit()}, "
            f"{datetime.now(timezone.utc).strftime('%Y-%m-%d %H:%M UTC')}, {seconds:.0f} s, "
            f"{platform.machine()}, Python {platform.python_version()}, load {os.getloadavg()[0]:.1f}."
        ),
        "",
        (
            f"Constant action {ACTION} (aileron, elevator, rudder, thrust), every env at 30 agent steps/s.  "
            "Rates are body rates (p roll, q pitch, r yaw); +p rolls the right wing down, Euler pitch < 0 is nose up.  "
            "The reference's `-v3` and the compat `-v3` spawn at (0, 0, 10) flying 20 m/s and fly its thrust entry "
            "as T / 2 + 0.5 = 0.75; the native `-v0` spawns 20 m up at 14 m/s and flies 0.5.  "
            'What the numbers mean: docs/migrating_from_pyflyt.md, "The fixed-wing\'s neutral stick".'
        ),
        "",
    ]
    if ref is None:
        lines += [f"The reference interpreter `{args.reference_python}` is missing: its rows are left out.", ""]
    for label, kwargs in CASES.items():
        lines += [
            f"## {label}" + (f" (`{kwargs}`)" if kwargs else " (the ids as registered)"),
            "",
            header,
            "|" + "---|" * 11,
        ]
        if ref is not None:
            lines += [row("reference -v3", r, 30) for r in ref[label]]
        lines += [row("compat -v3", r, 30) for r in compat[label]]
        lines += [row("native -v0", r, 30) for r in native[label]]
        lines += [row("native -v0, batched (copy)", r, 30) for r in batched[label]]
        lines.append("")

    lt = oracle["level_trim"]
    st = oracle["straight_trim_14"]
    lines += [
        "## Static trims of the native airframe (tests/vehicles/aero.py)",
        "",
        "| speed | trim | Euler pitch [rad] | elevator | aileron | rudder | sideslip [rad] | thrust [N] (channel) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for v, t in lt.items():
        lines.append(
            f"| {v:.0f} m/s | pitch plane (`level_trim`) | {t['pitch']:+.4f} | {t['pitch_channel']:+.4f} | - | - | - | {t['thrust']:.3f} |"
        )
    lines.append(
        f"| 14 m/s | six equations, reaction torque (`straight_trim`) | {st['pitch']:+.4f} | {st['pitch_channel']:+.4f} | "
        f"{st['roll_channel']:+.4f} | {st['yaw_channel']:+.4f} | {st['beta']:+.4f} | {st['thrust']:.3f} ({st['thrust_channel']:.4f}) |"
    )
    lines += [
        "",
        "## 10 s from the straight trim at 14 m/s, 200 m up (World, seed 0)",
        "",
        "| aileron, rudder | max abs roll [deg] | heading change [deg] | altitude [m] | max abs p / q / r [rad/s] |",
        "|---|---|---|---|---|",
    ]
    for label, f in oracle["flights_10s"].items():
        r = f["max_rates"]
        lines.append(
            f"| {label} | {f['max_abs_roll_deg']:.2f} | {f['heading_change_deg']:+.2f} | "
            f"{f['altitude_range'][0]:.2f} .. {f['altitude_range'][1]:.2f} | {r[0]:.4f} / {r[1]:.4f} / {r[2]:.4f} |"
        )
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("\n".join(lines) + "\n")

    def table(runs: list[dict[str, Any]]) -> list[dict[str, Any]]:
        return [{"seed": r["seed"], "ending": ending(r), **summarise(r["rows"], 30)} for r in runs]

    summary = {
        "cases": CASES,
        "reference": {label: table(runs) for label, runs in ref.items()} if ref else None,
        "compat": {label: table(runs) for label, runs in compat.items()},
        "native": {label: table(runs) for label, runs in native.items()},
        "batched": {label: table(runs) for label, runs in batched.items()},
        "oracle": {**oracle, "level_trim": {str(k): v for k, v in lt.items()}},
    }
    args.out.with_suffix(".json").write_text(json.dumps(summary, indent=1) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
