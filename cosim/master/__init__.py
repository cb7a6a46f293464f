"""The co-simulation master: integer-tick scheduler, ME integration (RK4 / implicit), CS stepping,
zero-order hold, routing, recorder, and result writing."""

from cosim.master.compiled import CompiledLoop
from cosim.master.engine import Engine, RunResult, engine_for
from cosim.master.loop import PythonLoop
from cosim.master.output import plot_results, read_results, write_results
from cosim.master.run import run, run_config
from cosim.master.schedule import TimeBase
from cosim.master.summary import summarize

__all__ = ["Engine", "PythonLoop", "CompiledLoop", "engine_for", "RunResult", "TimeBase", "run",
           "run_config", "write_results", "read_results", "plot_results", "summarize"]
