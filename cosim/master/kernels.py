"""Small numba-compiled array kernels of the master's per-tick work (RK4 stage combination, routing).

They act in place on preallocated arrays, so the Python engine calls them once per stage and the
compiled engine can inline them in its loop.
"""

import numba

__all__ = ["rk4_begin", "rk4_stage", "rk4_final", "route"]

# The RK4 kernels work on one array W of shape (7, n): rows X (state the FMUs see), X0 (state at the
# step's start), dX (derivative just evaluated), K1..K4.


@numba.njit(cache=True)
def rk4_begin(W):
    """Start a step: ``X0 = X``."""
    for i in range(W.shape[1]):
        W[1, i] = W[0, i]


@numba.njit(cache=True)
def rk4_stage(W, s, c):
    """Store the derivative ``dX`` as ``K[s]`` and set ``X = X0 + c * dX`` (the next stage's state)."""
    for i in range(W.shape[1]):
        W[3 + s, i] = W[2, i]
        W[0, i] = W[1, i] + c * W[2, i]


@numba.njit(cache=True)
def rk4_final(W, h):
    """Finish an RK4 step: ``X = X0 + h/6 (K1 + 2 K2 + 2 K3 + dX)``; ``X0 = X``."""
    for i in range(W.shape[1]):
        W[0, i] = W[1, i] + h / 6.0 * (W[3, i] + 2.0 * W[4, i] + 2.0 * W[5, i] + W[2, i])
        W[1, i] = W[0, i]


@numba.njit(cache=True)
def route(buf, src, dst, gain, offset):
    """``buf[dst[j]] = gain[j] * buf[src[j]] + offset[j]`` for every j, in order."""
    for j in range(src.shape[0]):
        buf[dst[j]] = gain[j] * buf[src[j]] + offset[j]
