"""The figure of docs/atmosphere.md: a Dryden realisation and its spectrum against the specification.

Light turbulence (MIL-F-8785C, W20 = 15 kt) at 10 m, sampled at the physics rate (240 Hz)
by the engine's exact discretisation: top, 60 s of the linear gusts u, v, w; bottom, their
power spectral densities (Welch, 20 min of samples) over the specified Dryden spectra.

    python experiments/plot_dryden.py [--out docs/images/dryden_light.png] [--seed 0]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from scipy import signal

from pyflyt_engine.atmosphere import load_wind_config
from pyflyt_engine.atmosphere.dryden import DrydenProcess, low_altitude_scales, spectrum


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("docs/images/dryden_light.png"))
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    turbulence = load_wind_config("dryden_light").turbulence
    scales = low_altitude_scales(turbulence.height, turbulence.wind_speed_20ft)
    V, fs = turbulence.advection_speed, 240.0
    process = DrydenProcess(scales, V, [], 1 / fs, np.random.default_rng(args.seed))
    y = process.generate(int(20 * 60 * fs))
    t = np.arange(y.shape[1]) / fs
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 7), layout="constrained")
    colours = {"u": "tab:blue", "v": "tab:orange", "w": "tab:green"}
    shown = t <= 60
    for row, name in enumerate("uvw"):
        top.plot(t[shown], y[row, shown], lw=0.8, color=colours[name], label=f"{name} (σ = {np.std(y[row]):.2f} m/s)")
    top.set(
        xlabel="time [s]",
        ylabel="gust velocity [m/s]",
        title=(
            f"Dryden light turbulence at {turbulence.height:g} m, W20 = 15 kt, V = {V:.1f} m/s: "
            f"σu = σv = {scales.sigma_u:.2f}, σw = {scales.sigma_w:.2f} m/s"
        ),
    )
    top.title.set_fontsize(9)
    top.legend(fontsize=8, loc="upper right")
    for row, name in enumerate("uvw"):
        f, psd = signal.welch(y[row], fs=fs, nperseg=16384)
        keep = f > 0
        bottom.loglog(f[keep], psd[keep], lw=0.8, color=colours[name], alpha=0.6, label=f"{name}: Welch estimate")
        bottom.loglog(
            f[keep],
            2 * np.pi * spectrum(name, 2 * np.pi * f[keep], scales, V),
            "--",
            color=colours[name],
            lw=1.5,
            label=f"{name}: MIL-F-8785C spectrum",
        )
    bottom.set(xlabel="frequency [Hz]", ylabel="PSD [(m/s)² / Hz]", xlim=(1e-2, fs / 2))
    bottom.legend(fontsize=7, ncol=2)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
