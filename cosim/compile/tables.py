"""The MSL's table blocks lowered natively: ``Modelica.Blocks.Sources.CombiTimeTable`` and
``Modelica.Blocks.Tables.CombiTable1Ds``/``CombiTable1Dv`` (and through them ``BooleanTable`` and
``IntegerTable``), whose MSL 4.1.0 implementation calls the external C functions of ModelicaStandardTables
(``Modelica/Resources/C-Sources/ModelicaStandardTables.c``). CasADi cannot call an arbitrary C function from
its generated code, so each call becomes a CasADi expression with the semantics of that C source:

- ``ModelicaStandardTables_CombiTimeTable_getValue`` (``getTimeTableValue``, ``...NoDer``, ``...NoDer2``):
  before ``startTime`` 0; with one row that row; outside ``[t_min, t_max)`` (time minus ``shiftTime``) the
  extrapolation: ``HoldLastPoint`` the first/last row, ``LastTwoPoints`` the line through the first/last two
  rows (also for constant segments; the later row where their times are equal), ``Periodic`` the table
  repeated with period ``t_max - t_min``, ``NoExtrapolation`` an error (an assertion that fails at the event
  where time leaves the table); inside it ``LinearSegments`` interpolates linearly, ``ConstantSegments`` holds
  the row at or before the time; two rows with the same time are a jump (the later row holds from that time on).
- ``..._CombiTimeTable_nextTimeEvent`` (``getNextTimeEvent``): the next time event strictly after the time: the
  start time, then the table's first time, the breakpoints (``timeEvents``: ``Always`` every distinct time,
  ``AtDiscontinuities`` the repeated ones, ``NoTimeEvents`` none; constant segments always ``Always``), its last
  time (with ``Periodic`` the end of every period), shifted by ``shiftTime``; ``inf`` when none is left.
  The MSL block holds that instant in ``nextTimeEvent`` and fires ``when time >= pre(nextTimeEvent)``: a time
  event of the event machinery (``cosim.compile.events``).
- Which segment the value is interpolated on is chosen from that held next event, not from time alone, as the
  C code does with its event interval: between events the segment that ends at the next event (so the value at
  an event instant is the left limit until the event is handled, the right limit after; a time rounded below a
  breakpoint does not pick the previous segment).
- ``..._CombiTable1D_getValue`` (``getTable1DValue``, ``...NoDer``, ``...NoDer2``): the same interpolation of
  ``u`` without events (``u_min <= u <= u_max`` inside the table; ``Periodic`` maps ``u`` into it).
- ``getTimeTableTmin``/``Tmax``, ``getTable1DAbscissaUmin``/``Umax``: the first and last abscissa.

rumoca 0.10.2 evaluates the table objects' constructors at build time: a table object parameter (``tableID``)
is bound to an integer handle, and ``ir["external_tables"]`` holds each handle's data, columns, smoothness and
extrapolation. The constructor's other arguments (``startTime``, ``shiftTime``, ``timeScale``, ``timeEvents``,
``tableOnFile``) are read from the parameters of the MSL block the handle belongs to (the ``tableID``'s
prefix), as the MSL 4.1.0 blocks pass them. The table's data is a constant of the FMU: the parameters it is
computed from are made structural (not tunable), since the lowered expressions hold its numbers.
Not lowered (rejected with the file and line): tables read from a file or a ``usertab`` function, cubic Hermite
splines (``ContinuousDerivative``, ``MonotoneContinuousDerivative1``/``2``, ``ModifiedContinuousDerivative``),
and any other external function.
"""

from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from cosim.compile.events import Relation
from cosim.errors import ModelicaError, UnsupportedConstructError

__all__ = ["Registry", "TableData", "call", "event_points", "time_table_value", "next_time_event", "table_1d_value"]

LINEAR, CONSTANT = 1, 3
HOLD, LAST_TWO, PERIODIC, NO_EXTRAPOLATION = 1, 2, 3, 4
ALWAYS, AT_DISCONTINUITIES, NO_TIME_EVENTS = 1, 2, 3
_SMOOTHNESS = {1: "LinearSegments", 2: "ContinuousDerivative", 3: "ConstantSegments",
               4: "MonotoneContinuousDerivative1", 5: "MonotoneContinuousDerivative2",
               6: "ModifiedContinuousDerivative"}
_EPSILON = 1e-10  # ModelicaStandardTables.c: _EPSILON, its relative tolerance for equal abscissa values
_TIME_FUNCTIONS = ("getTimeTableValue", "getTimeTableValueNoDer", "getTimeTableValueNoDer2")
_1D_FUNCTIONS = ("getTable1DValue", "getTable1DValueNoDer", "getTable1DValueNoDer2")
_PREFIX = "Modelica.Blocks.Tables.Internal."


@dataclass
class Registry:
    """The table objects of one translation: built once each, by the name of their tableID parameter."""

    tables: dict = field(default_factory=dict)     # tableID name -> TableData
    frozen: set = field(default_factory=set)       # parameters the tables' data is computed from (structural)
    asserted: set = field(default_factory=set)     # time tables whose NoExtrapolation assertion exists
    index: dict = None                             # flat variable name -> index in the IR


@dataclass
class TableData:
    """One table object: its rows and how they are interpolated (time tables: also when, in scaled time)."""

    name: str            # the MSL block's instance name (the prefix of its tableID)
    rows: np.ndarray     # the table matrix, first column the abscissa
    columns: list        # 1-based columns of the outputs
    smoothness: int
    extrapolation: int
    location: str        # where the table's data is written (file:line)
    time_events: int = ALWAYS
    start: object = None  # startTime/timeScale (SX: a parameter expression)
    shift: object = None  # shiftTime/timeScale


def _nearly_equal(x, y):
    """ModelicaStandardTables.c isNearlyEqual."""
    cmp = max(abs(x), abs(y), _EPSILON) * _EPSILON
    return abs(y - x) < cmp


def event_points(times, time_events):
    """The abscissa values with time events (ModelicaStandardTables_CombiTimeTable_nextTimeEvent): the first,
    the interior breakpoints ``time_events`` asks for, the last. A single point when all times are equal."""
    t0, t_max = float(times[0]), float(times[-1])
    points, last = [t0], t0
    if time_events in (ALWAYS, AT_DISCONTINUITIES):
        for a, b in zip(times[:-1], times[1:]):
            if b > last and not _nearly_equal(b, t_max):
                if (time_events == ALWAYS) != _nearly_equal(a, b):
                    points.append(float(b))
                    last = b
    if not _nearly_equal(t_max, t0):
        points.append(t_max)
    return points


def _segment_rows(times, lo, hi):
    """Rows (i_lo, i_hi) whose intervals lie between the event points lo and hi: i_lo the last row at or before
    lo, i_hi the last row strictly before hi (both at most n - 2)."""
    n = len(times)
    i_lo = max((i for i in range(n - 1) if times[i] <= lo or _nearly_equal(times[i], lo)), default=0)
    i_hi = max((i for i in range(n - 1) if times[i] < hi and not _nearly_equal(times[i], hi)), default=i_lo)
    return i_lo, max(i_lo, i_hi)


def _line(times, y, i, x, equal_value):
    """Linear interpolation on rows i, i+1 at x; ``equal_value`` when their abscissas are nearly equal."""
    t0, t1 = float(times[i]), float(times[i + 1])
    if _nearly_equal(t0, t1):
        return ca.SX(float(equal_value))
    return float(y[i]) + (float(y[i + 1]) - float(y[i])) * (x - t0) / (t1 - t0)


def _inside(times, y, smoothness, x, i_lo, i_hi):
    """The interpolated value at x on the rows i_lo..i_hi + 1 (the interval of x: the last row at or before it,
    clamped to i_lo..i_hi)."""
    if smoothness == CONSTANT:
        value = ca.SX(float(y[i_lo]))
        for i in range(i_lo + 1, i_hi + 1):
            value = ca.if_else(x >= float(times[i]), float(y[i]), value)
        return value
    value = _line(times, y, i_lo, x, y[i_lo + 1])
    for i in range(i_lo + 1, i_hi + 1):
        value = ca.if_else(x >= float(times[i]), _line(times, y, i, x, y[i + 1]), value)
    return value


def _outside(table, y, x, right):
    """Extrapolation left or right of the table (HoldLastPoint, LastTwoPoints; NoExtrapolation holds too, its
    error is an assertion)."""
    times = table.rows[:, 0]
    if table.extrapolation == LAST_TWO:
        i = len(times) - 2 if right else 0
        return _line(times, y, i, x, y[i + 1] if right else y[i])
    return ca.SX(float(y[-1] if right else y[0]))


def _tolerance(table, tau):
    """A time within this of an event instant has reached it (the importer's rounding of the instant)."""
    span = float(table.rows[-1, 0] - table.rows[0, 0])
    return _EPSILON * ca.fmax(ca.fabs(tau), span if span > 0 else 1.0)


def next_time_event(table, tau):
    """ModelicaStandardTables_CombiTimeTable_nextTimeEvent at the scaled time ``tau``: the first event instant
    strictly after it (within the tolerance), inf when none is left."""
    tol = _tolerance(table, tau)
    times = table.rows[:, 0]
    u = tau - table.shift
    best = ca.SX(ca.inf)
    if len(times) > 1:
        points = event_points(times, table.time_events)
        if table.extrapolation == PERIODIC:
            period = points[-1] - points[0]
            m = ca.floor((u - points[0]) / period)
            candidates = [p + m * period for p in points[1:]] + [points[1] + (m + 1) * period]
        else:
            candidates = [ca.SX(p) for p in points]
        for c in candidates:
            best = ca.fmin(best, ca.if_else(c > u + tol, c, ca.inf))
        best = best + table.shift
    return ca.if_else(tau + tol < table.start, table.start, best)


def _regions(table, y, u, u_event):
    """The value on the event interval that ends at the table abscissa ``u_event`` (non-periodic): left of the
    table, one interval per pair of event points, right of it (after the last event, ``u_event`` = inf)."""
    times = table.rows[:, 0]
    points = event_points(times, table.time_events)
    value = _outside(table, y, u, right=False)
    for k in range(1, len(points)):
        i_lo, i_hi = _segment_rows(times, points[k - 1], points[k])
        threshold = (points[k - 1] + points[k]) / 2
        value = ca.if_else(u_event > threshold, _inside(times, y, table.smoothness, u, i_lo, i_hi), value)
    beyond = points[-1] + max(points[-1] - points[0], 1.0)
    return ca.if_else(u_event > beyond, _outside(table, y, u, right=True), value)


def _periodic(table, y, u, u_event):
    """The value on the event interval that ends at ``u_event``, the table repeated with its period: the period
    is the one holding that interval (found from ``u_event`` with half the shortest interval as margin)."""
    times = table.rows[:, 0]
    points = event_points(times, table.time_events)
    period = points[-1] - points[0]
    margin = min(b - a for a, b in zip(points[:-1], points[1:])) / 2
    m = ca.floor((u_event - points[0] - margin) / period)
    u_local, event_local = u - m * period, u_event - m * period
    value = None
    for k in range(1, len(points)):
        i_lo, i_hi = _segment_rows(times, points[k - 1], points[k])
        here = _inside(times, y, table.smoothness, u_local, i_lo, i_hi)
        value = here if value is None else ca.if_else(event_local > (points[k - 1] + points[k]) / 2, here, value)
    return value


def time_table_value(table, icol, tau, next_event):
    """ModelicaStandardTables_CombiTimeTable_getValue: output ``icol`` (1-based) at the scaled time ``tau``
    with the held next event instant ``next_event`` (scaled)."""
    y = table.rows[:, table.columns[icol - 1] - 1]
    if len(y) == 1:
        value = ca.SX(float(y[0]))
    else:
        u, u_event = tau - table.shift, next_event - table.shift
        value = (_periodic if table.extrapolation == PERIODIC else _regions)(table, y, u, u_event)
    return ca.if_else(next_event <= table.start, 0, value)


def time_table_outside(table, next_event):
    """True while a non-periodic time table extrapolates (the held next event is its first time, or none is
    left), after its start time: the failure of NoExtrapolation."""
    points = event_points(table.rows[:, 0], table.time_events)
    u_event = next_event - table.shift
    left = u_event < (points[0] + points[1]) / 2 if len(points) > 1 else u_event < points[0] + 1.0
    right = u_event > points[-1] + max(points[-1] - points[0], 1.0)
    return ca.logic_and(next_event > table.start, ca.logic_or(left, right))


def table_1d_value(table, icol, u):
    """ModelicaStandardTables_CombiTable1D_getValue: output ``icol`` (1-based) at the abscissa ``u``."""
    times = table.rows[:, 0]
    y = table.rows[:, table.columns[icol - 1] - 1]
    n = len(times)
    if n == 1:
        return ca.SX(float(y[0]))
    u_min, u_max = float(times[0]), float(times[-1])
    if table.extrapolation == PERIODIC:
        period = u_max - u_min
        u = ca.if_else(u < u_min, u + period * ca.ceil((u_min - u) / period),
                       ca.if_else(u > u_max, u - period * ca.ceil((u - u_max) / period), u))
    if table.smoothness == CONSTANT:
        inside = _inside(times, y, CONSTANT, u, 0, n - 1)
    else:
        inside = _inside(times, y, LINEAR, u, 0, n - 2)
    if table.extrapolation == PERIODIC:
        return inside
    left = _line(times, y, 0, u, y[0]) if table.extrapolation == LAST_TWO else ca.SX(float(y[0]))
    right = _line(times, y, n - 2, u, y[-1]) if table.extrapolation == LAST_TWO else ca.SX(float(y[-1]))
    return ca.if_else(u < u_min, left, ca.if_else(u > u_max, right, inside))


# -- the calls of rumoca's IR -----------------------------------------------------------------------------------
def call(tr, function, args, location):
    """The outputs of a call of the external function ``function`` (an IR function table entry) with ``args``
    (SX); ``location`` is the call's file:line. A function that is not one of the tables' is rejected."""
    name = function["name"]
    short = name[len(_PREFIX):] if name.startswith(_PREFIX) else None
    kinds = {**{f: "time" for f in _TIME_FUNCTIONS + ("getNextTimeEvent", "getTimeTableTmin", "getTimeTableTmax")},
             **{f: "1d" for f in _1D_FUNCTIONS + ("getTable1DAbscissaUmin", "getTable1DAbscissaUmax")}}
    if short not in kinds:
        _reject(tr, f"the external function {name}", location)
    table = _table(tr, args[0], kinds[short], location)
    if short in ("getTimeTableTmin", "getTable1DAbscissaUmin"):
        return [ca.SX(float(table.rows[0, 0]))]
    if short in ("getTimeTableTmax", "getTable1DAbscissaUmax"):
        return [ca.SX(float(table.rows[-1, 0]))]
    if short == "getNextTimeEvent":
        return [next_time_event(table, args[1])]
    icol = _column_index(tr, args[1], table, location)
    if kinds[short] == "time":
        _time_extrapolation_error(tr, table, args[3])
        return [time_table_value(table, icol, args[2], args[3])]
    _1d_extrapolation_error(tr, table, args[2])
    return [table_1d_value(table, icol, args[2])]


def _reject(tr, what, location):
    raise UnsupportedConstructError(f"{what} is not supported (see docs/compiler.md)", *tr._file_line(location))


def _invalid(tr, what, location):
    raise ModelicaError(what, *tr._file_line(location))


def _column_index(tr, value, table, location):
    if not value.is_constant():
        _reject(tr, f"a table output index that is not known at build time in {table.name}", location)
    icol = int(float(value))
    if not 1 <= icol <= len(table.columns):
        _invalid(tr, f"{table.name}: output {icol} of a table with {len(table.columns)} columns", location)
    return icol


def _variable(tr, name):
    """(index, IR entry) of the flat variable ``name``, or (None, None)."""
    registry = tr.tables
    if registry.index is None:
        registry.index = {v["name"]: i for i, v in enumerate(tr.storage["variables"])}
    i = registry.index.get(name)
    return (None, None) if i is None else (i, tr.storage["variables"][i])


def _where(tr, name, default):
    """Where the value of parameter ``name`` is written (its binding: a modifier in the user's model)."""
    i, v = _variable(tr, name)
    node = None if v is None else v["attributes"].get("binding")
    return tr.where(node) if node is not None else default


def _numeric(tr, value, what, location):
    """The number(s) of a parameter expression, its bindings substituted until none is left; and the names of
    the parameters it was computed from."""
    used = set()
    for _ in range(1000):
        free = ca.symvar(value)
        if not free:
            return np.array(ca.evalf(value)), used
        bindings = [tr._binding(s.name()) for s in free]
        for s, b in zip(free, bindings):
            if b is None:
                _reject(tr, f"{what} computed from {s.name()}, which has no value at build time,", location)
        used.update(s.name() for s in free)
        value = ca.substitute(value, ca.vertcat(*free), ca.vertcat(*bindings))
    _invalid(tr, f"{what}: its parameter bindings form a cycle", location)


def _parameter(tr, prefix, name, location):
    """The symbol of the MSL block's parameter ``prefix + name``."""
    i, _ = _variable(tr, prefix + name)
    if i is None:
        _reject(tr, f"a table object whose block has no parameter {name} (only the MSL 4.1.0 table blocks are "
                    f"lowered; {prefix}tableID)", location)
    return tr.syms[i]


def _table(tr, handle, kind, location):
    """The table a ``tableID`` parameter refers to (built once per table object)."""
    name = handle.name() if handle.is_symbolic() else ""
    if not name.endswith("tableID"):
        _reject(tr, "a table object that is not the tableID parameter of an MSL table block", location)
    if name in tr.tables.tables:
        return tr.tables.tables[name]
    prefix = name[:-len("tableID")]
    block = prefix.rstrip(".") or "the model"
    handle_value = tr._binding(name)
    entries = {e["id"]: e for e in tr.flat.ir.get("external_tables", [])}
    if handle_value is None or not handle_value.is_constant() or int(float(handle_value)) not in entries:
        _reject(tr, f"the table object of {block} (rumoca 0.10.2 gave no table data for it)", location)
    entry = entries[int(float(handle_value))]
    if _variable(tr, prefix + "tableOnFile")[0] is None:  # not a table block's: the MSL's Clutch, LossyGear...
        table = tr.tables.tables[name] = _object_table(tr, entry, kind, prefix, block, location)
        return table
    data_at = _where(tr, prefix + "table", location)
    on_file, _ = _numeric(tr, _parameter(tr, prefix, "tableOnFile", location), f"{block}.tableOnFile", location)
    if on_file.item():
        _reject(tr, f"a table read from a file (tableOnFile = true in {block}; write the table into the model)",
                data_at)
    rows = np.array(entry["data"], dtype=float)
    if rows.ndim != 2 or rows.shape[0] < 1 or rows.shape[1] < 2:
        _invalid(tr, f"the table of {block} is empty or has fewer than two columns (shape {rows.shape})", data_at)
    table = TableData(block, rows, [int(c) for c in entry["columns"]], int(entry["smoothness"]),
                      int(entry["extrapolation"]), data_at)
    _check_data(tr, table, _parameter(tr, prefix, "table", location), kind, prefix, location)
    if kind == "time":
        scale = _parameter(tr, prefix, "timeScale", location)
        table.start = _parameter(tr, prefix, "startTime", location) / scale
        table.shift = _parameter(tr, prefix, "shiftTime", location) / scale
        events, _ = _numeric(tr, _parameter(tr, prefix, "timeEvents", location), f"{block}.timeEvents", location)
        table.time_events = {LINEAR: int(events.item()), CONSTANT: ALWAYS}[table.smoothness]
    tr.tables.tables[name] = table
    return table


def _object_table(tr, entry, kind, prefix, block, location):
    """The 1-D table object of a component that is not a table block (``mu_pos`` of the MSL's ``Clutch``,
    ``lossTable`` of ``LossyGear``): data, columns, smoothness and extrapolation as rumoca gives them. The data's
    parameter is the one of the component whose value is that data (it becomes structural)."""
    if kind != "1d":
        _reject(tr, f"a time table object of {block}, which is not a CombiTimeTable block", location)
    rows = np.array(entry["data"], dtype=float)
    sources = [v["name"] for i, v in enumerate(tr.storage["variables"]) if v["name"].startswith(prefix)
               and v["role"] == "parameter" and tr.syms[i].shape == rows.shape and _holds(tr, tr.syms[i], rows)]
    if len(sources) != 1:
        _reject(tr, f"the table object of {block}, whose data {len(sources)} of its parameters hold "
                    f"({', '.join(sources) or 'none'}; one is lowered)", location)
    table = TableData(block, rows, [int(c) for c in entry["columns"]], int(entry["smoothness"]),
                      int(entry["extrapolation"]), _where(tr, sources[0], location))
    _check_data(tr, table, tr.syms[_variable(tr, sources[0])[0]], kind, prefix, location)
    return table


def _holds(tr, symbol, rows):
    """Whether parameter expression ``symbol`` evaluates to ``rows`` at build time."""
    try:
        values, _ = _numeric(tr, symbol, "a parameter", None)
    except ModelicaError:
        return False
    return values.shape == rows.shape and np.array_equal(values, rows)


def _check_data(tr, table, symbol, kind, prefix, location):
    """The table's data against the MSL block's ``table`` parameter (the handle belongs to that block), the
    checks of ModelicaStandardTables.c (isValidCombiTimeTable, isValidCombiTable1D), the smoothness lowered;
    the parameters the data is computed from become structural."""
    what = f"the table of {table.name}"
    rows = table.rows
    if table.smoothness not in (LINEAR, CONSTANT):
        _reject(tr, f"smoothness = {_SMOOTHNESS.get(table.smoothness, table.smoothness)} in {table.name} (cubic "
                    "Hermite splines; LinearSegments and ConstantSegments are lowered)",
                _where(tr, prefix + "smoothness", location))
    values, used = _numeric(tr, symbol, what, table.location)
    if values.shape != rows.shape or not np.array_equal(values, rows):
        _reject(tr, f"{what}: rumoca's table object differs from the block's table parameter", table.location)
    tr.tables.frozen.update(used)
    for c in table.columns:
        if not 1 <= c <= rows.shape[1]:
            _invalid(tr, f"the column index {c} is out of range for {what} ({rows.shape[0]}x{rows.shape[1]})",
                     table.location)
    steps = np.diff(rows[:, 0])
    if kind == "1d" and np.any(steps <= 0):
        _invalid(tr, f"the values of the first column of {what} are not strictly increasing", table.location)
    if kind == "time" and np.any(steps < 0):
        _invalid(tr, f"the values of the first column of {what} are not monotonically increasing", table.location)
    if table.extrapolation == PERIODIC and len(rows) > 1 and not rows[-1, 0] > rows[0, 0]:
        _invalid(tr, f"{what} does not have a positive period for periodic extrapolation", table.location)


def _time_extrapolation_error(tr, table, next_event):
    """NoExtrapolation of a time table: an assertion that fails while it extrapolates (checked at events)."""
    if table.extrapolation != NO_EXTRAPOLATION or len(table.rows) == 1 or table.name in tr.tables.asserted:
        return
    tr.tables.asserted.add(table.name)
    tr.reader.system.asserts.append((time_table_outside(table, next_event), (
        f"{table.location}: Extrapolation error in {table.name}: time must be greater or equal than the shifted "
        "minimum abscissa value and less than the shifted maximum abscissa value defined in the table")))


def _1d_extrapolation_error(tr, table, u):
    """NoExtrapolation of a 1D table: an assertion on two relations of u (state events where u leaves it)."""
    if table.extrapolation != NO_EXTRAPOLATION or len(table.rows) == 1:
        return
    held = []
    for g, op in ((u - float(table.rows[0, 0]), "less"), (u - float(table.rows[-1, 0]), "greater")):
        k = len(tr.relations)
        tr.relations.append(Relation(ca.SX.sym(f"$rel{k}"), g, op, table.location))
        held.append(tr.relations[-1].sym)
    tr.reader.system.asserts.append((ca.logic_or(*held), (
        f"{table.location}: Extrapolation error in {table.name}: the value u must be within the minimum and "
        f"maximum abscissa values [{table.rows[0, 0]:g}, {table.rows[-1, 0]:g}] defined in the table")))
