"""The Modelica compiler: rumoca front end -> CasADi lowering (index reduction, causalisation) -> FMI 3.0 FMU.

The lowered model (:class:`LoweredModel`) is public: calibration and diagnosis use its CasADi functions for
exact derivatives of the same equations the FMU contains.
"""

from cosim.compile.build import build_all, build_fmu, lower, read_model_list
from cosim.compile.model import LoweredModel, ModelVariable

__all__ = ["lower", "build_fmu", "build_all", "read_model_list", "LoweredModel", "ModelVariable"]
