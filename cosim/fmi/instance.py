"""Load and drive one FMU (FMI 2.0 / 3.0, Model Exchange or Co-Simulation) through fmpy's low-level classes.

Every FMI call goes through :func:`check`, which raises :class:`cosim.errors.FmiCallError` with the
function name and the status label for any status worse than warning. The hot calls (set time,
set/get states and derivatives, get/set of real ports, ``doStep``) call the C entry points directly
with argument arrays built once, over numpy buffers the caller fills in place.
"""

import ctypes
import math
import shutil
import tempfile

import numpy as np

from cosim.errors import EventError, FmiCallError, SimulationTerminated
from cosim.fmi.extract import safe_extract
from cosim.fmi.model import read_model_info

__all__ = ["FmuInstance", "Port", "check", "value_dtype", "STATUS_LABELS"]

STATUS_LABELS = ("OK", "Warning", "Discard", "Error", "Fatal", "Pending")

# variable type -> (suffix of the Get/Set functions, C array dtype, dtype of a recorded column), per FMI version
_TYPES = {
    2: {"Real": ("Real", np.float64, np.float64), "Integer": ("Integer", np.int32, np.int32),
        "Enumeration": ("Integer", np.int32, np.int32), "Boolean": ("Boolean", np.int32, np.bool_)},
    3: {"Float64": ("Float64", np.float64, np.float64), "Float32": ("Float32", np.float32, np.float32),
        "Boolean": ("Boolean", np.bool_, np.bool_), "Enumeration": ("Int64", np.int64, np.int64),
        **{t: (t, np.dtype(t.lower()).type, np.dtype(t.lower()).type)
           for t in ("Int8", "UInt8", "Int16", "UInt16", "Int32", "UInt32", "Int64", "UInt64")}},
}


def value_dtype(version, vtype):
    """The numpy dtype a variable of FMI type ``vtype`` is recorded with, or None when it cannot be routed.

    Parameters
    ----------
    version : int
        2 or 3.
    vtype : str
        The variable's type as the model description names it ('Real', 'Integer', 'Float32', 'Boolean', ...).

    Returns
    -------
    numpy.dtype or None
        float64/float32 for reals, an integer dtype for integers and enumerations, bool for Booleans;
        None for String, Binary and Clock variables.
    """
    entry = _TYPES[version].get(vtype)
    return None if entry is None else np.dtype(entry[2])


def check(function, status, detail=""):
    """Raise ``FmiCallError(function, label)`` when ``status`` is worse than warning (> 1).

    Parameters
    ----------
    function : str
        The FMI function called, e.g. ``fmi3DoStep``.
    status : int
        The status it returned (0 OK, 1 warning, 2 discard, 3 error, 4 fatal).
    detail : str, optional
        What the caller was doing, appended to the message.
    """
    if status > 1:
        label = STATUS_LABELS[status] if 0 <= status < len(STATUS_LABELS) else f"illegal status {status}"
        raise FmiCallError(function, label, detail)


class Port:
    """A fixed list of variables of one type of one instance, with a float64 numpy buffer of their values.

    Reals are read and written in place; other types go through a typed array: Integer and Boolean values
    read into the buffer are exact (Boolean as 0/1), values written are rounded to the nearest integer
    (Boolean: true when that is not 0), Float32 rounded to the nearest float32.

    Parameters
    ----------
    names : sequence of str
        The variables, in buffer order.
    vrs : sequence of int
        Their value references.
    ctype : numpy dtype, optional
        The C array type of the FMU's Get/Set function for these variables (default float64).

    Attributes
    ----------
    names : tuple of str
    values : numpy.ndarray of float64, shape (n,)
        Filled by :meth:`FmuInstance.get`, read by :meth:`FmuInstance.set`.
    """

    def __init__(self, names, vrs, ctype=np.float64):
        self.names = tuple(names)
        self.n = len(self.names)
        self.values = np.zeros(self.n)
        self._vr = (ctypes.c_uint * self.n)(*vrs)
        self.raw = None if np.dtype(ctype) == np.float64 else np.zeros(self.n, dtype=ctype)
        self._ptr = self._pointer()

    def _pointer(self):
        arr = self.values if self.raw is None else self.raw
        return arr.ctypes.data_as(ctypes.POINTER(np.ctypeslib.as_ctypes_type(arr.dtype)))

    @property
    def vr_address(self):
        """Address of the port's value-reference array (uint32, length n), for a compiled engine."""
        return ctypes.addressof(self._vr)

    def bind(self, buffer):
        """Use ``buffer`` (a contiguous float64 array of length n, e.g. a slice of a larger buffer) for the values."""
        if buffer.shape != (self.n,) or buffer.dtype != np.float64 or not buffer.flags.c_contiguous:
            raise ValueError(f"Port.bind: need a contiguous float64 array of shape ({self.n},)")
        self.values = buffer
        self._ptr = self._pointer()

    def to_values(self):
        """Typed port: copy what the FMU returned (``raw``) into ``values``."""
        self.values[:] = self.raw

    def from_values(self):
        """Typed port: convert ``values`` into ``raw`` for the FMU (see the class docstring)."""
        kind = self.raw.dtype.kind
        if kind == "f":
            self.raw[:] = self.values
        elif kind == "b":
            self.raw[:] = np.rint(self.values) != 0
        else:
            self.raw[:] = np.rint(self.values)


class FmuInstance:
    """One running FMU instance.

    Parameters
    ----------
    path : path-like
        The ``.fmu`` file.
    name : str
        Instance name (used in messages).
    kind : {'ME', 'CS', None}
        Interface to use; ``None`` picks ME when the FMU provides it, CS otherwise.

    Attributes
    ----------
    info : cosim.fmi.model.ModelInfo
    kind : str
    n_states : int
    x, dx : numpy.ndarray of float64, shape (n_states,)
        State and derivative buffers for :meth:`push_states`, :meth:`pull_states`, :meth:`pull_derivatives`.
    """

    def __init__(self, path, name="fmu", kind=None):
        self.info = read_model_info(path)
        self.name = name
        if kind is None:
            kind = "ME" if "ME" in self.info.kinds else "CS"
        if kind not in self.info.kinds:
            raise FmiCallError("load", "unsupported", f"{path}: the FMU provides {self.info.kinds}, not {kind}")
        self.kind = kind
        self.version = self.info.fmi_version
        self._tmp = tempfile.mkdtemp(prefix=f"cosim-{name}-")
        self._fmu = None
        self.component = None
        self._initialised = False
        self._terminated = False
        self.messages = []
        try:
            safe_extract(path, self._tmp)
            self._load()
        except Exception:
            shutil.rmtree(self._tmp, ignore_errors=True)
            raise
        self.n_states = self.info.n_states if kind == "ME" else 0
        self.x = np.zeros(self.n_states)
        self.dx = np.zeros(self.n_states)
        self._xp = self.x.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
        self._dxp = self.dx.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
        self.n_indicators = self.info.n_event_indicators if kind == "ME" else 0
        self.z = np.zeros(self.n_indicators)
        self._zp = self.z.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
        self.next_event_time = math.inf

    def bind_state_buffers(self, x, dx):
        """Use ``x`` and ``dx`` (contiguous float64 arrays of length n_states, e.g. slices of the
        master's combined state vector) as the state and derivative buffers."""
        for b in (x, dx):
            if b.shape != (self.n_states,) or b.dtype != np.float64 or not b.flags.c_contiguous:
                raise ValueError(f"bind_state_buffers: need contiguous float64 arrays of shape ({self.n_states},)")
        x[:] = self.x
        self.x, self.dx = x, dx
        self._xp = x.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
        self._dxp = dx.ctypes.data_as(ctypes.POINTER(ctypes.c_double))

    # -- loading -----------------------------------------------------------------------------
    def _load(self):
        import fmpy

        md = fmpy.read_model_description(str(self.info.path), validate=False)
        ident = (md.modelExchange if self.kind == "ME" else md.coSimulation).modelIdentifier
        args = dict(guid=md.guid if self.version == 2 else md.instantiationToken,
                    unzipDirectory=self._tmp, modelIdentifier=ident, instanceName=self.name)
        try:
            if self.version == 3:
                from fmpy.fmi3 import FMU3Model, FMU3Slave

                self._fmu = (FMU3Model if self.kind == "ME" else FMU3Slave)(**args)
            else:
                from fmpy.fmi2 import FMU2Model, FMU2Slave

                self._fmu = (FMU2Model if self.kind == "ME" else FMU2Slave)(**args)
        except Exception as err:  # fmpy raises plain Exception when the library cannot be loaded
            raise FmiCallError("load", "failed", f"{self.info.path}: {err}") from err
        f = self._fmu._functions
        p = "fmi3" if self.version == 3 else "fmi2"
        self._f_set_time = f.get(f"{p}SetTime")
        self._f_set_states = f.get(f"{p}SetContinuousStates")
        self._f_get_states = f.get(f"{p}GetContinuousStates")
        self._f_get_der = f.get(f"{p}GetContinuousStateDerivatives" if self.version == 3 else "fmi2GetDerivatives")
        self._f_get_real = f[f"{p}GetFloat64" if self.version == 3 else "fmi2GetReal"]
        self._f_set_real = f[f"{p}SetFloat64" if self.version == 3 else "fmi2SetReal"]
        self._f_do_step = f.get(f"{p}DoStep")
        self._f_completed = f.get(f"{p}CompletedIntegratorStep")
        self._f_indicators = f.get(f"{p}GetEventIndicators")
        self._b1 = ctypes.c_bool() if self.version == 3 else ctypes.c_int()
        self._b2 = ctypes.c_bool() if self.version == 3 else ctypes.c_int()
        self._b3 = ctypes.c_bool()
        self._d1 = ctypes.c_double()

    def _logger(self, env, status, category, message):
        text = message.decode("utf-8", "replace") if isinstance(message, bytes) else str(message)
        self.messages.append(text)

    def _fmpy_call(self, fname, fn, *args):
        """Run an fmpy Python-tier call, turning fmpy's exception into FmiCallError through check()."""
        from fmpy.fmi1 import FMICallException

        try:
            return fn(*args)
        except FMICallException as err:
            check(err.function, err.status if isinstance(err.status, int) else 3, self._last_message())
        except FmiCallError:
            raise
        except Exception as err:  # fmpy raises plain Exception e.g. for a failed instantiation
            raise FmiCallError(fname, "failed", f"{self.name}: {err}") from err

    def _last_message(self):
        return f"{self.name}: {self.messages[-1]}" if self.messages else self.name

    # -- lifecycle ---------------------------------------------------------------------------
    def setup(self, start_time=0.0, stop_time=None, parameters=None, start_values=None, tolerance=None):
        """Instantiate, set parameters and start values, initialise, and enter continuous-time / step mode.

        Parameters
        ----------
        start_time : float
        stop_time : float, optional
        parameters, start_values : dict of str to value, optional
            Values set before initialisation (by variable name).
        tolerance : float, optional
        """
        fmu = self._fmu
        if self.version == 3:
            if self.kind == "ME":
                self._fmpy_call("fmi3InstantiateModelExchange", fmu.instantiate, False, False, self._logger)
            else:
                self._fmpy_call("fmi3InstantiateCoSimulation", lambda: fmu.instantiate(logMessage=self._logger))
        else:
            self._fmpy_call("fmi2Instantiate", fmu.instantiate)
        self.component = fmu.component
        self.set_values({**(start_values or {}), **(parameters or {})})
        if self.version == 3:
            self._fmpy_call("fmi3EnterInitializationMode", fmu.enterInitializationMode, tolerance, start_time, stop_time)
        else:
            self._fmpy_call("fmi2SetupExperiment", fmu.setupExperiment, tolerance, start_time, stop_time)
            self._fmpy_call("fmi2EnterInitializationMode", fmu.enterInitializationMode)
        self._fmpy_call("ExitInitializationMode", fmu.exitInitializationMode)
        self._initialised = True
        if self.kind == "ME":
            self._event_iteration(start_time)
            self._fmpy_call("EnterContinuousTimeMode", fmu.enterContinuousTimeMode)
            if self.n_states:
                self.pull_states()
        elif self.version == 3:
            pass  # FMI 3 CS without event mode is in step mode after exitInitializationMode

    MAX_EVENT_PASSES = 100  # event-iteration passes at one instant before EventError

    def _event_iteration(self, t):
        """Update discrete states until they settle (FMI event iteration) at time ``t``.

        Sets ``next_event_time`` (inf when the FMU defines none); returns whether the continuous
        states' values changed. Raises SimulationTerminated when the FMU asks to stop, EventError
        when it does not settle within ``MAX_EVENT_PASSES`` passes.
        """
        fmu = self._fmu
        changed = False
        update = fmu.updateDiscreteStates if self.version == 3 else fmu.newDiscreteStates
        for _ in range(self.MAX_EVENT_PASSES):
            again, terminate, _, values_changed, time_defined, next_time = self._fmpy_call("UpdateDiscreteStates", update)
            changed = changed or bool(values_changed)
            if terminate:
                raise SimulationTerminated(self.name, t, self.messages[-1] if self.messages else "")
            if not again:
                self.next_event_time = float(next_time) if time_defined else math.inf
                return changed
        raise EventError(f"{self.name}: the event iteration at t={t:.12g} s did not settle in "
                         f"{self.MAX_EVENT_PASSES} passes (discrete states keep changing)")

    def handle_event(self, t):
        """ME, in continuous-time mode at ``t`` (time and states set): enter event mode, iterate, return to
        continuous-time mode and re-read the states when the FMU changed them; returns whether it did."""
        fmu = self._fmu
        self._fmpy_call("EnterEventMode", fmu.enterEventMode)
        changed = self._event_iteration(t)
        self._fmpy_call("EnterContinuousTimeMode", fmu.enterContinuousTimeMode)
        if changed and self.n_states:
            self.pull_states()
        return changed

    def pull_indicators(self):
        """ME: evaluate the event indicators into ``self.z``."""
        st = self._f_indicators(self.component, self._zp, self.n_indicators)
        if st > 1:
            check("GetEventIndicators", st, self._last_message())

    def free_instance(self):
        """Terminate and free the instance but keep the FMU unpacked and its library loaded: :meth:`setup` then
        makes a new instance without loading the FMU again (runs repeated in one process, a campaign's trials)."""
        fmu = self._fmu
        if fmu is not None and self.component is not None:
            if self._initialised and not self._terminated:
                self._terminated = True
                try:
                    fmu.terminate()
                except Exception:  # terminating a failed instance may fail again; freeing still matters
                    pass
            # the raw call: fmpy's freeInstance also unloads the library
            (fmu.fmi3FreeInstance if self.version == 3 else fmu.fmi2FreeInstance)(fmu.component)
            self.component = None
        self._initialised = self._terminated = False
        self.next_event_time = math.inf

    def close(self):
        """Terminate and free the instance, unload the library and delete the unpacked files."""
        try:
            self.free_instance()
            if self._fmu is not None:
                self._fmu.freeLibrary()
                self._fmu = None
        finally:
            shutil.rmtree(self._tmp, ignore_errors=True)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # -- for a compiled engine ----------------------------------------------------------------------
    def entry_points(self):
        """Addresses of the hot C entry points and of the instance, for a compiled engine (issue 8).

        Returns
        -------
        dict of str to int
            ``component`` (the instance pointer) and, where the FMU exports them, ``SetTime``,
            ``SetContinuousStates``, ``GetContinuousStates``, ``GetDerivatives``, ``GetReal``,
            ``SetReal``, ``DoStep``, ``CompletedIntegratorStep``, and for events ``GetEventIndicators``,
            ``EnterEventMode``, ``UpdateDiscreteStates`` (FMI 2: ``fmi2NewDiscreteStates``),
            ``EnterContinuousTimeMode`` (FMI 2 or FMI 3 signatures per ``self.version``); 0 when absent.
        """
        def addr(f):
            return ctypes.cast(f, ctypes.c_void_p).value or 0 if f is not None else 0

        f = self._fmu._functions
        p = "fmi3" if self.version == 3 else "fmi2"
        update = "fmi3UpdateDiscreteStates" if self.version == 3 else "fmi2NewDiscreteStates"

        return {
            "component": self.component or 0,
            "SetTime": addr(self._f_set_time),
            "SetContinuousStates": addr(self._f_set_states),
            "GetContinuousStates": addr(self._f_get_states),
            "GetDerivatives": addr(self._f_get_der),
            "GetReal": addr(self._f_get_real),
            "SetReal": addr(self._f_set_real),
            "DoStep": addr(self._f_do_step),
            "CompletedIntegratorStep": addr(self._f_completed),
            "GetEventIndicators": addr(self._f_indicators),
            "EnterEventMode": addr(f.get(f"{p}EnterEventMode")),
            "UpdateDiscreteStates": addr(f.get(update)),
            "EnterContinuousTimeMode": addr(f.get(f"{p}EnterContinuousTimeMode")),
        }

    def port_entry_points(self, port):
        """Addresses of the Get and Set functions of ``port``'s type (``fmi3GetInt32``, ``fmi2SetBoolean``, ...; 0
        when absent), for a compiled engine: their C signatures are GetFloat64's / GetReal's with another value
        type."""
        f = self._fmu._functions
        return tuple(ctypes.cast(fn, ctypes.c_void_p).value or 0 if fn is not None else 0
                     for fn in (f.get(self.call_name("Get", port)), f.get(self.call_name("Set", port))))

    def call_name(self, what, port):
        """The FMI function that gets (``what`` "Get") or sets ("Set") ``port``'s variables: ``fmi3GetFloat64``,
        ``fmi3SetInt32``, ``fmi2GetInteger``, ... (what an error of the call names)."""
        return f"{'fmi3' if self.version == 3 else 'fmi2'}{what}{port.suffix}"

    # -- values by name (not hot) ------------------------------------------------------------
    def set_values(self, values):
        """Set variables by name: floats, ints, bools; raises KeyError for an unknown name."""
        fmu = self._fmu
        for name, value in values.items():
            v = self.info.variables[name]
            t = v.type
            if t in ("Real", "Float64", "Float32"):
                fn = fmu.setReal if self.version == 2 else (fmu.setFloat64 if t == "Float64" else fmu.setFloat32)
                self._fmpy_call("SetReal", fn, [v.vr], [float(value)])
            elif t == "Boolean":
                self._fmpy_call("SetBoolean", fmu.setBoolean, [v.vr], [bool(value)])
            elif t in ("Integer", "Int32", "Enumeration"):
                fn = fmu.setInteger if self.version == 2 else fmu.setInt32
                self._fmpy_call("SetInteger", fn, [v.vr], [int(value)])
            elif t == "Int64":
                self._fmpy_call("SetInt64", fmu.setInt64, [v.vr], [int(value)])
            else:
                raise FmiCallError("set", "unsupported", f"{self.name}.{name}: type {t} cannot be set")

    def get_values(self, names):
        """Return a dict of the current values of ``names`` (as floats; Booleans 0/1)."""
        out = {}
        for n in names:
            port = self.port([n])
            self.get(port)
            out[n] = float(port.values[0])
        return out

    # -- hot path ----------------------------------------------------------------------------
    def port(self, names):
        """Make a :class:`Port` over the variables ``names`` (all of one FMI type; see :func:`value_dtype`)."""
        vrs, types = [], set()
        for n in names:
            v = self.info.variables[n]
            if _TYPES[self.version].get(v.type) is None:
                raise FmiCallError("port", "unsupported", f"{self.name}.{n} is {v.type}; it cannot be routed")
            vrs.append(v.vr)
            types.add(v.type)
        if len(types) > 1:
            raise ValueError(f"{self.name}: a port holds one type; got {sorted(types)}")
        suffix, ctype, _ = _TYPES[self.version][types.pop() if types else ("Real", "Float64")[self.version - 2]]
        port = Port(names, vrs, ctype)
        port.suffix = suffix
        return port

    def _typed_call(self, what, port):
        fname = self.call_name(what, port)
        args = (self.component, port._vr, port.n, port._ptr) + ((port.n,) if self.version == 3 else ())
        st = self._fmu._functions[fname](*args)
        if st > 1:
            check(fname, st, self._last_message())

    def get(self, port):
        """Read the port's variables into ``port.values``."""
        if port.raw is None:
            if port.n:
                if self.version == 3:
                    st = self._f_get_real(self.component, port._vr, port.n, port._ptr, port.n)
                else:
                    st = self._f_get_real(self.component, port._vr, port.n, port._ptr)
                if st > 1:
                    check(self.call_name("Get", port), st, self._last_message())
        elif port.n:
            self._typed_call("Get", port)
            port.to_values()

    def set(self, port):
        """Write ``port.values`` to the port's variables."""
        if port.raw is None:
            if port.n:
                if self.version == 3:
                    st = self._f_set_real(self.component, port._vr, port.n, port._ptr, port.n)
                else:
                    st = self._f_set_real(self.component, port._vr, port.n, port._ptr)
                if st > 1:
                    check(self.call_name("Set", port), st, self._last_message())
        elif port.n:
            port.from_values()
            self._typed_call("Set", port)

    def set_time(self, t):
        """ME: set the independent variable."""
        st = self._f_set_time(self.component, t)
        if st > 1:
            check("SetTime", st, self._last_message())

    def push_states(self):
        """ME: send ``self.x`` to the FMU."""
        st = self._f_set_states(self.component, self._xp, self.n_states)
        if st > 1:
            check("SetContinuousStates", st, self._last_message())

    def pull_states(self):
        """ME: read the FMU's states into ``self.x``."""
        st = self._f_get_states(self.component, self._xp, self.n_states)
        if st > 1:
            check("GetContinuousStates", st, self._last_message())

    def pull_derivatives(self):
        """ME: evaluate the state derivatives into ``self.dx``."""
        st = self._f_get_der(self.component, self._dxp, self.n_states)
        if st > 1:
            check("GetContinuousStateDerivatives", st, self._last_message())

    def completed_integrator_step(self, t=math.nan):
        """ME: tell the FMU the integrator step ending at ``t`` is complete; returns True when it asks for event
        mode; raises SimulationTerminated when it asks to stop."""
        if self.version == 3:
            st = self._f_completed(self.component, True, ctypes.byref(self._b1), ctypes.byref(self._b2))
        else:
            st = self._f_completed(self.component, 1, ctypes.byref(self._b1), ctypes.byref(self._b2))
        if st > 1:
            check("CompletedIntegratorStep", st, self._last_message())
        if self._b2.value:
            raise SimulationTerminated(self.name, t, self.messages[-1] if self.messages else "")
        return bool(self._b1.value)

    def do_step(self, t, h):
        """CS: advance from ``t`` by ``h``; raises SimulationTerminated when the FMU asks to stop."""
        if self.version == 3:
            self._b2.value = False
            st = self._f_do_step(self.component, t, h, True, ctypes.byref(self._b1), ctypes.byref(self._b2),
                                 ctypes.byref(self._b3), ctypes.byref(self._d1))
            terminate = st <= 2 and self._b2.value
        else:
            st = self._f_do_step(self.component, t, h, 1)
            terminate = st == 2 and self._fmi2_terminated()
        if terminate:
            raise SimulationTerminated(self.name, t + h, self.messages[-1] if self.messages else "")
        if st > 1:
            check("DoStep", st, self._last_message())

    def _fmi2_terminated(self):
        """FMI 2 CS after a Discard from doStep: whether the FMU asks to terminate (fmi2Terminated status)."""
        f = self._fmu._functions.get("fmi2GetBooleanStatus")
        flag = ctypes.c_int(0)
        return f is not None and f(self.component, 3, ctypes.byref(flag)) <= 1 and bool(flag.value)  # fmi2Terminated
