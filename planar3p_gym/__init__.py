"""planar3p-gym: a 3-PRR planar parallel manipulator as a Gymnasium environment."""

from .design import Design

__all__ = ["Design"]
__version__ = "0.1.0"
