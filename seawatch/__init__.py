"""seawatch: a visual dimension for Vessel Traffic Services."""

__version__ = "0.1.0"
