"""Data files shipped with fieldmap (read them through importlib.resources)."""
