"""cosim: Modelica plants compiled to FMUs, co-simulated against Python controllers at their real rates."""

__version__ = "0.1.0"
__all__ = ["__version__"]
