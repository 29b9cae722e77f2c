"""``pyflyt export <run dir | zoo:name> format=onnx|c [out=<path>] [model=auto] [--force]``: write the
deterministic policy for a flight controller (:mod:`pyflyt_cli.export`), print what was written."""

from __future__ import annotations

import typer

from pyflyt_cli.commands import parse_overrides
from pyflyt_cli.errors import UsageError

#: the keys ``pyflyt export`` takes, and what each means (the help and the unknown-key message)
KEYS = {
    "format": "onnx | c",
    "out": "the .onnx file, or the .c file (its .h goes beside it); default policy.onnx / policy.c",
    "model": "auto | best | final | latest (as pyflyt eval)",
}


def parse_export_args(overrides: list[str]) -> dict[str, str]:
    """``key=value`` words -> options; an unknown or repeated key, or no format, is a :class:`UsageError`."""
    options: dict[str, str] = {}
    for item in parse_overrides(overrides):
        key, _, value = item.partition("=")
        key = key.lstrip("+")
        if key not in KEYS:
            from pyflyt_engine.suggest import did_you_mean

            known = ", ".join(f"{k}= ({v})" for k, v in KEYS.items())
            raise UsageError(f"unknown key {key!r} in '{item}'.{did_you_mean(key, KEYS)} pyflyt export takes {known}")
        if key in options:
            raise UsageError(f"{key}= given twice ({key}={options[key]} and {item}): give it once")
        if not value:
            raise UsageError(f"{key}= needs a value: {key}=<{KEYS[key]}>")
        options[key] = value
    if "format" not in options:
        out = options.get("out", "")
        inferred = {".onnx": "onnx", ".c": "c"}.get(out[out.rfind(".") :].lower() if "." in out else "")
        if inferred is None:
            raise UsageError(
                "format= is missing: write format=onnx or format=c (e.g. pyflyt export zoo:quadx_hover_ppo format=c out=policy.c)"
            )
        options["format"] = inferred
    return options


def run_export(source: str, overrides: list[str], *, force: bool = False) -> object:
    """Export ``source`` as the ``key=value`` overrides say; print the files and what they hold."""
    from pyflyt_cli.export import PROBES, export_policy

    options = parse_export_args(overrides)
    result = export_policy(
        source, options["format"], options.get("out"), model=options.get("model", "auto"), force=force
    )
    about = result.about
    act = about["action"]
    typer.echo(f"policy:  {about['run']}  {about['model']} ({about['which']}), {about['algo']}, step {about['step']}")
    typer.echo(f"env:     {about['env_id']} at {about['agent_hz']:g} Hz, flight mode {act['mode']}")
    typer.echo(f"input:   {about['observation']['size']} floats, the env's raw observation")
    typer.echo(f"output:  {act['size']} floats, the action the env receives: {', '.join(act['names'])}")
    typer.echo("inside:  " + "\n         ".join(about["steps"]))
    for path in result.files:
        typer.echo(f"wrote:   {path}")
    if result.check is not None:
        typer.echo(
            f"checked: onnxruntime gives the PyTorch chain's actions within {result.check:.2g} on {PROBES} probe observations"
        )
    return result
