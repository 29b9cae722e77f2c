"""The reference's ``PyFlyt.core.wind`` (empty there too in 0.29.0); wind fields derive from
:class:`~pyflyt_engine.compat.core.abstractions.WindFieldClass`."""
