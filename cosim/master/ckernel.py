"""The compiled engine's per-instant kernel: one numba function that runs a chunk of instants.

It does exactly what :class:`cosim.master.loop.PythonLoop` and :class:`cosim.master.plant.PlantSystem`
do at each instant, in the same order and with the same floating-point operations (so both engines
give the same numbers): sample the plant, route, step the due controllers (numba ``cfunc`` kernels
called by address), hold their outputs, record, and advance the plant (RK4 substeps over the ME
FMUs' combined state, ``doStep`` of CS FMUs). FMU functions are called by address through
:mod:`cosim.fmi.native`. Everything a run needs is in integer/float tables built by
``cosim.master.compiled.CompiledLoop``; the kernel itself is compiled once and cached on disk.

Tables (all int64 unless said):

``fmu`` (n_fmu, N_FMU_COLS)
    per FMU: component, SetTime, SetContinuousStates, GetDerivatives, GetReal, SetReal, DoStep,
    CompletedIntegratorStep addresses, FMI version, state offset in X, number of states, scratch
    address (16 bytes for the flags of CompletedIntegratorStep / DoStep).
``me``, ``cmp``, ``cs`` (n,)
    FMU indices of the ME FMUs (in order), of those needing CompletedIntegratorStep, of the CS FMUs.
``port`` (n_port, 4)
    FMU index, value-reference array address, n, offset in the signal buffer.
``pgrp`` (n_group, 2)
    port ranges: 0 sampled ports (get), 1 instant inputs (set), then per ME-to-ME level its gets and sets.
``rsrc``, ``rdst``, ``rgain`` (float64), ``roff`` (float64), ``rgrp`` (n_group, 2)
    routing ``buf[dst] = gain buf[src] + off``: group 0 instant FMU-to-FMU, 1 controllers to FMUs,
    then one per controller (its inputs), then one per ME-to-ME level.
``lvl`` (n_level, 3)
    port group of the level's gets, its route group, port group of its sets.
``ctl`` (n_ctrl, N_CTL_COLS)
    cfunc address, period (ticks), route group, then address and length of u, y, x, p.
``ii``
    k_stop, record period, time-base numerator, denominator, number of periods, then the periods.
``ff`` (float64)
    start time, h_max.
``st`` (N_ST,)
    run state kept between chunks: k, synced tick, first-chunk flag, error FMU, error function,
    error status, event FMU + 1, event tick.
``rec`` (n_rows, n_col) float64, ``times`` (n_rows,) float64, ``rows`` (1,)
    the recorder's arrays (:class:`cosim.master.recorder.Recorder`): rows are written at ``rows[0]``.
``scr`` (n_fmu, 16) uint8
    the scratch bytes whose addresses are in ``fmu`` (flags written by the FMUs).

The kernel is compiled without numba's reference counting (``_nrt=False``: nothing is allocated in
it; with reference counting the array arguments of the helpers cost two atomic operations per call
and made the loop four times slower). numba's on-disk cache keys on this file only: after editing
:mod:`cosim.fmi.native`, touch this file (or delete its ``__pycache__`` entries) so the kernel recompiles.
"""

import math

import numba

from cosim.fmi import native

__all__ = ["run_chunk", "FMU_COLS", "CTL_COLS", "ST", "FUNCTIONS", "DONE", "MORE", "ERROR"]

FMU_COLS = ("component", "SetTime", "SetContinuousStates", "GetDerivatives", "GetReal", "SetReal", "DoStep",
            "CompletedIntegratorStep", "version", "x_off", "n_states", "scratch")
(_C, _ST, _SX, _GD, _GR, _SR, _DS, _CI, _V, _XO, _NX, _SC) = range(len(FMU_COLS))
CTL_COLS = ("fn", "period", "route", "u", "nu", "y", "ny", "x", "nx", "p", "np")
ST = ("k", "synced", "first", "err_fmu", "err_fn", "err_status", "event_fmu", "event_k")
(_K, _SYNC, _FIRST, _EF, _EFN, _ES, _EVF, _EVK) = range(len(ST))
FUNCTIONS = ("SetTime", "SetContinuousStates", "GetDerivatives", "GetReal", "SetReal", "DoStep",
             "CompletedIntegratorStep", "DoStep:terminate")
DONE, MORE, ERROR = 0, 1, 2


@numba.njit(cache=True, _nrt=False)
def _fail(st, f, fn, status):
    st[_EF] = f
    st[_EFN] = fn
    st[_ES] = status
    return True


@numba.njit(cache=True, _nrt=False)
def _io(fmu, port, grp, g, buf_addr, setter, st):
    """Get (``setter`` False) or set the ports of group ``g``; True on an FMI error."""
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
            return _fail(st, f, 4 if setter else 3, s)
    return False


@numba.njit(cache=True, _nrt=False)
def _route(buf, rsrc, rdst, rgain, roff, rgrp, g):
    for j in range(rgrp[g, 0], rgrp[g, 1]):
        buf[rdst[j]] = rgain[j] * buf[rsrc[j]] + roff[j]


@numba.njit(cache=True, _nrt=False)
def _eval(t, push, fmu, me, port, pgrp, lvl, buf, rsrc, rdst, rgain, roff, rgrp, x_addr, buf_addr, st):
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
        if _io(fmu, port, pgrp, lvl[lv, 0], buf_addr, False, st):
            return True
        _route(buf, rsrc, rdst, rgain, roff, rgrp, lvl[lv, 1])
        if _io(fmu, port, pgrp, lvl[lv, 2], buf_addr, True, st):
            return True
    return False


@numba.njit(cache=True, _nrt=False)
def _deriv(t, push, fmu, me, port, pgrp, lvl, buf, rsrc, rdst, rgain, roff, rgrp, x_addr, dx_addr, buf_addr, st):
    if _eval(t, push, fmu, me, port, pgrp, lvl, buf, rsrc, rdst, rgain, roff, rgrp, x_addr, buf_addr, st):
        return True
    for i in range(me.shape[0]):
        f = me[i]
        s = native.vec(fmu[f, _GD], fmu[f, _C], dx_addr + 8 * fmu[f, _XO], fmu[f, _NX])
        if s > 1:
            return _fail(st, f, 2, s)
    return False


@numba.njit(cache=True, _nrt=False)
def _stage(W, s, c):
    for i in range(W.shape[1]):
        W[3 + s, i] = W[2, i]
        W[0, i] = W[1, i] + c * W[2, i]


@numba.njit(cache=True, _nrt=False)
def _completed(k, fmu, cmp, scr, st):
    """CompletedIntegratorStep of the ME FMUs that need it; notes the first event request; True on an FMI error."""
    for i in range(cmp.shape[0]):
        f = cmp[i]
        sc = fmu[f, _SC]
        if fmu[f, _V] == 3:
            s = native.completed3(fmu[f, _CI], fmu[f, _C], sc)
        else:
            s = native.completed2(fmu[f, _CI], fmu[f, _C], sc)
        if s > 1:
            return _fail(st, f, 6, s)
        if st[_EVF] == 0 and (scr[f, 0] != 0 or (fmu[f, _V] == 2 and (scr[f, 1] | scr[f, 2] | scr[f, 3]) != 0)):
            st[_EVF] = f + 1
            st[_EVK] = k
    return False


@numba.njit(cache=True, _nrt=False)
def _rk4(t, t_next, k, h_max, fmu, me, cmp, port, pgrp, lvl, buf, rsrc, rdst, rgain, roff, rgrp, W, x_addr, dx_addr,
         buf_addr, scr, st):
    """RK4 substeps of the ME FMUs' combined state from ``t`` to ``t_next``; True on an FMI error."""
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
        if _deriv(ta, not (synced and j == 0), fmu, me, port, pgrp, lvl, buf, rsrc, rdst, rgain, roff, rgrp,
                  x_addr, dx_addr, buf_addr, st):
            return True
        _stage(W, 0, 0.5 * h)
        if _deriv(th, True, fmu, me, port, pgrp, lvl, buf, rsrc, rdst, rgain, roff, rgrp, x_addr, dx_addr,
                  buf_addr, st):
            return True
        _stage(W, 1, 0.5 * h)
        if _deriv(th, True, fmu, me, port, pgrp, lvl, buf, rsrc, rdst, rgain, roff, rgrp, x_addr, dx_addr,
                  buf_addr, st):
            return True
        _stage(W, 2, h)
        if _deriv(t1, True, fmu, me, port, pgrp, lvl, buf, rsrc, rdst, rgain, roff, rgrp, x_addr, dx_addr,
                  buf_addr, st):
            return True
        for i in range(nX):
            W[0, i] = W[1, i] + h / 6.0 * (W[3, i] + 2.0 * W[4, i] + 2.0 * W[5, i] + W[2, i])
            W[1, i] = W[0, i]
        if cmp.shape[0] > 0:
            if _eval(t1, True, fmu, me, port, pgrp, lvl, buf, rsrc, rdst, rgain, roff, rgrp, x_addr, buf_addr, st):
                return True
            if _completed(k, fmu, cmp, scr, st):
                return True
    return False


@numba.njit(cache=True, _nrt=False)
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
def run_chunk(fmu, me, cmp, cs, port, pgrp, rsrc, rdst, rgain, roff, rgrp, lvl, ctl, ii, ff, buf, W, rec, times,
              rows, rec_idx, calls, scr, st, max_instants):
    """Run at most ``max_instants`` instants from the state in ``st``; returns DONE, MORE or ERROR."""
    k_stop = ii[0]
    rec_p = ii[1]
    num = ii[2]
    den = ii[3]
    n_per = ii[4]
    t0 = ff[0]
    h_max = ff[1]
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
        if _io(fmu, port, pgrp, 1, buf_addr, True, st):
            return ERROR
    code = MORE
    for _ in range(max_instants):
        t = t0 + (k * den) / num
        # 1. sample
        if n_me > 0:
            if _eval(t, True, fmu, me, port, pgrp, lvl, buf, rsrc, rdst, rgain, roff, rgrp, x_addr, buf_addr, st):
                code = ERROR
                break
            st[_SYNC] = k
        if _io(fmu, port, pgrp, 0, buf_addr, False, st):
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
            if _io(fmu, port, pgrp, 1, buf_addr, True, st):
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
        # 6. advance: RK4 over the ME FMUs, then doStep of the CS FMUs
        if n_me > 0 and nX > 0:
            if _rk4(t, t_next, k, h_max, fmu, me, cmp, port, pgrp, lvl, buf, rsrc, rdst, rgain, roff, rgrp, W, x_addr,
                    dx_addr, buf_addr, scr, st):
                code = ERROR
                break
        if _do_steps(t, t_next, fmu, cs, scr, st):
            code = ERROR
            break
        k = k_next
    st[_K] = k
    rows[0] = row
    return code
