"""Parallel map on a Dask cluster (a local one by default, an existing scheduler when given its address), with a
progress bar: the multi-start calibration and the diagnosis's candidate fits."""

import logging
import os
import sys

from tqdm import tqdm

__all__ = ["map_on_dask"]


def map_on_dask(function, items, scheduler="", max_workers=None, desc="fits", progress=True):
    """``[function(item) for item in items]`` on a Dask cluster with a progress bar, results in item order.

    Parameters
    ----------
    function : callable
        Takes one item; it and the items must pickle (they cross processes).
    items : sequence
    scheduler : str, default ""
        Address of an existing Dask scheduler; empty: a local cluster of processes (one per item, at most
        ``max_workers`` and the number of cores), closed afterwards.
    max_workers : int, optional
        Most workers of the local cluster.
    desc : str, default "fits"
        Label of the progress bar.
    progress : bool, default True
        Show the progress bar (on stderr).

    Returns
    -------
    list
        ``function(item)`` for each item, in item order; a task's error is raised here.
    """
    from distributed import Client, LocalCluster, as_completed

    cluster = None
    if scheduler:
        client = Client(scheduler)
    else:
        workers = max(1, min(len(items), max_workers or len(items), os.cpu_count() or 1))
        # CRITICAL: a worker's heartbeat racing the close logs a harmless CommClosedError traceback at ERROR
        # (dask/distributed#7105); a task's own error still reaches the caller through future.result()
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0",
                               silence_logs=logging.CRITICAL)
        client = Client(cluster)
    try:
        futures = [client.submit(function, item, pure=False) for item in items]
        index = {f.key: k for k, f in enumerate(futures)}
        results = [None] * len(futures)
        bar = tqdm(total=len(futures), desc=desc, unit="fit", file=sys.stderr, disable=not progress)
        for future in as_completed(futures):
            results[index[future.key]] = future.result()
            bar.update()
        bar.close()
        return results
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
