"""Everything that touches an FMU binary: reading model descriptions, safe unpacking, and driving
FMI 2.0 / 3.0 Model-Exchange and Co-Simulation instances. No other cosim module imports ctypes."""

from cosim.fmi.extract import safe_extract
from cosim.fmi.instance import FmuInstance, Port, check, value_dtype
from cosim.fmi.integrate import derivatives, rk4_steps
from cosim.fmi.model import ModelInfo, Variable, read_model_info

__all__ = ["FmuInstance", "Port", "check", "value_dtype", "safe_extract", "read_model_info", "ModelInfo", "Variable",
           "derivatives", "rk4_steps"]
