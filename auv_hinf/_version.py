"""The package version (one source: pyproject reads it, the certificate files record it)."""

__version__ = "0.3.0"
