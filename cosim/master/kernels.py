"""Small numba-compiled array kernels of the master's per-tick work (RK4 stage combination, routing).

They act in place on preallocated arrays, so the Python engine calls them once per stage and the
compiled engine can inline them in its loop.
"""

import numba

__all__ = ["rk4_stage", "rk4_final", "route"]


@numba.njit(cache=True)
def rk4_stage(X, X0, dX, K, s, c):
    """Store stage derivative ``dX`` as ``K[s]`` and set ``X = X0 + c * dX`` (the next stage's state)."""
    for i in range(X.shape[0]):
        K[s, i] = dX[i]
        X[i] = X0[i] + c * dX[i]


@numba.njit(cache=True)
def rk4_final(X, X0, dX, K, h):
    """Finish an RK4 step: ``X = X0 + h/6 (K0 + 2 K1 + 2 K2 + dX)``; ``X0 = X``."""
    for i in range(X.shape[0]):
        X[i] = X0[i] + h / 6.0 * (K[0, i] + 2.0 * K[1, i] + 2.0 * K[2, i] + dX[i])
        X0[i] = X[i]


@numba.njit(cache=True)
def route(buf, src, dst, gain, offset):
    """``buf[dst[j]] = gain[j] * buf[src[j]] + offset[j]`` for every j, in order."""
    for j in range(src.shape[0]):
        buf[dst[j]] = gain[j] * buf[src[j]] + offset[j]
