"""The compiled engine's per-instant kernel: one numba function that runs a chunk of instants.

It does exactly what :class:`cosim.master.loop.PythonLoop` and :class:`cosim.master.plant.PlantSystem`
do at each instant, in the same order and with the same floating-point operations (so both engines
give the same numbers): sample the plant, route, step the due controllers (numba ``cfunc`` kernels
called by address), hold their outputs, record, and advance the plant (RK4 substeps over the ME
FMUs' combined state, ``doStep`` of CS FMUs), handling the events of ME FMUs with the Python engine's rules
(state events located by bisection on the RK4 step to ``EVENT_TOL``, time events, step events, event
iteration with the chattering guard; :mod:`cosim.master.plant`). FMU functions are called by address through
:mod:`cosim.fmi.native`. Everything a run needs is in integer/float tables built by
``cosim.master.compiled.CompiledLoop``; the kernel itself is compiled once and cached on disk.

Tables (all int64 unless said):

``fmu`` (n_fmu, N_FMU_COLS)
    per FMU: component, SetTime, SetContinuousStates, GetDerivatives, GetReal, SetReal (FMI 3: GetFloat64,
    SetFloat64), DoStep, CompletedIntegratorStep addresses, FMI version, state offset in X, number of states,
    scratch address (32 bytes for the flags of CompletedIntegratorStep / DoStep / UpdateDiscreteStates), then
    GetEventIndicators, EnterEventMode, UpdateDiscreteStates (FMI 2: NewDiscreteStates),
    EnterContinuousTimeMode, GetContinuousStates addresses.
``me``, ``cmp``, ``cs`` (n,)
    FMU indices of the ME FMUs (in order), of those needing CompletedIntegratorStep, of the CS FMUs.
``port`` (n_port, 4)
    the float64 ports (read and written in place in the signal buffer with the FMU's GetReal / SetReal): FMU
    index, value-reference array address, n, offset in the signal buffer.
``typed`` (n_typed, N_PORT_COLS), or None when the run has no typed port (numba then compiles the loop without
    their code, as for ``evt``)
    the ports of other types: the same four columns, then the type (index in RAW_TYPES), the addresses of the
    Get and Set functions of that type and of the port's C values (``CompiledLoop`` keeps them, 8-byte aligned).
``pgrp`` (n_group, 4)
    port ranges, in ``port`` then in ``typed``: 0 sampled ports (get), 1 instant inputs (set), then per ME-to-ME
    level its gets and sets.
``rsrc``, ``rdst``, ``rgain`` (float64), ``roff`` (float64), ``rgrp`` (n_group, 2)
    routing ``buf[dst] = gain buf[src] + off``: group 0 instant FMU-to-FMU, 1 controllers to FMUs,
    then one per controller (its inputs), then one per ME-to-ME level.
``lvl`` (n_level, 3)
    port group of the level's gets, its route group, port group of its sets.
``ctl`` (n_ctrl, N_CTL_COLS)
    cfunc address, period (ticks), route group, then address and length of u, y, x, p.
``ii``
    k_stop, record period, time-base numerator, denominator, number of periods, then the periods.
``ff`` (float64, FF)
    start time, h_max, time of the latest event (or of the stop an FMU asked for), earliest next time event,
    then the event rules of the Python engine (run-time data, so that numba's cache of this file never
    holds stale copies): ``EVENT_TOL``, ``CHATTER_WINDOW``, ``MAX_EVENTS_AT_ONE_TIME``
    (:mod:`cosim.master.plant`), ``FmuInstance.MAX_EVENT_PASSES``.
``st`` (N_ST,)
    run state kept between chunks: k, synced tick, first-chunk flag, error FMU, error function (index
    in FUNCTIONS; ``terminate``, ``unsettled``, ``chatter`` are event outcomes, ``nonfinite`` a NaN or infinite
    value, state or derivative at the instant ``k``; ``GetReal``/``SetReal`` a call on a row of ``port``,
    ``GetTyped``/``SetTyped`` on a row of ``typed``), error status, number of events in a row within
    CHATTER_WINDOW of each other, number of events in the log, the row of the port whose Get or Set failed.
``rec`` (n_rows, n_col) float64, ``times`` (n_rows,) float64, ``rows`` (1,)
    the recorder's arrays (:class:`cosim.master.recorder.Recorder`): rows are written at ``rows[0]``.
``scr`` (n_fmu, 32) uint8, ``scr64`` the same memory as (n_fmu, 4) float64
    the scratch bytes whose addresses are in ``fmu`` (flags and next event time written by the FMUs).
``evt``
    None when no FMU can have events, else the tuple ``(ev, Z, E, due, tev, scr, scr64, ff, log)``:

    ``ev`` (n_ev, 3)
        the ME FMUs with event indicators: FMU index, offset of its indicators in ``Z``, their number.
    ``Z`` (2, n_z) float64
        indicators at the last accepted point, and just read.
    ``E`` (2, n_x) float64
        the state and first-stage derivative at the start of a step being cut at an event.
    ``due`` (n_fmu,)
        FMUs marked for event iteration.
    ``tev`` (n_fmu,) float64
        each FMU's next time event (inf: none).
    ``log`` (n_log, 3) float64
        the events handled since Python last read the log (``st`` n_log of them): time, FMU index,
        kind (index in KINDS). A chunk stops early when it is half full.

The kernel is compiled without numba's reference counting (``_nrt=False``: nothing is allocated in
it; with reference counting the array arguments of the helpers cost two atomic operations per call
and made the loop four times slower). numba's on-disk cache keys a function on its own file only; the cache's
folder (:mod:`cosim.kernel_cache`) is named by a hash of this file, :mod:`cosim.fmi.native` and
:mod:`cosim.master.events` (the event rules, shared with the Python loop), so an edit of any of them compiles
the loop anew.
"""

import math

import numba
import numpy as np
from numba.core import types
from numba.extending import overload

from cosim.fmi import native
from cosim.master.events import bisection_narrow, bisection_trial, chatter, crossed, step_end, time_event_due

__all__ = ["run_chunk", "nonfinite", "FMU_COLS", "PORT_COLS", "RAW_TYPES", "CTL_COLS", "ST", "FF", "FUNCTIONS",
           "KINDS", "DONE", "MORE", "ERROR"]

FMU_COLS = ("component", "SetTime", "SetContinuousStates", "GetDerivatives", "GetReal", "SetReal", "DoStep",
            "CompletedIntegratorStep", "version", "x_off", "n_states", "scratch", "GetEventIndicators",
            "EnterEventMode", "UpdateDiscreteStates", "EnterContinuousTimeMode", "GetContinuousStates")
(_C, _ST, _SX, _GD, _GR, _SR, _DS, _CI, _V, _XO, _NX, _SC, _GZ, _EEM, _UDS, _ECT, _GX) = range(len(FMU_COLS))
PORT_COLS = ("fmu", "vr", "n", "buf_off", "type", "Get", "Set", "raw_addr")
(_PF, _PVR, _PN, _PB, _PT, _PGET, _PSET, _PRA) = range(len(PORT_COLS))
RAW_TYPES = ("float64", "float32", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64", "uint64", "bool")
CTL_COLS = ("fn", "period", "route", "u", "nu", "y", "ny", "x", "nx", "p", "np")
ST = ("k", "synced", "first", "err_fmu", "err_fn", "err_status", "ev_count", "n_log", "err_port")
(_K, _SYNC, _FIRST, _EF, _EFN, _ES, _EVN, _NLOG, _EP) = range(len(ST))
FUNCTIONS = ("SetTime", "SetContinuousStates", "GetDerivatives", "GetReal", "SetReal", "DoStep",
             "CompletedIntegratorStep", "DoStep:terminate", "GetEventIndicators", "EnterEventMode",
             "UpdateDiscreteStates", "EnterContinuousTimeMode", "GetContinuousStates", "terminate", "unsettled",
             "chatter", "nonfinite", "GetTyped", "SetTyped")
(_FN_GZ, _FN_EEM, _FN_UDS, _FN_ECT, _FN_GX, _FN_TERM, _FN_UNSETTLED, _FN_CHATTER, _FN_NONFINITE, _FN_GET_TYPED,
 _FN_SET_TYPED) = range(8, 19)
FF = ("t0", "h_max", "event_t", "next_time_event", "event_tol", "chatter_window", "max_events", "max_passes")
(_T0, _HMAX, _EVT, _TNEXT, _TOL, _WINDOW, _MAXEV, _MAXPASS) = range(len(FF))
DONE, MORE, ERROR = 0, 1, 2
_DBL_MAX = 1.7976931348623157e308
KINDS = ("state", "time", "step", "input")  # event kinds of the event log, as the Python engine's
(_STATE, _TIME, _STEP, _INPUT) = range(len(KINDS))

_PLAIN_LOOP = ("run_chunk", "_rk4", "_deriv", "_eval", "_io")


def _in_plain_loop(expr, caller, callee):
    """numba inlines the helpers of the per-instant loop without events into their callers there: a call passes
    each array as 7 words on the stack, and those calls were 27 % of the loop's CPU time on the gripper (issue
    54). The event code, run at events only, keeps its calls."""
    return caller.func_id.func_name in _PLAIN_LOOP


@numba.njit(cache=True, _nrt=False, inline=_in_plain_loop)
def _fail(st, f, fn, status):
    st[_EF] = f
    st[_EFN] = fn
    st[_ES] = status
    return True


@numba.njit(cache=True, _nrt=False, inline=_in_plain_loop)
def nonfinite(buf, W):
    """True when a value of the signal buffer or a state (row 0 of W) is NaN or infinite (``abs(v) <= DBL_MAX`` is
    false for those only; or-ed without branches, about 50 ns for the gripper's 31 values). A bad derivative makes
    the state bad in the same RK4 step (every stage enters the update), so the derivatives need no check."""
    bad = 0
    for i in range(buf.shape[0]):
        bad |= not (abs(buf[i]) <= _DBL_MAX)
    for i in range(W.shape[1]):
        bad |= not (abs(W[0, i]) <= _DBL_MAX)
    return bad != 0


@numba.njit(cache=True, _nrt=False)
def _from_raw(code, raw, val, n):
    """The ``n`` C values of type ``RAW_TYPES[code]`` at address ``raw`` into the doubles at ``val``, exact
    (Booleans 0/1), as ``Port.to_values``."""
    for i in range(n):
        if code == 1:
            v = native.load_f32(raw + 4 * i)
        elif code == 2:
            v = native.load_i8(raw + i)
        elif code == 3:
            v = native.load_u8(raw + i)
        elif code == 4:
            v = native.load_i16(raw + 2 * i)
        elif code == 5:
            v = native.load_u16(raw + 2 * i)
        elif code == 6:
            v = native.load_i32(raw + 4 * i)
        elif code == 7:
            v = native.load_u32(raw + 4 * i)
        elif code == 8:
            v = native.load_i64(raw + 8 * i)
        elif code == 9:
            v = native.load_u64(raw + 8 * i)
        else:
            v = 1.0 if native.load_u8(raw + i) != 0 else 0.0
        native.store_f64(val + 8 * i, v)


@numba.njit(cache=True, _nrt=False)
def _to_raw(code, raw, val, n):
    """The ``n`` doubles at ``val`` into C values of type ``RAW_TYPES[code]`` at ``raw``, as ``Port.from_values``:
    Float32 rounded to the nearest float32, integers to the nearest integer (``rint``), Booleans true when that
    is not 0."""
    for i in range(n):
        v = native.load_f64(val + 8 * i)
        r = np.rint(v)
        if code == 1:
            native.store_f32(raw + 4 * i, v)
        elif code == 2:
            native.store_i8(raw + i, r)
        elif code == 3:
            native.store_u8(raw + i, r)
        elif code == 4:
            native.store_i16(raw + 2 * i, r)
        elif code == 5:
            native.store_u16(raw + 2 * i, r)
        elif code == 6:
            native.store_i32(raw + 4 * i, r)
        elif code == 7:
            native.store_u32(raw + 4 * i, r)
        elif code == 8:
            native.store_i64(raw + 8 * i, r)
        elif code == 9:
            native.store_u64(raw + 8 * i, r)
        else:
            native.store_u8(raw + i, 1.0 if r != 0 else 0.0)


@numba.njit(cache=True, _nrt=False)
def _typed_io(fmu, port, j, buf_addr, setter, st):
    """Get or set the typed port ``j`` (``type`` > 0) through its C values at ``raw_addr``, converted as
    :class:`cosim.fmi.Port` does; True on an FMI error."""
    f = port[j, _PF]
    n = port[j, _PN]
    code = port[j, _PT]
    raw = port[j, _PRA]
    val = buf_addr + 8 * port[j, _PB]
    if setter:
        _to_raw(code, raw, val, n)
    fn = port[j, _PSET] if setter else port[j, _PGET]
    if fmu[f, _V] == 3:
        s = native.real3(fn, fmu[f, _C], port[j, _PVR], n, raw, n)
    else:
        s = native.real2(fn, fmu[f, _C], port[j, _PVR], n, raw)
    if s > 1:
        st[_EP] = j
        return _fail(st, f, _FN_SET_TYPED if setter else _FN_GET_TYPED, s)
    if not setter:
        _from_raw(code, raw, val, n)
    return False


@numba.njit(cache=True, _nrt=False, inline=_in_plain_loop)
def _io(fmu, port, typed, grp, g, buf_addr, setter, st):
    """Get (``setter`` False) or set the ports of group ``g``; True on an FMI error. Float64 ports are read and
    written in place in the signal buffer; typed ports (``typed``; None when the run has none: numba then
    compiles the loop without their code) by ``_typed_io``."""
    for j in range(grp[g, 0], grp[g, 1]):
        f = port[j, 0]
        fn = fmu[f, _SR] if setter else fmu[f, _GR]
        n = port[j, 2]
        val = buf_addr + 8 * port[j, 3]
        if fmu[f, _V] == 3:
            s = native.real3(fn, fmu[f, _C], port[j, 1], n, val, n)
        else:
            s = native.real2(fn, fmu[f, _C], port[j, 1], n, val)
        if s > 1:
            st[_EP] = j
            return _fail(st, f, 4 if setter else 3, s)
    return _typed_group(fmu, typed, grp, g, buf_addr, setter, st)


def _typed_group(fmu, typed, grp, g, buf_addr, setter, st):
    """Get or set the typed ports of group ``g``; True on an FMI error (compiled through the overload below)."""
    raise NotImplementedError("only callable from numba-compiled code")


@overload(_typed_group, inline="always")
def _typed_group_code(fmu, typed, grp, g, buf_addr, setter, st):
    """No code when the run has no typed port (``typed`` None: chosen by type, so that it holds where ``_io`` is
    inlined and ``typed`` is no longer an argument numba can prune on), else ``_typed_io`` port by port."""
    if isinstance(typed, types.NoneType):
        return lambda fmu, typed, grp, g, buf_addr, setter, st: False

    def code(fmu, typed, grp, g, buf_addr, setter, st):
        for j in range(grp[g, 2], grp[g, 3]):
            if _typed_io(fmu, typed, j, buf_addr, setter, st):
                return True
        return False

    return code


@numba.njit(cache=True, _nrt=False, inline=_in_plain_loop)
def _route(buf, rsrc, rdst, rgain, roff, rgrp, g):
    for j in range(rgrp[g, 0], rgrp[g, 1]):
        buf[rdst[j]] = rgain[j] * buf[rsrc[j]] + roff[j]


@numba.njit(cache=True, _nrt=False, inline=_in_plain_loop)
def _eval(t, push, fmu, me, port, typed, pgrp, lvl, buf, rsrc, rdst, rgain, roff, rgrp, x_addr, buf_addr, st):
    """Set time and states of every ME FMU (``push``), route ME-to-ME connections level by level."""
    if push:
        for i in range(me.shape[0]):
            f = me[i]
            s = native.set_time(fmu[f, _ST], fmu[f, _C], t)
            if s > 1:
                return _fail(st, f, 0, s)
            s = native.vec(fmu[f, _SX], fmu[f, _C], x_addr + 8 * fmu[f, _XO], fmu[f, _NX])
            if s > 1:
                return _fail(st, f, 1, s)
    for lv in range(lvl.shape[0]):
        if _io(fmu, port, typed, pgrp, lvl[lv, 0], buf_addr, False, st):
            return True
        _route(buf, rsrc, rdst, rgain, roff, rgrp, lvl[lv, 1])
        if _io(fmu, port, typed, pgrp, lvl[lv, 2], buf_addr, True, st):
            return True
    return False


@numba.njit(cache=True, _nrt=False, inline=_in_plain_loop)
def _deriv(t, push, fmu, me, port, typed, pgrp, lvl, buf, rsrc, rdst, rgain, roff, rgrp, x_addr, dx_addr, buf_addr,
           st):
    if _eval(t, push, fmu, me, port, typed, pgrp, lvl, buf, rsrc, rdst, rgain, roff, rgrp, x_addr, buf_addr, st):
        return True
    for i in range(me.shape[0]):
        f = me[i]
        s = native.vec(fmu[f, _GD], fmu[f, _C], dx_addr + 8 * fmu[f, _XO], fmu[f, _NX])
        if s > 1:
            return _fail(st, f, 2, s)
    return False


@numba.njit(cache=True, _nrt=False, inline=_in_plain_loop)
def _stage(W, s, c):
    for i in range(W.shape[1]):
        W[3 + s, i] = W[2, i]
        W[0, i] = W[1, i] + c * W[2, i]


@numba.njit(cache=True, _nrt=False)
def _flag(fmu, scr, f, i):
    """Flag ``i`` an FMU wrote to its scratch: FMI 3 a C bool at byte i, FMI 2 an int32 at byte 4 i."""
    if fmu[f, _V] == 3:
        return scr[f, i] != 0
    return (scr[f, 4 * i] | scr[f, 4 * i + 1] | scr[f, 4 * i + 2] | scr[f, 4 * i + 3]) != 0


@numba.njit(cache=True, _nrt=False)
def _completed(fmu, cmp, scr, due, st):
    """CompletedIntegratorStep of the ME FMUs that need it; marks in ``due`` those asking for event mode and
    returns how many; -1 on an FMI error or a request to terminate."""
    n = 0
    for i in range(cmp.shape[0]):
        f = cmp[i]
        sc = fmu[f, _SC]
        if fmu[f, _V] == 3:
            s = native.completed3(fmu[f, _CI], fmu[f, _C], sc)
        else:
            s = native.completed2(fmu[f, _CI], fmu[f, _C], sc)
        if s > 1:
            _fail(st, f, 6, s)
            return -1
        if _flag(fmu, scr, f, 1):
            _fail(st, f, _FN_TERM, 0)
            return -1
        due[f] = 1 if _flag(fmu, scr, f, 0) else 0
        n += due[f]
    return n


@numba.njit(cache=True, _nrt=False)
def _copy_row(A, a, B, b):
    """``A[a] = B[b]`` (a loop: no array temporaries in the kernel)."""
    for i in range(A.shape[1]):
        A[a, i] = B[b, i]


@numba.njit(cache=True, _nrt=False)
def _net_eval(t, net, addrs, st):
    """``_eval`` (push) with the plant's arrays bundled: ``net`` as in run_chunk, ``addrs`` (x, dx, buf)."""
    return _eval(t, True, net[0], net[1], net[2], net[3], net[4], net[5], net[6], net[7], net[8], net[9], net[10], net[11],
                 addrs[0], addrs[2], st)


@numba.njit(cache=True, _nrt=False)
def _net_deriv(t, net, addrs, st):
    return _deriv(t, True, net[0], net[1], net[2], net[3], net[4], net[5], net[6], net[7], net[8], net[9], net[10], net[11],
                  addrs[0], addrs[1], addrs[2], st)


@numba.njit(cache=True, _nrt=False)
def _iterate(f, fmu, scr, scr64, tev, max_passes, x_addr, st):
    """Event mode of ME FMU ``f`` (it holds the event's time and states): update its discrete states until they
    settle, note its next time event, back to continuous-time mode, re-read its states when they changed.
    True on an FMI error, a request to terminate or an iteration that does not settle."""
    c = fmu[f, _C]
    s = native.call0(fmu[f, _EEM], c)
    if s > 1:
        return _fail(st, f, _FN_EEM, s)
    changed = False
    settled = False
    for _ in range(max_passes):
        if fmu[f, _V] == 3:
            s = native.update3(fmu[f, _UDS], c, fmu[f, _SC])
        else:
            s = native.update2(fmu[f, _UDS], c, fmu[f, _SC])
        if s > 1:
            return _fail(st, f, _FN_UDS, s)
        changed = changed or _flag(fmu, scr, f, 3)
        if _flag(fmu, scr, f, 1):
            return _fail(st, f, _FN_TERM, 0)
        if not _flag(fmu, scr, f, 0):
            settled = True
            break
    if not settled:
        return _fail(st, f, _FN_UNSETTLED, 0)
    tev[f] = (scr64[f, 1] if fmu[f, _V] == 3 else scr64[f, 3]) if _flag(fmu, scr, f, 4) else math.inf
    s = native.call0(fmu[f, _ECT], c)
    if s > 1:
        return _fail(st, f, _FN_ECT, s)
    if changed and fmu[f, _NX] > 0:
        s = native.vec(fmu[f, _GX], c, x_addr + 8 * fmu[f, _XO], fmu[f, _NX])
        if s > 1:
            return _fail(st, f, _FN_GX, s)
    return False


@numba.njit(cache=True, _nrt=False)
def _indicators(fmu, ev, Z, st):
    """Read the event indicators of the FMUs that have some into ``Z[1]``; True on an FMI error."""
    z_addr = Z.ctypes.data + 8 * Z.shape[1]
    for e in range(ev.shape[0]):
        f = ev[e, 0]
        s = native.vec(fmu[f, _GZ], fmu[f, _C], z_addr + 8 * ev[e, 1], ev[e, 2])
        if s > 1:
            return _fail(st, f, _FN_GZ, s)
    return False


@numba.njit(cache=True, _nrt=False)
def _crossed(ev, Z, due):
    """Mark in ``due`` the FMUs whose indicators changed sign from ``Z[0]`` (accepted) to ``Z[1]`` (just read):
    from > 0 to <= 0 or from < 0 to >= 0, as the Python engine; returns how many."""
    n = 0
    for e in range(ev.shape[0]):
        hit = 1 if crossed(Z[0], Z[1], ev[e, 1], ev[e, 1] + ev[e, 2]) else 0
        due[ev[e, 0]] = hit
        n += hit
    return n


@numba.njit(cache=True, _nrt=False)
def _handle_events(t, kind, net, evt, addrs, st):
    """Event iteration at ``t`` of the FMUs marked in ``due`` (they hold t and X), each logged with ``kind``,
    then every indicator re-read and accepted; the chattering guard counts events in a row each within
    CHATTER_WINDOW of the previous one. True on an error."""
    fmu, me = net[0], net[1]
    ev, Z, due, tev, scr, scr64, ff, log = evt[0], evt[1], evt[3], evt[4], evt[5], evt[6], evt[7], evt[8]
    first = -1
    for i in range(me.shape[0]):
        if due[me[i]] != 0 and first < 0:
            first = me[i]
    count, chattering = chatter(t, ff[_EVT], st[_EVN], ff[_WINDOW], ff[_MAXEV])
    st[_EVN] = count
    ff[_EVT] = t
    if chattering:
        return _fail(st, max(first, 0), _FN_CHATTER, 0)
    t_next = math.inf
    for i in range(me.shape[0]):
        f = me[i]
        if due[f] != 0:
            due[f] = 0
            if _iterate(f, fmu, scr, scr64, tev, int(ff[_MAXPASS]), addrs[0], st):
                return True
            n = st[_NLOG]
            if n < log.shape[0]:
                log[n, 0] = t
                log[n, 1] = f
                log[n, 2] = kind
            st[_NLOG] = n + 1
        t_next = min(t_next, tev[f])
    ff[_TNEXT] = t_next
    st[_SYNC] = -1
    if ev.shape[0] > 0:
        if _net_eval(t, net, addrs, st) or _indicators(fmu, ev, Z, st):
            return True
        _copy_row(Z, 0, Z, 1)
    return False


@numba.njit(cache=True, _nrt=False)
def _time_events(t, synced, net, evt, addrs, st):
    """Event iteration at ``t`` of the FMUs whose next time event has come (``synced``: they hold t and X)."""
    ff = evt[7]
    if not time_event_due(ff[_TNEXT], t):
        return False
    me, due, tev = net[1], evt[3], evt[4]
    for i in range(me.shape[0]):
        due[me[i]] = 1 if time_event_due(tev[me[i]], t) else 0
    if not synced and _net_eval(t, net, addrs, st):
        return True
    return _handle_events(t, _TIME, net, evt, addrs, st)


@numba.njit(cache=True, _nrt=False)
def _step_from(t, h, net, W, E, addrs, st):
    """One RK4 step of length h from (t, E[0]) whose first-stage derivative is E[1]; W[0] holds the result."""
    for i in range(W.shape[1]):
        W[0, i] = E[0, i]
        W[1, i] = E[0, i]
        W[2, i] = E[1, i]
    th = t + 0.5 * h
    _stage(W, 0, 0.5 * h)
    if _net_deriv(th, net, addrs, st):
        return True
    _stage(W, 1, 0.5 * h)
    if _net_deriv(th, net, addrs, st):
        return True
    _stage(W, 2, h)
    if _net_deriv(t + h, net, addrs, st):
        return True
    for i in range(W.shape[1]):
        W[0, i] = W[1, i] + h / 6.0 * (W[3, i] + 2.0 * W[4, i] + 2.0 * W[5, i] + W[2, i])
        W[1, i] = W[0, i]
    return False


@numba.njit(cache=True, _nrt=False)
def _trial(t, h, net, evt, W, addrs, st):
    """Integrate to t + h and mark the FMUs whose indicators changed sign; their number, -1 on an error."""
    if _step_from(t, h, net, W, evt[2], addrs, st) or _net_eval(t + h, net, addrs, st):
        return -1
    if _indicators(net[0], evt[0], evt[1], st):
        return -1
    return _crossed(evt[0], evt[1], evt[3])


@numba.njit(cache=True, _nrt=False)
def _input_events(t, k, net, evt, addrs, st):
    """At an instant, after the new inputs are set: an indicator that changed sign is an event at ``t``."""
    if st[_SYNC] != k and _net_eval(t, net, addrs, st):
        return True
    if _indicators(net[0], evt[0], evt[1], st):
        return True
    if _crossed(evt[0], evt[1], evt[3]) > 0:
        return _handle_events(t, _INPUT, net, evt, addrs, st)
    _copy_row(evt[1], 0, evt[1], 1)
    return False


@numba.njit(cache=True, _nrt=False)
def _after_step(t1, net, evt, cmp, addrs, st):
    """A step ended at ``t1`` without a state event: accept the indicators, step events, time events due."""
    _copy_row(evt[1], 0, evt[1], 1)
    if cmp.shape[0] > 0:
        n = _completed(net[0], cmp, evt[5], evt[3], st)
        if n < 0 or (n > 0 and _handle_events(t1, _STEP, net, evt, addrs, st)):
            return True
    return _time_events(t1, True, net, evt, addrs, st)


@numba.njit(cache=True, _nrt=False)
def _rk4_events(ta, tb, n, net, evt, cmp, W, addrs, st):
    """RK4 from ta to tb on n equal steps, each cut at time events and at located state events (bisection on
    the step length to EVENT_TOL, each trial re-integrating from the step's start): the rules of the Python
    engine (``PlantSystem._rk4_events``). True on an error."""
    E = evt[2]
    ff = evt[7]
    n_ev = evt[0].shape[0]
    L = tb - ta
    st[_SYNC] = -1
    j = 1
    t = ta
    while t < tb:
        grid = tb if j == n else ta + L * j / n
        if _time_events(t, False, net, evt, addrs, st):
            return True
        t1 = step_end(t, ff[_TNEXT], grid)
        _copy_row(E, 0, W, 0)
        if _net_deriv(t, net, addrs, st):
            return True
        _copy_row(E, 1, W, 2)
        hits = _trial(t, t1 - t, net, evt, W, addrs, st) if n_ev > 0 else 0
        if hits < 0:
            return True
        if hits > 0:
            lo, hi = 0.0, t1 - t
            mid = bisection_trial(lo, hi, ff[_TOL])
            while mid >= 0:
                hits = _trial(t, mid, net, evt, W, addrs, st)
                if hits < 0:
                    return True
                lo, hi = bisection_narrow(lo, hi, mid, hits > 0)
                mid = bisection_trial(lo, hi, ff[_TOL])
            t1 = t + hi
            if _trial(t, hi, net, evt, W, addrs, st) < 0 or _handle_events(t1, _STATE, net, evt, addrs, st):
                return True
        else:
            if n_ev == 0 and (_step_from(t, t1 - t, net, W, E, addrs, st) or _net_eval(t1, net, addrs, st)):
                return True
            if _after_step(t1, net, evt, cmp, addrs, st):
                return True
        if t1 >= grid:
            j += 1
        t = t1
    return False


@numba.njit(cache=True, _nrt=False, inline=_in_plain_loop)
def _rk4(t, t_next, k, h_max, fmu, me, port, typed, pgrp, lvl, buf, rsrc, rdst, rgain, roff, rgrp, W, x_addr, dx_addr,
         buf_addr, st):
    """RK4 substeps of the ME FMUs' combined state from ``t`` to ``t_next`` when no FMU has events or asks for
    CompletedIntegratorStep (the plain path, as fast as before events existed); True on an FMI error."""
    nX = W.shape[1]
    L = t_next - t
    n = max(1, math.ceil(L / h_max - 1e-9))
    synced = st[_SYNC] == k  # the first stage can reuse (t, X) set when sampling: only the inputs changed
    st[_SYNC] = -1
    for i in range(nX):
        W[1, i] = W[0, i]
    for j in range(n):
        ta = t + L * j / n
        t1 = t + L * (j + 1) / n
        h = t1 - ta
        th = ta + 0.5 * h
        if _deriv(ta, not (synced and j == 0), fmu, me, port, typed, pgrp, lvl, buf, rsrc, rdst, rgain, roff, rgrp,
                  x_addr, dx_addr, buf_addr, st):
            return True
        _stage(W, 0, 0.5 * h)
        if _deriv(th, True, fmu, me, port, typed, pgrp, lvl, buf, rsrc, rdst, rgain, roff, rgrp, x_addr, dx_addr,
                  buf_addr, st):
            return True
        _stage(W, 1, 0.5 * h)
        if _deriv(th, True, fmu, me, port, typed, pgrp, lvl, buf, rsrc, rdst, rgain, roff, rgrp, x_addr, dx_addr,
                  buf_addr, st):
            return True
        _stage(W, 2, h)
        if _deriv(t1, True, fmu, me, port, typed, pgrp, lvl, buf, rsrc, rdst, rgain, roff, rgrp, x_addr, dx_addr,
                  buf_addr, st):
            return True
        for i in range(nX):
            W[0, i] = W[1, i] + h / 6.0 * (W[3, i] + 2.0 * W[4, i] + 2.0 * W[5, i] + W[2, i])
            W[1, i] = W[0, i]
    return False


@numba.njit(cache=True, _nrt=False, inline=_in_plain_loop)
def _do_steps(t, t_next, fmu, cs, scr, st):
    """doStep of every CS FMU from ``t`` to ``t_next``; True on an FMI error or a request to terminate."""
    for i in range(cs.shape[0]):
        f = cs[i]
        if fmu[f, _V] == 3:
            s = native.do_step3(fmu[f, _DS], fmu[f, _C], t, t_next - t, fmu[f, _SC])
        else:
            s = native.do_step2(fmu[f, _DS], fmu[f, _C], t, t_next - t)
        if s > 1:
            return _fail(st, f, 5, s)
        if fmu[f, _V] == 3 and scr[f, 1] != 0:
            return _fail(st, f, 7, 0)
    return False


@numba.njit(cache=True, _nrt=False)
def _advance_events(t, t_next, k, net, evt, cmp, W, addrs, st):
    """Bring the ME FMUs from ``t`` to ``t_next`` when one has event indicators or asks for
    CompletedIntegratorStep, or a time event falls before ``t_next``: input events at ``t``, then the
    event-locating steps. True on an error."""
    nX = W.shape[1]
    if evt[0].shape[0] > 0 and _input_events(t, k, net, evt, addrs, st):
        return True
    n = 1 if nX == 0 else max(1, math.ceil((t_next - t) / evt[7][_HMAX] - 1e-9))
    return _rk4_events(t, t_next, n, net, evt, cmp, W, addrs, st)


@numba.njit(cache=True, _nrt=False)
def run_chunk(fmu, me, cmp, cs, port, typed, pgrp, rsrc, rdst, rgain, roff, rgrp, lvl, ctl, ii, ff, buf, W, rec,
              times, rows, rec_idx, calls, scr, st, evt, max_instants):
    """Run at most ``max_instants`` instants from the state in ``st``; returns DONE, MORE or ERROR.

    ``evt`` is ``(ev, Z, E, due, tev, scr, scr64, ff, log)``, or None when no FMU can have events (no event
    indicators, no CompletedIntegratorStep, no time event announced at initialisation): numba then compiles a
    version without the event code (its branch is pruned), the loop as it was before events existed.
    """
    k_stop = ii[0]
    rec_p = ii[1]
    num = ii[2]
    den = ii[3]
    n_per = ii[4]
    t0 = ff[_T0]
    h_max = ff[_HMAX]
    buf_addr = buf.ctypes.data
    nX = W.shape[1]
    x_addr = W.ctypes.data
    dx_addr = x_addr + 8 * 2 * nX
    n_me = me.shape[0]
    k = st[_K]
    row = rows[0]
    if max_instants <= 0:
        return MORE
    if st[_FIRST] == 1:
        st[_FIRST] = 0
        if _io(fmu, port, typed, pgrp, 1, buf_addr, True, st):
            return ERROR
    code = MORE
    for _ in range(max_instants):
        if evt is not None and 2 * st[_NLOG] > evt[8].shape[0]:
            break  # the event log is half full: Python reads it before the next chunk
        t = t0 + (k * den) / num
        # 1. sample
        if n_me > 0:
            if _eval(t, True, fmu, me, port, typed, pgrp, lvl, buf, rsrc, rdst, rgain, roff, rgrp, x_addr, buf_addr,
                     st):
                code = ERROR
                break
            st[_SYNC] = k
        if _io(fmu, port, typed, pgrp, 0, buf_addr, False, st):
            code = ERROR
            break
        # 2. instant FMU-to-FMU routes
        _route(buf, rsrc, rdst, rgain, roff, rgrp, 0)
        if k < k_stop:
            # 3. controllers due, in order
            for c in range(ctl.shape[0]):
                if k % ctl[c, 1] == 0:
                    _route(buf, rsrc, rdst, rgain, roff, rgrp, ctl[c, 2])
                    native.call_kernel(ctl[c, 0], t, ctl[c, 3], ctl[c, 4], ctl[c, 5], ctl[c, 6], ctl[c, 7], ctl[c, 8],
                                       ctl[c, 9], ctl[c, 10])
                    calls[c] += 1
            # 4. hold: controller outputs to the FMUs
            _route(buf, rsrc, rdst, rgain, roff, rgrp, 1)
            if _io(fmu, port, typed, pgrp, 1, buf_addr, True, st):
                code = ERROR
                break
        if nonfinite(buf, W):  # Python names the value (cosim.master.finite)
            _fail(st, 0, _FN_NONFINITE, 0)
            code = ERROR
            break
        # 5. record
        if k % rec_p == 0:
            times[row] = t
            for j in range(rec_idx.shape[0]):
                rec[row, j] = buf[rec_idx[j]]
            row += 1
        if k >= k_stop:
            code = DONE
            break
        k_next = k_stop
        for j in range(n_per):
            p = ii[5 + j]
            kn = (k // p + 1) * p
            if kn < k_next:
                k_next = kn
        t_next = t0 + (k_next * den) / num
        # 6. advance: RK4 over the ME FMUs (locating events when they have some), then doStep of the CS FMUs
        if n_me > 0:
            plain = True
            if evt is not None:
                plain = not (evt[0].shape[0] > 0 or cmp.shape[0] > 0 or ff[_TNEXT] <= t_next)
                net = (fmu, me, port, typed, pgrp, lvl, buf, rsrc, rdst, rgain, roff, rgrp)
                if not plain and _advance_events(t, t_next, k, net, evt, cmp, W, (x_addr, dx_addr, buf_addr), st):
                    code = ERROR
                    break
            if plain and nX > 0 and _rk4(t, t_next, k, h_max, fmu, me, port, typed, pgrp, lvl, buf, rsrc, rdst, rgain,
                                         roff, rgrp, W, x_addr, dx_addr, buf_addr, st):
                code = ERROR
                break
        if _do_steps(t, t_next, fmu, cs, scr, st):
            ff[_EVT] = t_next
            code = ERROR
            break
        k = k_next
    st[_K] = k
    rows[0] = row
    return code
