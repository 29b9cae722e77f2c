"""The reference's ``PyFlyt.core.utils``: :mod:`.load_objs`."""
