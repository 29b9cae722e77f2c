"""Output files of CLI commands (pictures, plots, videos, reports): checks, then safe writes.

A command never writes over its input or over a file of another kind: an existing
output is replaced only when its first bytes say it is the same kind of file
(:func:`check_output`).  Every output is written through :func:`atomic_output`: to a
temporary file beside it, renamed into place only once complete, so a failed write (a
full disk, a read-only directory, a file-size limit) leaves the old file or nothing,
never a partial one, and is reported as one message naming the path and the reason.
"""

from __future__ import annotations

import contextlib
import os
import re
import secrets
from collections.abc import Iterator, Sequence
from pathlib import Path

from pyflyt_cli.errors import UsageError

#: largest image side [pixels]: the offscreen renderer is a CPU rasteriser
MAX_PIXELS = 4096

#: suffix -> (what it is, leading bytes a file of that kind starts with)
_KINDS: dict[str, tuple[str, tuple[bytes, ...]]] = {
    ".png": ("PNG image", (b"\x89PNG\r\n\x1a\n",)),
    ".gif": ("GIF image", (b"GIF8",)),
    ".pdf": ("PDF file", (b"%PDF",)),
    ".svg": ("SVG file", (b"<?xml", b"<svg")),
    ".mp4": ("MP4 video", ()),  # 'ftyp' at offset 4, checked below
}


def parse_size(text: str) -> tuple[int, int]:
    """``"640x480"`` -> (640, 480), each side 16 ... :data:`MAX_PIXELS` pixels."""
    match = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", text)
    if not match:
        raise UsageError(f"--size '{text}': write WIDTHxHEIGHT in pixels, e.g. 640x480")
    width, height = int(match.group(1)), int(match.group(2))
    if not (16 <= width <= MAX_PIXELS and 16 <= height <= MAX_PIXELS):
        raise UsageError(f"--size {width}x{height}: each side must be between 16 and {MAX_PIXELS} pixels")
    return width, height


def _same_kind(path: Path, suffix: str) -> bool:
    with path.open("rb") as handle:
        head = handle.read(16)
    if suffix == ".mp4":
        return head[4:8] == b"ftyp"
    return any(head.startswith(magic) for magic in _KINDS[suffix][1])


def check_output(
    path: Path, option: str, suffixes: Sequence[str], protected: Sequence[Path] = (), input_name: str = "an input file"
) -> Path:
    """Refuse an output path with the wrong suffix, that is an input, or would replace another kind of file.

    Args:
        path: the output the user asked for.
        option: the command-line option it came from (named in messages).
        suffixes: accepted file endings (keys of the known kinds: .png .gif .pdf .svg .mp4).
        protected: input files that must never be overwritten.
        input_name: how messages call those inputs (e.g. "the input recording").

    Raises:
        UsageError: naming the option, the path and what to do instead.
    """
    endings = " or ".join(suffixes)
    suffix = path.suffix.lower()
    if suffix not in suffixes:
        raise UsageError(f"{option} {path}: give a file name ending in {endings}")
    if path.is_dir():
        raise UsageError(f"{option} {path}: is a directory; give a file name ending in {endings}")
    if path.exists():
        resolved = path.resolve()
        if any(resolved == p.resolve() for p in protected):
            raise UsageError(f"{option} {path}: that is {input_name}; refusing to overwrite it")
        if not _same_kind(path, suffix):
            raise UsageError(
                f"{option} {path}: the file exists and is not a {_KINDS[suffix][0]}; refusing to overwrite it "
                "(choose another name or delete it)"
            )
    if not path.parent.is_dir():
        raise UsageError(f"{option} {path}: the directory {path.parent} does not exist; create it first")
    return path


def _reason(exc: OSError) -> str:
    """The operating system's reason for ``exc`` in a few words (e.g. 'No space left on device')."""
    if exc.strerror:
        return exc.strerror
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


@contextlib.contextmanager
def atomic_output(path: Path, option: str | None = None) -> Iterator[Path]:
    """Write ``path`` all at once: yields a temporary path to write to, renamed over ``path`` on success.

    The temporary file sits in the same directory (so the rename is atomic) and keeps
    ``path``'s suffix (writers choose the format by it); the writer creates it, so it gets
    the usual permissions.  If the block fails, the temporary file is removed and ``path``
    is left as it was.  Example::

        with atomic_output(out, "--plot") as tmp:
            fig.savefig(tmp)

    Raises:
        UsageError: the write or the rename failed with an OSError (full disk, read-only
            directory, file too large ...): one message naming the option, ``path`` and
            the reason.  Other exceptions propagate unchanged (after the clean-up).
    """
    path = Path(path)
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.{secrets.token_hex(4)}.tmp{path.suffix}")
    try:
        yield tmp
        os.replace(tmp, path)
    except OSError as exc:
        where = f"{option} {path}" if option else str(path)
        raise UsageError(f"{where}: cannot write the file: {_reason(exc)}; the file was not changed") from None
    finally:
        tmp.unlink(missing_ok=True)


def make_output_dir(path: Path, option: str | None = None) -> Path:
    """Create the directory ``path`` (and its parents) for outputs; UsageError naming it and the reason."""
    where = f"{option} {path}" if option else str(path)
    if path.exists() and not path.is_dir():
        raise UsageError(f"{where}: is a file, not a directory; give a directory for the outputs")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"{where}: cannot create the output directory: {_reason(exc)}") from None
    return path
