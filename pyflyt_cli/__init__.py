"""pyflyt_cli: the ``pyflyt`` command line (Typer) and its Hydra configuration glue."""
