"""The lowered model: the public, explicit form of a Modelica model that the FMU, calibration and diagnosis share."""

from dataclasses import dataclass, field

import numpy as np

__all__ = ["ModelVariable", "DiscreteVariable", "EventPart", "Carried", "LoweredModel"]


@dataclass(frozen=True)
class ModelVariable:
    """A variable of the lowered model.

    Attributes
    ----------
    name : str
        Flat Modelica name.
    unit : str
        Modelica unit string ('' when undeclared).
    description : str
        The declaration's description string.
    start : float
        Start value (parameters: the default; states: the initial value at default parameters).
    kind : str
        ``real``, or for an input: ``integer``, ``boolean`` or ``enumeration`` (its value passed as a float).
    min, max : float or None
        A parameter's physical range as declared (``min``/``max`` attributes; None: unbounded on that side).
    nominal : float or None
        A state's magnitude as declared (``nominal``; None: not declared): the importer's solver scales its
        absolute tolerance by it (a state of 1e-4 rad/s integrated with an absolute error of 1e-8 is wrong by 1e-4).
    """

    name: str
    unit: str = ""
    description: str = ""
    start: float = 0.0
    kind: str = "real"
    min: float = None
    max: float = None
    nominal: float = None


@dataclass(frozen=True)
class DiscreteVariable:
    """A discrete variable of a hybrid model: it changes only at events and holds its value between them.

    Attributes
    ----------
    name : str
        Flat Modelica name.
    kind : str
        ``real``, ``integer``, ``boolean`` or ``enumeration`` (stored as its 1-based ordinal).
    unit, description : str
    start : float
        The value before the first event (``pre()`` at initialisation).
    causality : str
        ``output`` or ``local``.
    """

    name: str
    kind: str
    unit: str = ""
    description: str = ""
    start: float = 0.0
    causality: str = "local"


@dataclass(frozen=True)
class EventPart:
    """The discrete side of a hybrid model, as CasADi functions an FMU's C code and the master can call.

    ``m`` is the event memory, a float vector of length ``n_memory``: the discrete variables first (in
    ``discretes`` order; Integer and Boolean as whole numbers), then whatever else the events need (the held
    value of each relation, the next instant of each ``sample``...). Between events ``m`` is constant; the
    continuous functions of the :class:`LoweredModel` take it as a fifth argument.

    Attributes
    ----------
    discretes : tuple of DiscreteVariable
    n_memory : int
    n_indicators : int
        Number of event indicators (state events).
    indicators : casadi.Function
        ``indicators(x, u, p, t, m) -> z`` (n_indicators,): an event happens where a component changes sign.
    update : casadi.Function
        ``update(x, u, p, t, m_pre) -> (x_new, m_new, status)``: one pass of event iteration at time ``t``:
        relations re-evaluated from the actual values, ``when`` clauses that became active fire, ``reinit``
        applied. The importer repeats it with ``m_pre = m_new`` until ``m_new == m_pre``. ``status`` is 0, or 1
        when ``terminate()`` fired, or ``2 + k`` when assertion ``k`` failed (``messages[k]``).
    initial : casadi.Function
        ``initial(x, u, p, t) -> m``: the memory at initialisation (start values; ``initial()`` is true).
    next_time : casadi.Function
        ``next_time(t, p, m) -> t_next``: the next time event strictly after ``t``, or ``inf`` when none.
    messages : tuple of str
        ``"file:line: message"`` of each assertion (index ``k`` of status ``2 + k``); the last entry is the
        message of ``terminate()`` when the model has one.
    terminal : casadi.Function or None
        Like ``update``, with ``terminal()`` true: the passes an importer runs when the simulation ends
        (``fmi3Terminate``), repeated like ``update`` until ``m`` settles. None when the model does not use
        ``terminal()``.
    mixed : casadi.Function or None
        ``mixed(x, u, p, t, m_pre, c) -> (x_new, m_new, status, m_fresh)``: the pass of ``update`` with the
        relations and steps (rows ``candidates`` of ``m``) at the values of ``c`` instead of those they take;
        ``m_fresh`` is ``m_new`` with the values they take there. ``m_fresh == m_new``: the pass's mixed system
        (discrete variables and the continuous unknowns they decide) is solved. None without relations or steps.
    candidates : tuple of int
        The rows of ``m`` that ``mixed`` takes from ``c``.
    """

    discretes: tuple
    n_memory: int
    n_indicators: int
    indicators: object
    update: object
    initial: object
    next_time: object
    messages: tuple = ()
    terminal: object = None
    mixed: object = None
    candidates: tuple = ()


@dataclass(frozen=True)
class Carried:
    """A model's functions with the starting point of its nonlinear loops' Newton iterations an argument: every
    Modelica tool solves a loop from its last solution, so that a loop with several solutions (a Schmitt
    trigger's hysteresis) stays on the branch it is on. The FMU keeps that point in its state.

    ``ode``, ``out`` and ``observe`` are f(x, u, p, t[, m], g) -> (value, g_new), g_new the loops' solutions
    there (NaN in a loop that did not converge); ``loops(x, u, p, t[, m], g)`` as ``LoweredModel.loops``;
    ``guess`` the starting point at instantiation (the loops' start values), whose concatenated unknowns g is.
    """

    ode: object
    out: object
    observe: object
    loops: object
    guess: object


@dataclass(frozen=True)
class LoweredModel:
    """An explicit ODE ``der(x) = f(x, u, p, t)`` with outputs ``y = h(x, u, p, t)``.

    Attributes
    ----------
    name : str
        Full Modelica model name.
    states, inputs, outputs, parameters : tuple of ModelVariable
        In the order of the function arguments and results. ``parameters`` are the tunable ones; parameters
        bound to other parameters are substituted and so follow them.
    ode : casadi.Function
        ``ode(x, u, p, t) -> xdot``.
    out : casadi.Function
        ``out(x, u, p, t) -> y``.
    observe : casadi.Function
        ``observe(x, u, p, t) -> v``: every other continuous variable, named in ``observed``.
    observed : tuple of ModelVariable
        The variables ``observe`` returns, in order.
    x0 : casadi.Function
        ``x0(p) -> x`` initial states from start values and initial equations.
    constants : dict
        Integer and non-tunable parameters, evaluated at build time (name -> value).
    constant_variables : tuple of ModelVariable
        The same constants with their units, descriptions and kinds (``start`` is the value).
    dependent : tuple of ModelVariable
        Parameters bound to other parameters (substituted into the equations); ``start`` is the value at the
        default parameters.
    calculate : casadi.Function or None
        ``calculate(p) -> q``: the dependent parameters' values from the tunable ones, in ``dependent`` order.
    notes : tuple of str
        What the lowering did that a user may want to know (demoted states, nonlinear blocks, frozen starts).
    events : EventPart or None
        ``None`` for a continuous model. For a hybrid model, ``ode``, ``out`` and ``observe`` take the event
        memory ``m`` as a fifth argument: ``ode(x, u, p, t, m)``.
    loops : casadi.Function or None
        ``loops(x, u, p, t[, m])``: 1 per nonlinear algebraic loop whose Newton iterations converged there, 0
        per loop that did not (``ode``, ``out`` and ``observe`` then give NaN where they depend on it); None
        when the model has no such loop.
    loop_names : tuple of str
        The loops, in ``loops`` order: their unknowns and equations' lines.
    carried : Carried or None
        The same functions with the Newton iterations' starting point an argument, for the FMU, which starts each
        solve from the last solution (None when the model has no such loop).
    experiment : dict
        The model's ``experiment`` annotation (``StartTime``, ``StopTime``, ``Interval``, ``Tolerance``, those
        it gives), the FMU's DefaultExperiment.
    """

    name: str
    states: tuple
    inputs: tuple
    outputs: tuple
    parameters: tuple
    ode: object
    out: object
    observe: object
    observed: tuple
    x0: object
    constants: dict = field(default_factory=dict)
    notes: tuple = ()
    events: EventPart = None
    dependent: tuple = ()
    calculate: object = None
    constant_variables: tuple = ()
    loops: object = None
    loop_names: tuple = ()
    carried: object = None
    experiment: dict = field(default_factory=dict)

    @property
    def parameter_values(self):
        """Default values of the tunable parameters, as an array in ``parameters`` order."""
        return np.array([p.start for p in self.parameters], dtype=float)

    def initial_state(self, p=None):
        """Initial state vector for parameter values ``p`` (default: the model's defaults)."""
        p = self.parameter_values if p is None else np.asarray(p, dtype=float)
        return np.array(self.x0(p), dtype=float).ravel()

    def _arguments(self, x, u, p, t, m):
        """(x, u, p, t[, m]) for the model's functions; a hybrid model's memory defaults to its initial one."""
        p = self.parameter_values if p is None else p
        if self.events is None:
            return (x, u, p, t)
        return (x, u, p, t, self.events.initial(x, u, p, t) if m is None else m)

    def derivatives(self, x, u, p=None, t=0.0, m=None):
        """Evaluate ``der(x)`` numerically; arrays in, array out. ``m``: a hybrid model's event memory
        (default: its value at initialisation for these x, u, p, t)."""
        return np.array(self.ode(*self._arguments(x, u, p, t, m)), dtype=float).ravel()

    def output_values(self, x, u, p=None, t=0.0, m=None):
        """Evaluate the outputs numerically; arrays in, array out (``m`` as in :meth:`derivatives`)."""
        return np.array(self.out(*self._arguments(x, u, p, t, m)), dtype=float).ravel()

    def index(self, group, name):
        """Position of variable ``name`` in ``group`` ('states', 'inputs', 'outputs', 'parameters', 'observed')."""
        names = [v.name for v in getattr(self, group)]
        try:
            return names.index(name)
        except ValueError:
            raise KeyError(f"{self.name} has no {group[:-1]} named {name!r}; it has {', '.join(names)}") from None

    def linearization(self, input, output):
        """The SISO linearisation ``input`` -> ``output`` at the rest point (x0(p), u = 0), as a function of the
        tunable parameters: returns ``f(p) -> (A, B, C, D)`` (numpy, shapes (n, n), (n, 1), (1, n), (1, 1)).

        The Jacobians are CasADi's exact derivatives of the lowered equations, built once. A hybrid model is
        linearised with its discrete state held at its value at initialisation."""
        import casadi as ca

        i, j = self.index("inputs", input), self.index("outputs", output)
        x = ca.SX.sym("x", len(self.states))
        u = ca.SX.sym("u", len(self.inputs))
        p = ca.SX.sym("p", len(self.parameters))
        args = self._arguments(x, u, p, 0.0, None)
        xdot, y = self.ode(*args), self.out(*args)
        jac = ca.Function("abcd", [x, u, p], [ca.jacobian(xdot, x), ca.jacobian(xdot, u)[:, i],
                                              ca.jacobian(y, x)[j, :], ca.jacobian(y, u)[j, i]])
        rest = np.zeros(len(self.inputs))

        def abcd(values):
            values = np.asarray(values, dtype=float)
            return tuple(np.array(m, dtype=float) for m in jac(self.initial_state(values), rest, values))

        return abcd
