"""The ``pyflyt`` command line.

Commands take Hydra-style ``key=value`` overrides of the configs in ``conf/``; every
user error prints one clear message and exits with code 2, never a traceback.
"""

from __future__ import annotations

import functools
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any, Optional

try:
    import typer
except ImportError as exc:  # the simulator was installed without the command's extra
    raise SystemExit(
        f"error: the pyflyt command needs its extra ({exc}): pip install 'pyflyt-toolkit[cli]' "
        "(after pip install torch==2.13.0, so that PyTorch comes without CUDA)"
    ) from None

from pyflyt_engine.errors import PyFlytError


def _untyped_flags(params: Any) -> None:
    """Blank the metavar of every on/off flag in ``params``: it is what the type column of
    typer's rich help shows, ``<bool>`` beside a flag (``--verify <bool>``), which reads as
    if it took a value.  A flag takes no value, so no usage line or message shows it."""
    for param in params:
        if getattr(param, "is_flag", False) and param.metavar is None:
            param.metavar = ""


class _UntypedFlags:
    """Mixed into Typer's command and group classes: ``--help`` lists their flags (``--help``
    included) without a value type."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        _untyped_flags(self.params)  # type: ignore[attr-defined]

    def get_help_option(self, ctx: Any) -> Any:
        option = super().get_help_option(ctx)  # type: ignore[misc]
        _untyped_flags([option])
        return option


class _SuggestedOptions:
    """Mixed into Typer's command class: a misspelt ``--option`` gets the one closest option
    of :func:`pyflyt_engine.suggest.closest` (``--vidoe``: did you mean --video?), as every
    other name a user types does."""

    def parse_args(self, ctx: Any, args: list[str]) -> list[str]:
        from pyflyt_engine.suggest import closest

        try:
            return super().parse_args(ctx, args)  # type: ignore[misc]
        except Exception as exc:  # Typer's own copy of Click's NoSuchOption (no public import path)
            if type(exc).__name__ != "NoSuchOption" or not hasattr(exc, "possibilities"):
                raise
            names = [o for p in self.params for o in (*p.opts, *p.secondary_opts) if o.startswith("--")]  # type: ignore[attr-defined]
            meant = closest(exc.option_name, names)  # type: ignore[attr-defined]
            exc.possibilities = [meant] if meant is not None else []
            raise


class _Command(_SuggestedOptions, _UntypedFlags, typer.core.TyperCommand):
    """A command whose ``--help`` lists its flags without a value type and whose misspelt
    options get the closest one."""


class _Group(_UntypedFlags, typer.core.TyperGroup):
    """A command group whose ``--help`` lists its flags without a value type."""


class _App(typer.Typer):
    """:class:`typer.Typer` building its group and its commands from :class:`_Group` and :class:`_Command`."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(cls=_Group, **kwargs)

    def command(self, *args: Any, **kwargs: Any) -> Any:
        return super().command(*args, **{"cls": _Command, **kwargs})


app = _App(
    name="pyflyt",
    help="UAV simulation and reinforcement-learning toolkit (PyFlyt paper).",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


@app.callback()
def _check_numerics() -> None:
    # PYFLYT_NUMERICS (pinned | native) is read when pyflyt_engine loads; a value it does not
    # know is refused here, before any command runs
    from pyflyt_engine.numerics import check_mode

    try:
        check_mode()
    except ValueError as exc:
        typer.secho(f"error: {exc}", err=True, fg=typer.colors.RED)
        raise typer.Exit(code=2) from None


def user_errors(func: Callable[..., Any]) -> Callable[..., Any]:
    """Turn library errors into a one-line message on stderr and exit code 2."""

    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return func(*args, **kwargs)
        except PyFlytError as exc:
            typer.secho(f"error: {exc}", err=True, fg=typer.colors.RED)
            raise typer.Exit(code=2) from None

    return wrapper


@app.command(
    context_settings={"allow_extra_args": False},
    help="Fly one vehicle toward a setpoint and print a trajectory summary.\n\n"
    "Overrides (key=value) of conf/fly.yaml, e.g.:\n\n"
    "  pyflyt fly uav=quadx_cf2x mode=position_yaw setpoint=[0,0,0,1] duration=10\n\n"
    "  pyflyt fly uav=quadx_f450 mode=velocity_yawrate 'setpoint={vx:1}'\n\n"
    "  pyflyt fly uav=path/to/my_airframe.yaml",
)
@user_errors
def fly(overrides: Optional[list[str]] = typer.Argument(None, help="key=value overrides")) -> None:
    from pyflyt_cli.commands.fly import run_fly

    run_fly(overrides or [])


@app.command(help="List the flight modes, their PyFlyt numbers and setpoint layouts.")
def modes() -> None:
    from pyflyt_cli.catalog import list_modes

    typer.echo(list_modes())


@app.command(
    help="List the Gymnasium environments: spaces, reward presets and defaults.\n\n"
    "With an env (a Gymnasium id, a multi-agent env or an env config), print its full manual, written from its "
    "config and spaces:\n\n"
    "  pyflyt envs PyFlyt/QuadX-Hover-v0\n\n"
    "  pyflyt envs quadx_gates_state"
)
@user_errors
def envs(
    name: Optional[str] = typer.Argument(
        None, help="Gymnasium id (PyFlyt/QuadX-Hover-v0), multi-agent env (ma_quadx_hover_v0) or env config name"
    ),
) -> None:
    if name is None:
        from pyflyt_cli.catalog import list_envs

        typer.echo(list_envs())
        return
    from pyflyt_engine.envs.manual import env_manual

    typer.echo(env_manual(name), nl=False)


def _train_help() -> str:
    from pyflyt_cli.commands.train import train_help

    return train_help()


@app.command(help=_train_help(), context_settings={"allow_extra_args": False})
@user_errors
def train(
    overrides: Optional[list[str]] = typer.Argument(None, help="key=value overrides of conf/train.yaml"),
    multirun: bool = typer.Option(
        False, "--multirun", "-m", help="one run per combination of swept values (seed=0,1,2)"
    ),
    show_cfg: bool = typer.Option(False, "--cfg", help="print the composed, validated configuration and exit"),
) -> None:
    from pyflyt_cli.commands.train import run_train

    code = run_train(overrides or [], multirun=multirun, show_config=show_cfg)
    if code:
        raise typer.Exit(code=code)


@app.command(
    "eval",
    help="Evaluate a trained run: N episodes, a returns table, each episode to <run>/episodes/*.mcap.\n\n"
    "Overrides of conf/eval.yaml: episodes=10 seed=<run seed + 1000> deterministic=true "
    "model=auto|best|final|latest record=true video=out.gif\n\n"
    "  pyflyt eval runs/quadx_hover/ppo/<time>-seed0 episodes=20 video=hover.gif\n\n"
    "env.<key>=value and env.task.<option>=value fly the run's policy in its env with that changed "
    "(spaces unchanged):\n\n"
    "  pyflyt eval <run> env.wind=dryden_severe env.max_duration_seconds=30\n\n"
    "oracle:<name> flies a scripted controller (rocket_lander) in its env instead, into a new "
    "runs/<env>/oracle_<name>/<time>-seed<k>; other keys set the env as in pyflyt train:\n\n"
    "  pyflyt eval oracle:rocket_lander episodes=50 seed=0 env.task.start_position_noise=0",
)
@user_errors
def eval_(
    run_dir: str = typer.Argument(
        ...,
        help="run directory written by pyflyt train, zoo:<name> (pyflyt zoo) or oracle:<name> (a scripted controller)",
    ),
    overrides: Optional[list[str]] = typer.Argument(None, help="key=value overrides of conf/eval.yaml"),
) -> None:
    from pyflyt_cli.commands.eval import run_eval

    run_eval(run_dir, overrides or [])


@app.command(
    "export",
    help="Write a trained run's deterministic policy for a flight controller: an ONNX file (format=onnx) or a "
    "dependency-free C99 source and header (format=c: float32 weights and "
    "void policy_forward(const float *obs, float *action)).  The observation normaliser, the squashing or "
    "clipping and the rescaling to the env's action bounds are inside: the function takes the env's raw "
    "observation and returns the action the env receives (docs/deploy.md).  An existing output is replaced "
    "only with --force.  Recurrent and image policies are refused.\n\n"
    "Keys: format=onnx|c  out=<file.onnx | file.c> (default policy.onnx / policy.c)  model=auto|best|final|latest\n\n"
    "  pyflyt export zoo:quadx_hover_ppo format=c out=hover_policy.c\n\n"
    "  pyflyt export runs/quadx_hover/ppo/<time>-seed0 format=onnx out=hover.onnx",
)
@user_errors
def export_(
    source: str = typer.Argument(..., help="run directory written by pyflyt train, or zoo:<name> (pyflyt zoo)"),
    overrides: Optional[list[str]] = typer.Argument(None, help="format=onnx|c out=<path> model=auto|best|final|latest"),
    force: bool = typer.Option(False, "--force", help="replace output files that exist"),
) -> None:
    from pyflyt_cli.commands.export import run_export

    run_export(source, overrides or [], force=force)


@app.command(
    help="Summarise a recorded episode (.mcap); optionally re-simulate it, render a video, plot it.\n\n"
    "Prints vehicles, duration, return, success and per-term reward totals.  --verify rebuilds the env "
    "from the file's metadata, re-applies the recorded actions and reports the largest state deviation "
    "(exit 1 if above --tolerance).  Bad files exit 2 with a message.\n\n"
    "  pyflyt replay runs/demo/episodes/ep_0000.mcap --verify --video out.mp4 --plot out.png",
)
@user_errors
def replay(
    file: Path = typer.Argument(..., help="episode recording (.mcap) written by RecordEpisode / pyflyt eval"),
    verify: bool = typer.Option(
        False, "--verify", help="re-simulate from the recorded metadata and actions; compare states"
    ),
    tolerance: float = typer.Option(1e-6, "--tolerance", help="largest state deviation --verify accepts [SI units]"),
    video: Optional[Path] = typer.Option(
        None, "--video", help="render the flight with a chase camera to this .mp4 or .gif"
    ),
    size: Optional[str] = typer.Option(
        None, "--size", help="video size WIDTHxHEIGHT (default: the env's render resolution)"
    ),
    plot: Optional[Path] = typer.Option(
        None, "--plot", help="draw 3-D path, altitude, attitude and actions to this .png/.pdf/.svg"
    ),
    as_json: bool = typer.Option(False, "--json", help="print the summary (and verify result) as JSON"),
) -> None:
    from pyflyt_cli.commands.replay import run_replay

    code = run_replay(file, verify=verify, tolerance=tolerance, video=video, size=size, plot=plot, as_json=as_json)
    if code:
        raise typer.Exit(code=code)


@app.command(
    help="Measure speed and memory on this machine: env steps/s, resets, real-time factor and peak memory of "
    "every env; worlds of 1, 8 and 64 QuadX; the multi-agent envs' agent-steps/s and real-time factor against "
    "the number of agents (1 to 128); a 128x128 camera capture; the bare-PyBullet floor; optionally "
    "vector envs (--vector).  Every case runs in a fresh process; figures are medians of --repeats runs.\n\n"
    "  pyflyt speed --vector --markdown",
)
@user_errors
def speed(
    repeats: int = typer.Option(5, "--repeats", min=1, help="runs per figure; the median is printed"),
    quick: bool = typer.Option(False, "--quick", help="tiny counts: check that everything runs (figures unreliable)"),
    vector: bool = typer.Option(
        False,
        "--vector",
        help="also measure 1 vs 2 subprocess workers (gymnasium async, SB3), a stand-in env of the "
        "same step cost, and the machine's own 1 vs 2 process scaling",
    ),
    markdown: bool = typer.Option(False, "--markdown", help="print the tables as Markdown (for docs/performance.md)"),
    env: Optional[list[str]] = typer.Option(
        None,
        "--env",
        help="env id to measure (repeatable; default: all; with "
        "--backend batched also an env config, e.g. quadx_waypoints_velocity)",
    ),
    vehicles: Optional[str] = typer.Option(None, "--vehicles", help="world sizes, comma-separated (default 1,8,64)"),
    agents: Optional[str] = typer.Option(
        None,
        "--agents",
        help="swarm sizes of the multi-agent curve, comma-separated (default 1,2,4,8,16,32,64,128; 0 skips it)",
    ),
    json_path: Optional[Path] = typer.Option(None, "--json", help="also write the full results to this JSON file"),
    backend: str = typer.Option(
        "pybullet",
        "--backend",
        help="pybullet (the sections above), or batched: the batched "
        "backend's agent-steps/s against the number of envs, beside the PyBullet env",
    ),
    batch_sizes: Optional[str] = typer.Option(
        None,
        "--batch-sizes",
        help="with --backend batched: env counts, comma-separated (default 1,16,64,256,1024,4096)",
    ),
) -> None:
    from pyflyt_cli.commands.speed import speed_command

    typer.echo(
        speed_command(
            repeats=repeats,
            quick=quick,
            vector=vector,
            markdown=markdown,
            envs=env,
            vehicles=vehicles,
            agents=agents,
            json_path=json_path,
            backend=backend,
            batch_sizes=batch_sizes,
            progress=lambda message: typer.echo(message, err=True),
        )
    )


@app.command(
    help="Run an experiment's benchmark grid (tasks x algorithms x seeds), resumably, and summarise it.\n\n"
    "Every run is one `pyflyt train` line (--dry-run prints them) trained in "
    "<benchmark>/runs/<task>/<algo>/seed<k>, in its own process with its log in <benchmark>/logs/.  Rerunning "
    "the same command skips complete runs, resumes interrupted ones and extends runs whose budget grew; a run "
    "trained with other settings is refused before anything trains (--restart-changed moves it aside and "
    "trains it afresh).  A failed run is reported and the others carry on.  seeds=N and jobs=J are short for "
    "benchmark.seeds and benchmark.jobs; other key=value overrides apply to every run "
    "(train.total_timesteps=...).  hydra/launcher=ray|submitit_slurm|... and hydra.launcher.<key>=<value> run "
    "them through a Hydra launcher instead of local processes.  "
    "Exit 0: all complete; 1: a run failed; 130: interrupted; 2: a user error, nothing trained.\n\n"
    "  pyflyt benchmark experiment=paper_rl seeds=5 jobs=2\n\n"
    "  pyflyt benchmark experiment=paper_rl hydra/launcher=ray\n\n"
    "  pyflyt plot benchmarks/paper_rl_laptop",
    context_settings={"allow_extra_args": False},
)
@user_errors
def benchmark(
    overrides: Optional[list[str]] = typer.Argument(None, help="experiment=<name> and key=value overrides"),
    dry_run: bool = typer.Option(
        False, "--dry-run", help="validate; print each run's state and pyflyt train line; train nothing"
    ),
    restart_changed: bool = typer.Option(
        False,
        "--restart-changed",
        help="train runs whose saved settings differ from the plan afresh (and the runs that start from them); "
        "their old directories move to <benchmark>/replaced/<time>/",
    ),
) -> None:
    from pyflyt_cli.commands.benchmark import benchmark_command

    code = benchmark_command(overrides or [], dry_run=dry_run, restart_changed=restart_changed)
    if code:
        raise typer.Exit(code=code)


@app.command(
    help="Search hyper-parameters with Optuna: trials=N training runs of env=<task> algo=<algo> over the search "
    "space conf/search_space/<algo>.yaml (space=<name or file> for another), jobs=J at once in separate "
    "processes; a trial whose evaluation curve falls below the others' median is pruned.  The study is kept in "
    "<study_dir>/study.db (SQLite; default tune/<env>_<algo>): the same command continues it.  It compares "
    "the best trial with a random policy and the shipped tuning by the spread of their evaluation returns, "
    "and only on a finding writes best_<env>_<algo>.yaml (a conf/hparams-style file: pyflyt train "
    "experiment=<file>) and importance.png; always trials.csv and history.png.  Other key=value overrides are fixed for every trial "
    "(train.total_timesteps=...).  Options and defaults: conf/tune.yaml.\n\n"
    "  pyflyt tune env=quadx_hover algo=sac trials=20 jobs=2 train.total_timesteps=30000",
    context_settings={"allow_extra_args": False},
)
@user_errors
def tune(
    overrides: Optional[list[str]] = typer.Argument(None, help="env=, algo=, tune options, training overrides"),
) -> None:
    from pyflyt_cli.commands.tune import run_tune

    code = run_tune(overrides or [])
    if code:
        raise typer.Exit(code=code)


@app.command(
    help="List the trained agents shipped with the package (name, env, algorithm, training steps, recorded "
    "evaluation return and success); fly one with pyflyt eval zoo:<name>.  --add <run dir> makes a run's best "
    "policy (else final) a shipped agent, evaluated now with pyflyt eval's defaults; an agent of that name "
    "already shipped is kept unless --replace.",
)
@user_errors
def zoo(
    add: Optional[str] = typer.Option(None, "--add", help="a training run directory to ship as an agent"),
    name: Optional[str] = typer.Option(None, "--name", help="the agent's name (default: <env>_<algo>)"),
    replace: bool = typer.Option(False, "--replace", help="with --add: replace a shipped agent of that name"),
) -> None:
    from pyflyt_cli import zoo as zoo_lib
    from pyflyt_engine.errors import ConfigError

    if replace and add is None:
        raise ConfigError("--replace goes with --add <run dir>: pyflyt zoo --add <run dir> --replace")
    if add is not None:
        made = zoo_lib.add_agent(add, name, replace=replace)
        e = made.summary["evaluation"]
        typer.echo(f"added {made.name}: return {e['mean_return']:.2f} ± {e['std_return']:.2f} ({made.path})")
    typer.echo(zoo_lib.table())


@app.command(
    help="Report a benchmark directory with rliable: IQM learning curves with 95 % stratified-bootstrap "
    "bands, median / IQM / mean / optimality gap with intervals, performance profiles and probability of "
    "improvement, as PNG and SVG figures plus report.md and report.json.  Reads "
    "<dir>/[runs/]<env>/<algo>/<run>/metrics.mcap; scores are normalised with <dir>/normalisation.yaml "
    "(random and reference score per env) when present.  Same data, --reps and --seed: same report.\n\n"
    "  pyflyt plot benchmarks/paper_rl_laptop --out figures --reps 5000",
)
@user_errors
def plot(
    benchmark_dir: Path = typer.Argument(..., help="benchmark directory (runs of several algorithms and seeds)"),
    out: Optional[Path] = typer.Option(None, "--out", help="output directory (default: <benchmark_dir>/report)"),
    reps: int = typer.Option(2000, "--reps", help="stratified-bootstrap replicates per statistic"),
    seed: int = typer.Option(0, "--seed", help="seed of the bootstrap (the report is reproducible)"),
) -> None:
    from pyflyt_cli.plotting import plot_benchmark

    report = plot_benchmark(benchmark_dir, out, reps=reps, seed=seed)
    typer.echo(f"report: {report.markdown}")
    for path in report.figures:
        typer.echo(f"figure: {path}")
    for name, why in report.skipped.items():
        typer.echo(f"not drawn: {name} ({why})")


uav_app = _App(
    help="Check and inspect airframe (UAV) YAML files: shipped names (quadx_cf2x) or paths.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
)
app.add_typer(uav_app, name="uav")


@uav_app.command(
    "validate",
    help="Load, validate and build (offline) each airframe; print 'ok: ...' or what to fix. "
    "Exits 2 if any file is invalid.\n\n  pyflyt uav validate quadx_cf2x my_hexacopter.yaml",
)
def uav_validate(files: list[str] = typer.Argument(..., help="YAML files or shipped names")) -> None:
    from pyflyt_cli.commands.uav import run_validate

    if run_validate(files):
        raise typer.Exit(code=2)


@uav_app.command(
    "show",
    help="Print mass, centre of mass, inertia, thrust-to-weight, components, channels and "
    "controller; optionally render a picture (offscreen) and the surfaces' C_L/C_D/C_M curves. "
    "With --env, also the env's payloads (bodies, mass, inertia, geometry, joints and tethers), "
    "drawn in the picture.\n\n"
    "  pyflyt uav show quadx_f450 --png f450.png --size 800x600\n\n"
    "  pyflyt uav show --env quadx_pole_balance --png pole.png",
)
@user_errors
def uav_show(
    file: Optional[str] = typer.Argument(
        None, help="YAML file or shipped name (default with --env: the env's airframe)"
    ),
    png: Optional[Path] = typer.Option(None, "--png", help="write a 3/4-view picture to this .png file"),
    size: str = typer.Option("640x480", "--size", help="picture size WIDTHxHEIGHT in pixels"),
    curves: Optional[Path] = typer.Option(
        None, "--curves", help="plot every lifting surface's coefficients to this .png"
    ),
    env: Optional[str] = typer.Option(
        None, "--env", help="also show this env config's payloads (shipped name in conf/env or a YAML path)"
    ),
) -> None:
    from pyflyt_cli.commands.uav import run_show

    run_show(file, png=png, size=size, curves=curves, env=env)


@uav_app.command(
    "schema", help="Print the reference of every airframe YAML field (Markdown: key, type, default, meaning)."
)
def uav_schema() -> None:
    from pyflyt_cli.airframes import schema_markdown

    typer.echo(schema_markdown(), nl=False)


def main() -> None:  # pragma: no cover - console entry
    app()


if __name__ == "__main__":  # pragma: no cover
    sys.exit(app())
