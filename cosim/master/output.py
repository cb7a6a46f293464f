"""Write a run's results: Parquet (units and config in the file metadata), CSV, summary.json, PNG plots."""

import json
from pathlib import Path

import numpy as np

from cosim.master.plot import plot_results
from cosim.outputs import optional_file

__all__ = ["write_results", "write_csv", "plot_results", "read_results"]


def write_results(result, config, out_dir, csv=False, summary=None):
    """Write ``results.parquet`` (and ``results.csv``), ``summary.json`` and the plot into ``out_dir``, in this
    order: a plot that cannot be drawn (values matplotlib cannot scale, a figure too large) is an
    :class:`~cosim.errors.OutputWarning`, and the results stay written.

    Parameters
    ----------
    result : cosim.master.engine.RunResult
    config : cosim.config.Config
    out_dir : path-like
        Created if missing.
    csv : bool
        Also write ``results.csv``.
    summary : dict, optional
        Written to ``summary.json`` when given.

    Returns
    -------
    list of pathlib.Path
        The files written (without the plot when it could not be drawn).
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    names = result.data.dtype.names
    types = {n: pa.from_numpy_dtype(result.data.dtype[n]) for n in names}
    fields = [pa.field(n, types[n], metadata={"unit": result.units.get(n, "")}) for n in names]
    meta = {
        "cosim.units": json.dumps({n: result.units.get(n, "") for n in names}),
        "cosim.config": json.dumps(config.raw, default=str),
        "cosim.config_path": str(config.path),
        "cosim.overrides": json.dumps(list(config.overrides)),
        "cosim.signals": json.dumps({k: list(v) for k, v in result.signals.items()}),
        "cosim.interrupted": json.dumps(result.interrupted),
        "cosim.stopped": json.dumps(result.stopped),
    }
    from cosim import __version__

    meta["cosim.version"] = __version__
    schema = pa.schema(fields, metadata=meta)
    columns = [_arrow_column(pa, types[n], result.data[n]) for n in names]
    table = pa.Table.from_arrays(columns, schema=schema)
    files = []
    p = out / "results.parquet"
    pq.write_table(table, p)
    files.append(p)
    if csv:
        files.append(write_csv(result, out / "results.csv"))
    if summary is not None:
        p = out / "summary.json"
        p.write_text(json.dumps(summary, indent=2, sort_keys=False) + "\n")
        files.append(p)
    if len(result.data) > 1:
        plot = optional_file(out / config.plot.file, lambda p: plot_results(result, p, panels=config.plot.panels,
                                                                             config=config, summary=summary))
        files += [plot] if plot is not None else []
    return files


def write_csv(result, path):
    """Write a run's recorded columns to ``path`` as CSV: one header line of ``name [unit]`` (the bare name when
    the variable declares no unit), then one row an instant; reals with 10 significant digits, integers and
    Booleans (0/1) exact.

    Parameters
    ----------
    result : cosim.master.engine.RunResult
    path : path-like

    Returns
    -------
    pathlib.Path
    """
    names = result.data.dtype.names
    header = ",".join(f"{n} [{result.units.get(n, '')}]" if result.units.get(n) else n for n in names)
    arr = (np.column_stack([result.data[n].astype(np.float64) for n in names]) if len(result.data)
           else np.zeros((0, len(names))))
    fmt = ["%.10g" if result.data.dtype[n].kind == "f" else "%d" for n in names]
    np.savetxt(path, arr, delimiter=",", header=header, comments="", fmt=fmt)
    return Path(path)


def _arrow_column(pa, atype, column):
    """An Arrow array over a numpy column (pa.array would import pandas, a second of start-up, to check its type):
    fixed-width columns wrap the numpy buffer, Booleans are packed into Arrow's bitmap."""
    column = np.ascontiguousarray(column)
    data = np.packbits(column, bitorder="little") if column.dtype == np.bool_ else column
    return pa.Array.from_buffers(atype, len(column), [None, pa.py_buffer(data)])


def read_results(path):
    """Read ``results.parquet`` back, as :func:`write_results` wrote it.

    Parameters
    ----------
    path : path-like
        The Parquet file.

    Returns
    -------
    data : numpy.ndarray
        Structured array, ``time`` first, one field per recorded column in its recorded dtype.
    units : dict
        Column name -> unit string.
    meta : dict
        The file's metadata (str -> str).
    """
    import pyarrow.parquet as pq

    table = pq.read_table(path)
    meta = {k.decode(): v.decode() for k, v in (table.schema.metadata or {}).items()}
    units = json.loads(meta.get("cosim.units", "{}"))
    names = table.column_names
    data = np.zeros(table.num_rows, dtype=[(n, table.schema.field(n).type.to_pandas_dtype()) for n in names])
    for n in names:
        data[n] = table.column(n).to_numpy()
    return data, units, meta
