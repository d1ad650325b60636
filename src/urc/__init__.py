"""urc — the Universal Rotator Controller."""

__version__ = "0.1.0"
