"""Closed-form solutions of the test FMUs, the independent references their tests compare against."""

import math

import numpy as np


def bounce_times(h0=1.0, g=9.81, e=0.7, v_min=0.1, stop=math.inf):
    """Impact instants of a ball dropped from rest at ``h0`` up to ``stop``; with ``v_min > 0`` the last one is
    where it comes to rest (BouncingBall of tests/fmus).

    The first impact is at sqrt(2 h0 / g) with speed w = g t1; after impact k the ball leaves with e^k w and
    is back 2 e^k w / g later; it rests at the first impact whose rebound speed is below ``v_min``.
    """
    t = math.sqrt(2 * h0 / g)
    w = g * t
    times = [t]
    while e * w >= v_min:
        w *= e
        t += 2 * w / g
        if t > stop:
            break
        times.append(t)
    return np.array([t for t in times if t <= stop])


def ball_state(t, h0=1.0, g=9.81, e=0.7, v_min=0.1):
    """(h, v, bounces, flying) of BouncingBall at the instants ``t`` (after an impact at exactly t)."""
    impacts = bounce_times(h0, g, e, v_min)
    t = np.asarray(t, dtype=float)
    n = np.searchsorted(impacts, t, side="right")
    w1 = g * impacts[0]
    since = t - np.where(n > 0, impacts[np.maximum(n - 1, 0)], 0.0)
    v0 = np.where(n > 0, w1 * e ** n, 0.0)
    h = np.where(n > 0, v0 * since - g * since**2 / 2, h0 - g * t**2 / 2)
    v = v0 - g * since
    flying = n < len(impacts)
    return np.where(flying, h, 0.0), np.where(flying, v, 0.0), n, flying


def ticker_state(t, period=0.25):
    """(counter, x) of Ticker: counter = floor(t / period), x the integral of counter from 0."""
    t = np.asarray(t, dtype=float)
    k = np.floor(t / period + 1e-12)
    return k, period * k * (k - 1) / 2 + k * (t - k * period)
