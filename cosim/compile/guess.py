"""The starting point of the Newton iterations that solve a nonlinear algebraic loop in the generated code.

The FMU starts a loop's first solve from its start values (later ones from its last solution), and, where the
loop's equations hold homotopy(), from its simplified model's solution continued to the actual one
(:func:`continued_guess`). Where the loop's unknowns carry no start value (0),
that point can be one where Newton's method cannot move: a resistor heated through a thermal conductor has
``v = R_actual*i`` with ``R_actual`` guessed 0, a singular Jacobian, and every evaluation returns NaN. So the
lowering tries the start values at the model's start point (initial states, default parameters, inputs at their
start, t = 0); when Newton's method does not converge there, it solves the loop once at that point with
scipy's Levenberg-Marquardt (which needs no invertible Jacobian) and starts the generated iterations from that
solution instead. A loop that converges from its start values keeps them, so models that built before keep
their numbers.
"""

import warnings

import casadi as ca
import numpy as np
from scipy.optimize import least_squares

from cosim.compile.causalise import symbol_names
from cosim.compile.newton import NEWTON_ITERATIONS, newton
from cosim.compile.translate import HOMOTOPY
from cosim.errors import LoopWarning

__all__ = ["better_guess", "continued_guess"]

_TOLERANCE = 1e-9  # residual norm, relative to the unknowns' size, of a converged solve
HOMOTOPY_STEPS = 4  # continuation from the simplified model: HOMOTOPY = 0, 1/4, ..., 1


def _converged(residual, solution):
    """True when ``solution`` is finite and ``residual(solution)`` is within the tolerance."""
    value = np.asarray(residual(solution), dtype=float).ravel()
    scale = 1.0 + float(np.max(np.abs(solution))) if len(solution) else 1.0
    return bool(np.all(np.isfinite(solution)) and np.all(np.isfinite(value))
                and np.max(np.abs(value), initial=0.0) <= _TOLERANCE * scale)


def continued_guess(k, unknowns, written, context, context_value, guess):
    """The loop's starting point continued from the solution of its simplified model (each homotopy() at its
    simplified argument, HOMOTOPY = 0) to the actual one (HOMOTOPY = 1) in HOMOTOPY_STEPS steps at the model's
    start point, as Modelica tools initialise: of a loop with several solutions, the one the model's author
    chose (the MSL's op-amp multivibrator starts at its lower limit). ``guess`` (the start values) where the
    loop has no homotopy() (``written`` None) or a step does not converge."""
    extended = ca.vertcat(context, HOMOTOPY)
    if written is None or not symbol_names(written) <= symbol_names(ca.vertcat(extended, unknowns)):
        return guess  # none, or one that reads an unknown the run-time model solves in another block
    solver = newton(f"{k}_homotopy", unknowns, written, extended, damped=True)
    residual = ca.Function("loop_residual", [unknowns, extended], [written])
    point = guess
    for homotopy in np.linspace(0.0, 1.0, HOMOTOPY_STEPS + 1):
        at = np.append(context_value, homotopy)
        point = np.asarray(solver(point, np.tile(at[:, None], (1, NEWTON_ITERATIONS))), dtype=float).ravel()
        if not _converged(lambda v: np.asarray(residual(v, at), dtype=float).ravel(), point):  # noqa: B023
            return guess
    return point


def better_guess(solver, unknowns, residual, context, context_value, guess, name):
    """The guess the generated Newton iterations should start from, and a note when it is not ``guess``.

    Parameters
    ----------
    solver : casadi.Function
        The generated iterations: (guess, context repeated NEWTON_ITERATIONS times) -> unknowns.
    unknowns, residual, context : casadi.SX
        The loop: ``0 = residual(unknowns, context)``.
    context_value : numpy.ndarray
        The context at the model's start point.
    guess : numpy.ndarray
        The unknowns' start values.
    name : str
        The loop in words (its unknowns and equations' lines), for the warning.

    Returns
    -------
    (numpy.ndarray, str or None, numpy.ndarray)
        The guess, the note, and what the generated iterations give from that guess at the start point.
    """
    f = ca.Function("loop_residual", [unknowns, context], [residual])
    at_start = lambda v: np.asarray(f(v, context_value), dtype=float).ravel()  # noqa: E731
    iterate = lambda g: np.asarray(solver(g, np.tile(context_value[:, None], (1, NEWTON_ITERATIONS))),  # noqa: E731
                                   dtype=float).ravel()
    newton = iterate(guess)
    if _converged(at_start, newton):
        return guess, None, newton
    found = _least_squares(at_start, guess)
    if found is None:
        warnings.warn(LoopWarning(
            f"the {name} has no solution Newton's method or Levenberg-Marquardt finds at the model's start point "
            "(initial states, default parameters, inputs at their start, t = 0): its iterations start from the start "
            "values, and the FMU reports an error wherever they do not converge"), stacklevel=2)
        return guess, None, newton
    names = ", ".join(u.name() for u in ca.vertsplit(unknowns))
    return found, (f"Newton's method does not converge from the start values of {names} at the start point: "
                   "its iterations start from the loop's solution there (found by Levenberg-Marquardt)"), iterate(found)


def _least_squares(residual, guess):
    """The loop's solution by Levenberg-Marquardt from ``guess``, or, where the loop is undefined there (a
    thermal voltage k T/q guessed 0 divides), from the guess with its zeros replaced by 1, then by 1e-3; None
    when none converges."""
    for zeros in (None, 1.0, 1e-3):
        start = guess if zeros is None else np.where(guess == 0.0, zeros, guess)
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # a trial point where the loop is undefined (NaN)
            if not np.all(np.isfinite(residual(start))):
                continue
            try:
                found = least_squares(residual, start, method="lm", xtol=1e-15, ftol=1e-15, gtol=1e-15).x
            except (ValueError, np.linalg.LinAlgError):
                continue
            if _converged(residual, found):
                return found
    return None
