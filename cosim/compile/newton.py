"""Newton's method as CasADi expressions that C code can be generated for (CasADi cannot generate C for its own
rootfinders): one SX step ``v - J(v)^-1 r(v)``, folded a fixed number of times (a loop in the C code), and the
test that those iterations converged (:func:`converged`): a solve that did not is an error at run time, not a
number."""

import casadi as ca

__all__ = ["NEWTON_ITERATIONS", "RETRY_ITERATIONS", "STEP_TOLERANCE", "newton", "loop_solvers", "converged"]

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
    new = _damped(unknowns, delta, lambda u: ca.sumsqr(ca.substitute(residual, unknowns, u))) if damped \
        else unknowns - delta
    step = ca.Function(f"newton_step{k}", [unknowns, context], [new])
    return step.fold(iterations)


def _damped(unknowns, delta, norm):
    """The longest of the steps ``-delta``, ``-delta/2``, ... from ``unknowns`` that lowers ``norm`` (a function
    of the unknowns: the residual's squared norm)."""
    before = norm(unknowns)
    new = unknowns - delta / 2**HALVINGS  # when no tried step lowers the residual: the shortest one
    for j in reversed(range(HALVINGS)):
        candidate = unknowns - delta / 2**j
        new = ca.if_else(norm(candidate) < before, candidate, new)
    return new


def loop_solvers(k, unknowns, residual, context):
    """The solvers of a loop of the generated code, sharing one Newton step (the C code holds it once): Newton's
    method (as :func:`newton`, NEWTON_ITERATIONS), its retry (RETRY_ITERATIONS, damped as :func:`newton`'s: full steps
    can cycle between a limiter's pieces), both of (guess, context repeated as columns), and the chord method, of
    (guess, context): NEWTON_ITERATIONS Newton steps with the Jacobian kept from the guess, as DAE solvers keep it.
    Where the guess is a solution on a branch that has just ended (a limiter's saturation past a Schmitt trigger's
    threshold), Newton's method can cycle between the pieces of a piecewise-linear residual whose targets each lie
    on the other piece; the Jacobian of the branch the guess is on leads across them, to the other saturation, whose
    Jacobian is the same.

    The step takes the Jacobian's entries that are not constant as an argument, the constant ones (the loop's
    linear equations) staying in its expressions, so that its elimination simplifies as Newton's did."""
    jac = ca.jacobian(residual, unknowns)
    varying = [e for e in jac.nonzeros() if not e.is_constant()]
    held = ca.SX.sym("jacobian", len(varying))
    entries = iter(ca.vertsplit(held))
    matrix = ca.SX(jac.sparsity(), ca.vertcat(*[e if e.is_constant() else next(entries) for e in jac.nonzeros()]))
    step = ca.Function(f"newton_step{k}", [unknowns, held, context], [unknowns - ca.solve(matrix, residual)])
    at = ca.Function(f"newton_jacobian{k}", [unknowns, context], [ca.vertcat(*varying)])
    v, c, h = ca.MX.sym("v", unknowns.shape[0]), ca.MX.sym("c", context.shape[0]), ca.MX.sym("h", held.shape[0])
    newton_step = ca.Function(f"newton_iteration{k}", [v, c], [step(v, at(v, c), c)])
    r = ca.Function(f"newton_residual{k}", [unknowns, context], [residual])
    damped_step = ca.Function(f"damped_iteration{k}", [v, c], [_damped(v, v - newton_step(v, c),
                                                                         lambda u: ca.sumsqr(r(u, c)))])
    chord_steps = ca.Function(f"chord_iteration{k}", [v, ca.vertcat(h, c)], [step(v, h, c)]).fold(NEWTON_ITERATIONS)
    held_at_guess = ca.Function(f"chord{k}", [v, c], [chord_steps(v, ca.repmat(ca.vertcat(at(v, c), c), 1,
                                                                                 NEWTON_ITERATIONS))])
    return newton_step.fold(NEWTON_ITERATIONS), damped_step.fold(RETRY_ITERATIONS), held_at_guess


def converged(k, unknowns, residual, context):
    """A CasADi function of (unknowns, context) that is 1 where ``unknowns`` solve ``0 = residual`` (one more
    Newton step from them is within STEP_TOLERANCE of their size), 0 where not (a singular Jacobian or a
    residual that is not a number included: NaN compares false)."""
    delta = ca.solve(ca.jacobian(residual, unknowns), residual)
    ok = ca.mmax(ca.fabs(delta)) <= STEP_TOLERANCE * (1 + ca.mmax(ca.fabs(unknowns)))
    return ca.Function(f"newton_converged{k}", [unknowns, context], [ok])
