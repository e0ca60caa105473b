"""The package version (one place; read by the build and by ``gloffset --version``)."""

__version__ = "0.1.0"
