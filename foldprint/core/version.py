"""foldprint's version: the one place it is written (``pyproject.toml`` reads it, the
package re-exports it as ``foldprint.__version__``, every writer stamps its files with it)."""

__version__ = "0.1.0"
