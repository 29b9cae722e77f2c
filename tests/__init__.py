"""The test suite.  The engine is imported first so that it pins the numeric kernels
before NumPy or PyTorch load (pyflyt_engine/numerics.py), as the ``pyflyt`` command does."""

import pyflyt_engine  # noqa: F401
