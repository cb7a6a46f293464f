"""Signal handlers installed for the length of a block: the one place cosim sets them, and puts the previous ones
back (a command's Ctrl-C, SIGTERM and SIGHUP are held while results are written, deferred while numba compiles,
turned into a stop of the run)."""

import contextlib
import signal
import threading

__all__ = ["handlers"]


@contextlib.contextmanager
def handlers(signals, handler):
    """Within the block, ``handler(signum, frame)`` handles each of ``signals``; the previous handlers are back
    after it, whatever ends it. Yields the previous handlers by signal. Only in the main thread, where handlers
    can be set: elsewhere the block runs as it is and ``{}`` is yielded."""
    if threading.current_thread() is not threading.main_thread():
        yield {}
        return
    previous = {s: signal.signal(s, handler) for s in signals}
    try:
        yield previous
    finally:
        for s, old in previous.items():
            signal.signal(s, old)
