"""The package version (one place; ``pyproject.toml`` gives the same to installers)."""

VERSION = "0.1.0"
