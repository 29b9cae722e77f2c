"""Where the shipped configuration lives, in a checkout and in an installed wheel."""

from __future__ import annotations

from pathlib import Path

_PACKAGE_DIR = Path(__file__).resolve().parent


def conf_dir() -> Path:
    """The ``conf/`` directory: packaged inside the wheel, or the checkout's top level."""
    packaged = _PACKAGE_DIR / "conf"
    if packaged.is_dir():
        return packaged
    checkout = _PACKAGE_DIR.parent / "conf"
    if checkout.is_dir():
        return checkout
    raise FileNotFoundError(
        f"cannot find the configuration directory: looked in {packaged} and {checkout}; "
        "reinstall the package (pip install .) or run from a checkout of the repository"
    )


def uav_dir() -> Path:
    """The directory of shipped airframes (``conf/uav``)."""
    return conf_dir() / "uav"
