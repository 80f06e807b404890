"""The library's version, in one place: pyproject.toml, `graspmanifold.__version__`, `--version`
and the metadata of every saved file read it from here."""

__version__ = "0.1.0"
