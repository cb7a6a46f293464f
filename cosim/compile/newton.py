"""Newton's method as CasADi expressions that C code can be generated for (CasADi cannot generate C for its own
rootfinders): one SX step ``v - J(v)^-1 r(v)``, folded a fixed number of times (a loop in the C code)."""

import casadi as ca

__all__ = ["NEWTON_ITERATIONS", "newton"]

# Newton iterations unrolled into the generated code.
NEWTON_ITERATIONS = 30


def newton(k, unknowns, residual, context):
    """A solver for ``0 = residual(unknowns, context)``: a CasADi function of (guess, context repeated
    NEWTON_ITERATIONS times as columns) returning the unknowns after NEWTON_ITERATIONS steps.

    Parameters
    ----------
    k : int or str
        Distinguishes the step functions' names.
    unknowns, residual, context : casadi.SX
        Column vectors; ``residual`` depends on ``unknowns`` and ``context`` only.

    Returns
    -------
    casadi.Function
    """
    jac = ca.jacobian(residual, unknowns)
    step = ca.Function(f"newton_step{k}", [unknowns, context], [unknowns - ca.solve(jac, residual)])
    return step.fold(NEWTON_ITERATIONS)
