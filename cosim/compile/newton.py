"""Newton's method as CasADi expressions that C code can be generated for (CasADi cannot generate C for its own
rootfinders): one SX step ``v - J(v)^-1 r(v)``, folded a fixed number of times (a loop in the C code), and the
test that those iterations converged (:func:`converged`): a solve that did not is an error at run time, not a
number."""

import casadi as ca

__all__ = ["NEWTON_ITERATIONS", "RETRY_ITERATIONS", "STEP_TOLERANCE", "newton", "converged"]

# Newton iterations unrolled into the generated code.
NEWTON_ITERATIONS = 30
# Damped iterations more, run only where the first NEWTON_ITERATIONS did not converge (an exponential's slow
# approach from far: the Z-diodes of the MSL's OvervoltageProtection need more than 30 from their start values;
# full steps that cycle between the branches of a limiter, as OpAmpDetailed's output current).
RETRY_ITERATIONS = 70
# Converged: one more Newton step would move the unknowns by at most this, relative to their size (1 + max |v|).
# Scale-free in the residual's units; quadratic convergence ends near 1e-16, a double root's linear one after
# NEWTON_ITERATIONS halvings near 1e-9; a loop without a real solution steps by about its unknowns' size.
STEP_TOLERANCE = 1e-8
# A damped step tries the full Newton step, then halves it up to this many times.
HALVINGS = 8


def newton(k, unknowns, residual, context, damped=False, iterations=NEWTON_ITERATIONS):
    """A solver for ``0 = residual(unknowns, context)``: a CasADi function of (guess, context repeated
    ``iterations`` times as columns) returning the unknowns after ``iterations`` steps.

    Parameters
    ----------
    k : int or str
        Distinguishes the step functions' names.
    unknowns, residual, context : casadi.SX
        Column vectors; ``residual`` depends on ``unknowns`` and ``context`` only.
    damped : bool
        Take the longest of the steps 1, 1/2, 1/4, ... that lowers the residual's norm (and stays where the
        residual is defined: ``sqrt`` of a negative overshoot is NaN, which compares false), for start values
        far from the root (an initialisation).
    iterations : int, default NEWTON_ITERATIONS

    Returns
    -------
    casadi.Function
    """
    jac = ca.jacobian(residual, unknowns)
    delta = ca.solve(jac, residual)
    new = _damped(unknowns, residual, delta) if damped else unknowns - delta
    step = ca.Function(f"newton_step{k}", [unknowns, context], [new])
    return step.fold(iterations)


def _damped(unknowns, residual, delta):
    before = ca.sumsqr(residual)
    new = unknowns - delta / 2**HALVINGS  # when no tried step lowers the residual: the shortest one
    for j in reversed(range(HALVINGS)):
        candidate = unknowns - delta / 2**j
        new = ca.if_else(ca.sumsqr(ca.substitute(residual, unknowns, candidate)) < before, candidate, new)
    return new


def converged(k, unknowns, residual, context):
    """A CasADi function of (unknowns, context) that is 1 where ``unknowns`` solve ``0 = residual`` (one more
    Newton step from them is within STEP_TOLERANCE of their size), 0 where not (a singular Jacobian or a
    residual that is not a number included: NaN compares false)."""
    delta = ca.solve(ca.jacobian(residual, unknowns), residual)
    ok = ca.mmax(ca.fabs(delta)) <= STEP_TOLERANCE * (1 + ca.mmax(ca.fabs(unknowns)))
    return ca.Function(f"newton_converged{k}", [unknowns, context], [ok])
