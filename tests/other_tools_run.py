"""Run an FMI 2.0 Co-Simulation FMU under constant inputs in another tool's master, libcosim (libcosimpy) or Ecos
(ecospy), and print the outputs after each communication step as JSON rows ``[time, output...]``.

A script, run in a subprocess by tests/test_other_tools.py: these masters crashed (SIGSEGV) on FMUs they could not
handle, and a crash must fail the test, not end the test session.
    python tests/other_tools_run.py TOOL FMU INPUTS_JSON OUTPUTS_JSON STEP STOP
    python tests/other_tools_run.py libcosim-ssp SSP '{}' OUTPUTS_JSON STEP STOP  (outputs "instance.variable")
"""

import json
import sys


def run_libcosim(fmu, inputs, outputs, step, stop):
    """libcosim: a fixed-step execution of one slave, read back through a last-value observer."""
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    execution = CosimExecution.from_step_size(round(step * 1e9))  # ns
    index = execution.add_local_slave(CosimLocalSlave(fmu_path=fmu, instance_name="plant"))
    refs = {v.name.decode(): v.reference for v in execution.slave_variables(index)}
    for name, value in inputs.items():
        execution.real_initial_value(index, refs[name], value)
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)
    vrs = [refs[name] for name in outputs]
    rows = []
    for k in range(round(stop / step)):
        if not execution.step(1):
            raise RuntimeError(f"libcosim: step {k} failed")
        rows.append([(k + 1) * step, *observer.last_real_values(index, vrs)])
    return rows


def run_libcosim_ssp(ssp, inputs, outputs, step, stop):
    """libcosim's SSP loader: the system of an SSP archive (its FMUs, connections, parameter sets), fixed-step."""
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimObserver import CosimObserver

    execution = CosimExecution.from_ssp_file(ssp, round(step * 1e9))  # ns
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)
    reads = []
    for signal in outputs:
        instance, _, name = signal.partition(".")
        index = execution.slave_index_from_instance_name(instance)
        refs = {v.name.decode(): v.reference for v in execution.slave_variables(index)}
        reads.append((index, refs[name]))
    rows = []
    for k in range(round(stop / step)):
        if not execution.step(1):
            raise RuntimeError(f"libcosim: step {k} failed")
        rows.append([(k + 1) * step, *(observer.last_real_values(index, [ref])[0] for index, ref in reads)])
    return rows


def run_ecos(fmu, inputs, outputs, step, stop):
    """Ecos: one model in a simulation structure, inputs given as its initial parameter set."""
    from ecospy import EcosSimulation, EcosSimulationStructure

    rows = []
    with EcosSimulationStructure() as structure:
        structure.add_model("plant", fmu)
        structure.add_parameter_set("initial", {f"plant::{name}": value for name, value in inputs.items()})
        with EcosSimulation(structure=structure, step_size=step) as sim:
            sim.init(parameter_set="initial")
            for _ in range(round(stop / step)):
                sim.step()
                rows.append([sim.get_time(), *(sim.get_real(f"plant::{name}") for name in outputs)])
            sim.terminate()
    return rows


if __name__ == "__main__":
    tool, fmu, inputs, outputs, step, stop = sys.argv[1:]
    run = {"libcosim": run_libcosim, "libcosim-ssp": run_libcosim_ssp, "ecos": run_ecos}[tool]
    print(json.dumps(run(fmu, json.loads(inputs), json.loads(outputs), float(step), float(stop))))
