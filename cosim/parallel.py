"""Parallel map on a Dask cluster (a local one by default, an existing scheduler when given its address), with a
progress bar: the multi-start calibration and the diagnosis's candidate fits.

A local cluster listens on 127.0.0.1 only (scheduler and workers) and has no dashboard: its HTTP server has no
login, so it must not answer on the machine's network address. Its workers' temporary folder (``TMPDIR``: the
FMUs they unpack, Dask's scratch space) is one folder removed when the cluster is closed, so nothing a worker
left, even one killed by Ctrl-C, outlives the command. Its workers ignore Ctrl-C (the terminal sends it to every
process of the command): the command stops them itself, without a traceback from each.
"""

import contextlib
import functools
import logging
import os
import shutil
import signal
import sys
import tempfile

from tqdm import tqdm

from cosim.errors import ConfigError

__all__ = ["open_client", "keep_local_cluster", "check_scheduler", "map_on_dask", "map_here"]

LOOPBACK = "127.0.0.1"


@contextlib.contextmanager
def open_client(scheduler="", max_workers=None, timeout_s=5.0):
    """A Dask client: on a local cluster bound to 127.0.0.1, or on the scheduler at ``scheduler``.

    Parameters
    ----------
    scheduler : str, default ""
        Address of an existing Dask scheduler (``tcp://host:port``); empty: a local cluster of processes, one
        worker a core (at most ``max_workers``), one thread each, no dashboard, closed on exit.
    max_workers : int, optional
        Most workers of the local cluster.
    timeout_s : float, default 5.0
        How long to wait for the scheduler at ``scheduler`` to answer (s).

    Yields
    ------
    distributed.Client

    Raises
    ------
    ConfigError
        The scheduler at ``scheduler`` does not answer within ``timeout_s``, or the address is malformed.
    """
    from distributed import Client, LocalCluster

    if scheduler:
        check_scheduler(scheduler, timeout_s)
        with Client(scheduler, timeout=timeout_s) as client:
            yield client
        return
    workers = max(1, min(max_workers or os.cpu_count() or 1, os.cpu_count() or 1))
    # CRITICAL: a worker's heartbeat racing the close logs a harmless CommClosedError traceback at ERROR
    # (dask/distributed#7105); a task's own error still reaches the caller through future.result()
    # the scheduler always serves a small HTTP page (health, JSON): on loopback, on a free port (not 8787, which a
    # second cluster would find taken), without the dashboard
    quiet_http = {"dashboard": False, "dashboard_address": f"{LOOPBACK}:0"}
    scratch = tempfile.mkdtemp(prefix="cosim-dask-")
    try:
        with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, host=LOOPBACK,
                          dashboard_address=None, worker_dashboard_address=None, scheduler_kwargs=quiet_http,
                          silence_logs=logging.CRITICAL, local_directory=scratch,
                          env={"TMPDIR": scratch}) as cluster, Client(cluster) as client:
            client.run(_ignore_ctrl_c)
            yield client
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def _ignore_ctrl_c():
    """Run in each local worker (in its main thread): ignore SIGINT. A Ctrl-C in the terminal reaches every
    process of the command, and the command, which closes the cluster, is the one to handle it."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


# The local cluster kept open by keep_local_cluster: its most workers, then (on first use) the client's context
_KEPT = {}


@contextlib.contextmanager
def keep_local_cluster(max_workers=None):
    """Inside the block, :func:`map_on_dask` without a scheduler runs on one local cluster, started at its first
    use and closed when the block ends: a workflow of several parallel maps (a diagnosis: screen, fold fits,
    restarts, final fit) starts its worker processes once, not once a map (2-5 s each on a 2-core machine), and
    what a worker keeps between tasks (lowered models) serves the later maps. A nested block uses the outer one's
    cluster.

    Parameters
    ----------
    max_workers : int, optional
        Most workers of the cluster (as :func:`open_client`).
    """
    if _KEPT:
        yield
        return
    _KEPT["max_workers"] = max_workers
    try:
        yield
    finally:
        context = _KEPT.pop("context", None)
        _KEPT.clear()
        if context is not None:
            context.__exit__(None, None, None)


@contextlib.contextmanager
def _client(scheduler, max_workers):
    """The kept local cluster's client (:func:`keep_local_cluster`), or a client of :func:`open_client`."""
    if scheduler or not _KEPT:
        with open_client(scheduler, max_workers=max_workers) as client:
            yield client
        return
    if "client" not in _KEPT:
        context = open_client("", max_workers=_KEPT["max_workers"])
        _KEPT["client"] = context.__enter__()
        _KEPT["context"] = context
    yield _KEPT["client"]


def check_scheduler(address, timeout_s=5.0):
    """Ask the Dask scheduler at ``address`` for its identity: a ConfigError naming the address when none answers.

    Done before a Client is made: a Client given a wrong address waits its whole timeout, and one given a port of
    another service fails deep inside its reader (even with a MemoryError).

    Parameters
    ----------
    address : str
        ``tcp://host:port``.
    timeout_s : float, default 5.0
        How long to wait for the answer (s).

    Raises
    ------
    ConfigError
        No Dask scheduler answered at ``address`` within ``timeout_s``, or the address is malformed.
    """
    import asyncio

    from distributed.comm import connect

    async def identity():
        comm = await connect(address, timeout=timeout_s)
        try:
            await comm.write({"op": "identity", "reply": True})
            return await comm.read()
        finally:
            comm.abort()

    try:
        reply = asyncio.run(asyncio.wait_for(identity(), timeout_s))
    except Exception as exc:  # any failure of the probe means: not a scheduler we can use
        reply = f"{type(exc).__name__}: {exc}"
    if not (isinstance(reply, dict) and reply.get("type") == "Scheduler"):
        raise ConfigError(f"scheduler: no Dask scheduler answered at {address!r} within {timeout_s:g} s "
                          f"(got {str(reply)[:200]}); expected the address of a running scheduler, "
                          f"e.g. tcp://127.0.0.1:8786, or an empty scheduler for a local cluster")


def map_on_dask(function, items, scheduler="", max_workers=None, desc="fits", progress=True, report=False):
    """``[function(item) for item in items]`` on a Dask cluster with a progress bar, results in item order.

    Parameters
    ----------
    function : callable
        Takes one item; it and the items must pickle (they cross processes).
    items : sequence
    scheduler : str, default ""
        Address of an existing Dask scheduler; empty: a local cluster of processes on 127.0.0.1 (one per item,
        at most ``max_workers`` and the number of cores), closed afterwards; inside :func:`keep_local_cluster`,
        that block's cluster.
    max_workers : int, optional
        Most workers of the local cluster.
    desc : str, default "fits"
        Label of the progress bar.
    progress : bool, default True
        Show the progress bar (on stderr).
    report : bool, default False
        Call ``function(item, report=sink)``: each line a task gives ``sink`` (a fit's iteration, cost and time
        left) shows beside the bar, after the item's number, until the task ends.

    Returns
    -------
    list
        ``function(item)`` for each item, in item order; a task's error is raised here.
    """
    from distributed import as_completed

    workers = max(1, min(len(items), max_workers or len(items)))
    topic = f"cosim-progress-{os.getpid()}-{id(items)}"
    with _client(scheduler, workers) as client, _Bar(len(items), desc, progress) as bar:
        if report:
            client.subscribe_topic(topic, lambda event: bar.line(*event[1]))
        futures = [client.submit(function, item, **({"report": _WorkerSink(topic, k)} if report else {}),
                                 pure=False) for k, item in enumerate(items)]
        index = {f.key: k for k, f in enumerate(futures)}
        results = [None] * len(futures)
        try:
            for future in as_completed(futures):
                results[index[future.key]] = future.result()
                bar.finished(index[future.key])
        finally:
            if report:  # a kept cluster's client outlives this map
                client.unsubscribe_topic(topic)
        return results


def map_here(function, items, desc="fits", progress=True, report=False):
    """``[function(item) for item in items]`` in this process, with the progress bar of :func:`map_on_dask`.

    Parameters
    ----------
    function : callable
    items : sequence
    desc : str, default "fits"
        Label of the progress bar.
    progress : bool, default True
        Show the progress bar (on stderr).
    report : bool, default False
        As :func:`map_on_dask`'s.

    Returns
    -------
    list
    """
    results = []
    with _Bar(len(items), desc, progress) as bar:
        for k, item in enumerate(items):
            results.append(function(item, report=functools.partial(bar.line, k)) if report else function(item))
            bar.finished(k)
    return results


class _WorkerSink:
    """A task's ``report``: sends its lines from the worker to the client's topic (picklable)."""

    def __init__(self, topic, index):
        self.topic, self.index = topic, index

    def __call__(self, line):
        from distributed import get_worker

        get_worker().log_event(self.topic, [self.index, line])


class _Bar:
    """A tqdm bar counting finished items, with the last line of each running item beside it."""

    def __init__(self, total, desc, progress):
        self.bar = tqdm(total=total, desc=desc, unit="task", file=sys.stderr, disable=not progress)
        self.lines = {}
        self.done = set()

    def line(self, index, text):
        """Show ``text`` for item ``index`` (numbered from 1 on the bar) while it runs (a worker's last line may
        arrive after its result)."""
        if index not in self.done:
            self.lines[index] = text
            self._show()

    def finished(self, index):
        self.done.add(index)
        self.lines.pop(index, None)
        self.bar.update()
        self._show()

    def _show(self):
        self.bar.set_postfix_str("; ".join(f"#{k + 1} {t}" for k, t in sorted(self.lines.items())), refresh=True)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.lines.clear()
        self.bar.close()
