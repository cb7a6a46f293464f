"""Calls of C entry points from numba-compiled code, by address (the compiled engine's FFI).

Each function here is a numba intrinsic: it takes the address of a C function (an ``int64``, from
:meth:`cosim.fmi.FmuInstance.entry_points` or a numba ``cfunc``) and its arguments as ``int64``
addresses / ``float64`` values, and emits one indirect call. Addresses are run-time data, never
compile-time constants, so a kernel using these intrinsics compiles once and is cached on disk
(``numba.njit(cache=True)``) whatever FMUs a run loads. Usable only inside numba-compiled code.

Signatures (FMI 2.0 and 3.0 share the first two; statuses are returned as int32):

* :func:`set_time` ``fmiXSetTime(c, t)``
* :func:`vec` ``fmiXSetContinuousStates / GetContinuousStates / GetDerivatives(c, double*, size_t)``
* :func:`real3` ``fmi3GetFloat64 / SetFloat64(c, const uint32* vr, size_t n, double* v, size_t n)``, and the
  Get/Set functions of the other value types (``fmi3GetInt32``, ``fmi3SetBoolean``, ...), whose signature differs
  only in the type ``v`` points to
* :func:`real2` ``fmi2GetReal / SetReal(c, const uint32* vr, size_t n, double* v)``, and ``fmi2GetInteger`` /
  ``fmi2SetBoolean`` ... likewise
* :func:`completed3` ``fmi3CompletedIntegratorStep(c, true, bool* enterEventMode, bool* terminate)``:
  flags written to the two bytes at ``flags``
* :func:`completed2` ``fmi2CompletedIntegratorStep(c, 1, int* enterEventMode, int* terminate)``:
  flags written to the two int32 at ``flags``
* :func:`do_step3` ``fmi3DoStep(c, t, h, true, bool*, bool* terminate, bool*, double*)``: the three
  flags at ``scratch`` bytes 0..2 (terminate at byte 1), the last successful time at ``scratch + 8``
* :func:`do_step2` ``fmi2DoStep(c, t, h, 1)``
* :func:`call0` ``fmiXEnterEventMode / EnterContinuousTimeMode(c)``
* :func:`update3` ``fmi3UpdateDiscreteStates(c, bool*, bool*, bool*, bool*, bool*, double*)``: the five flags
  at ``scratch`` bytes 0..4, the next event time at ``scratch + 8``
* :func:`update2` ``fmi2NewDiscreteStates(c, fmi2EventInfo*)``: the struct (five int32, the next event
  time at byte 24) at ``scratch``
* ``load_<type>(addr) -> float64`` / ``store_<type>(addr, float64)`` for ``f64 f32 i8 u8 i16 u16 i32 u32 i64
  u64``: one value of that C type at ``addr``, converted to or from a double (stores truncate: round first);
  the compiled engine's typed ports convert through them
* :func:`call_kernel` ``void kernel(double t, double* u, int64 nu, double* y, int64 ny, double* x,
  int64 nx, double* p, int64 np)``: a controller kernel compiled as a numba ``cfunc``
"""

from llvmlite import ir
from numba.core import types
from numba.extending import intrinsic

__all__ = ["set_time", "vec", "real3", "real2", "completed3", "completed2", "do_step3", "do_step2", "call0",
           "update3", "update2", "call_kernel", "KERNEL_SIGNATURE", "load_f64", "store_f64", "load_f32", "store_f32",
           "load_i8", "store_i8", "load_u8", "store_u8", "load_i16", "store_i16", "load_u16", "store_u16", "load_i32",
           "store_i32", "load_u32", "store_u32", "load_i64", "store_i64", "load_u64", "store_u64"]

_I8P = ir.IntType(8).as_pointer()
_I32 = ir.IntType(32)
_I64 = ir.IntType(64)
_DBL = ir.DoubleType()
_VOID = ir.VoidType()


def _make(spec, ret, doc):
    """An intrinsic ``f(fn, *args)`` calling the C function at address ``fn``.

    ``spec`` gives each C argument: ``P`` pointer (from an int64 address), ``D`` double, ``Z`` size_t
    (int64), ``I`` int (int32: also C ``bool`` inputs, passed zero-extended), ``1`` the constant
    int32 1 (not a Python argument), ``+N`` the first pointer argument plus N bytes (not a Python
    argument). ``ret``: ``"i32"`` (a status) or ``"void"``.
    """
    n_py = sum(1 for s in spec if s in "PDZI")

    def typer(typingctx, fn, *args):
        if len(args) != n_py:
            return None
        rt = types.int32 if ret == "i32" else types.void
        sig = rt(fn, *args)

        def codegen(context, builder, signature, llargs):
            c_args, c_types = [], []
            last_ptr = None
            it = iter(llargs[1:])
            for s in spec:
                if s == "P":
                    c_args.append(builder.inttoptr(next(it), _I8P))
                    c_types.append(_I8P)
                elif s == "D":
                    c_args.append(next(it))
                    c_types.append(_DBL)
                elif s == "Z":
                    c_args.append(next(it))
                    c_types.append(_I64)
                elif s == "I":
                    c_args.append(builder.trunc(next(it), _I32))
                    c_types.append(_I32)
                elif s == "1":
                    c_args.append(ir.Constant(_I32, 1))
                    c_types.append(_I32)
                else:  # "+N": an offset into the last pointer argument given
                    c_args.append(builder.gep(last_ptr, [ir.Constant(_I64, int(s[1:]))]))
                    c_types.append(_I8P)
                if s == "P":
                    last_ptr = c_args[-1]
            fnty = ir.FunctionType(_I32 if ret == "i32" else _VOID, c_types)
            fp = builder.inttoptr(llargs[0], fnty.as_pointer())
            out = builder.call(fp, c_args)
            return out if ret == "i32" else context.get_dummy_value()

        return sig, codegen

    # numba's intrinsic needs an explicit positional signature: build one per arity
    names = ", ".join(f"a{i}" for i in range(n_py))
    ns = {"typer": typer}
    exec(f"def _typer(typingctx, fn, {names}):\n    return typer(typingctx, fn, {names})\n", ns)
    f = intrinsic(ns["_typer"])
    f.__doc__ = doc
    return f


def _spec(*items):
    return list(items)


set_time = _make(_spec("P", "D"), "i32", "fmiXSetTime(fn, c, t) -> status")
vec = _make(_spec("P", "P", "Z"), "i32", "fmiX{Set,Get}ContinuousStates / GetDerivatives(fn, c, ptr, n) -> status")
real3 = _make(_spec("P", "P", "Z", "P", "Z"), "i32", "fmi3{Get,Set}Float64(fn, c, vr, n, values, n) -> status")
real2 = _make(_spec("P", "P", "Z", "P"), "i32", "fmi2{Get,Set}Real(fn, c, vr, n, values) -> status")
completed3 = _make(_spec("P", "1", "P", "+1"), "i32", "fmi3CompletedIntegratorStep(fn, c, flags) -> status")
completed2 = _make(_spec("P", "1", "P", "+4"), "i32", "fmi2CompletedIntegratorStep(fn, c, flags) -> status")
do_step3 = _make(_spec("P", "D", "D", "1", "P", "+1", "+2", "+8"), "i32", "fmi3DoStep(fn, c, t, h, scratch) -> status")
do_step2 = _make(_spec("P", "D", "D", "1"), "i32", "fmi2DoStep(fn, c, t, h) -> status")
call0 = _make(_spec("P"), "i32", "fmiXEnterEventMode / EnterContinuousTimeMode(fn, c) -> status")
update3 = _make(_spec("P", "P", "+1", "+2", "+3", "+4", "+8"), "i32",
                "fmi3UpdateDiscreteStates(fn, c, scratch) -> status")
update2 = _make(_spec("P", "P"), "i32", "fmi2NewDiscreteStates(fn, c, scratch) -> status")
call_kernel = _make(_spec("D", "P", "Z", "P", "Z", "P", "Z", "P", "Z"), "void",
                    "kernel(fn, t, u, nu, y, ny, x, nx, p, np): a controller kernel compiled as a cfunc")



def _memory(llty, signed):
    """The intrinsics ``load(addr) -> float64`` and ``store(addr, value)`` of one C value of type ``llty`` at the
    int64 address ``addr`` (integers: ``signed`` or not; a store of a double into an integer truncates)."""

    def to_double(builder, v):
        if isinstance(llty, ir.DoubleType):
            return v
        if isinstance(llty, ir.FloatType):
            return builder.fpext(v, _DBL)
        return builder.sitofp(v, _DBL) if signed else builder.uitofp(v, _DBL)

    def from_double(builder, v):
        if isinstance(llty, ir.DoubleType):
            return v
        if isinstance(llty, ir.FloatType):
            return builder.fptrunc(v, llty)
        return builder.fptosi(v, llty) if signed else builder.fptoui(v, llty)

    def load_typer(typingctx, addr):
        def codegen(context, builder, signature, args):
            return to_double(builder, builder.load(builder.inttoptr(args[0], llty.as_pointer())))

        return types.float64(addr), codegen

    def store_typer(typingctx, addr, value):
        def codegen(context, builder, signature, args):
            builder.store(from_double(builder, args[1]), builder.inttoptr(args[0], llty.as_pointer()))
            return context.get_dummy_value()

        return types.void(addr, value), codegen

    return intrinsic(load_typer), intrinsic(store_typer)


load_f64, store_f64 = _memory(_DBL, True)
load_f32, store_f32 = _memory(ir.FloatType(), True)
load_i8, store_i8 = _memory(ir.IntType(8), True)
load_u8, store_u8 = _memory(ir.IntType(8), False)
load_i16, store_i16 = _memory(ir.IntType(16), True)
load_u16, store_u16 = _memory(ir.IntType(16), False)
load_i32, store_i32 = _memory(_I32, True)
load_u32, store_u32 = _memory(_I32, False)
load_i64, store_i64 = _memory(_I64, True)
load_u64, store_u64 = _memory(_I64, False)

KERNEL_SIGNATURE = types.void(types.float64, types.CPointer(types.float64), types.int64,
                              types.CPointer(types.float64), types.int64, types.CPointer(types.float64), types.int64,
                              types.CPointer(types.float64), types.int64)
"""The numba signature of a controller kernel's cfunc wrapper (see :func:`call_kernel`)."""
