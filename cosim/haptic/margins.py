"""Stability of a sampled virtual wall rendered on the device + user (seed 000 Sec. IV, eqs. 15-18).

The loop is ``L(z) = C(z) G(z)`` with ``G(z) = Z[H0(s) G(s)]`` (zero-order hold at the loop period T) and the
wall impedance ``C(z) = K + B (1 - z^-1) / T`` (stiffness K, damping B on a backward-difference velocity).
From it: critical stiffness ``K_CR = Gm{G(z)}`` (16), phase margin at K, damping ratio ``zeta ~ PM/100 deg``
(17), predicted overshoot of the second-order step ``exp(-pi zeta / sqrt(1 - zeta^2))`` and settling time
``t_s ~ 4 / (zeta w_cg)`` (18).
"""

from dataclasses import dataclass, asdict
import math

import numpy as np
import pandas as pd
import control
from scipy.optimize import brentq

from cosim.haptic.params import USERS, POSITIONS, load_user_params
from cosim.haptic.tf import tf_user
from cosim.errors import HapticDataError

__all__ = [
    "WallMargins",
    "discretize",
    "wall_margins",
    "critical_stiffness",
    "margins_table",
    "position_means",
    "adaptive_damping",
    "MARGIN_COLUMNS",
]

MARGIN_COLUMNS = ["user", "position", "model", "K_CR_Nm_per_rad", "PM_deg", "f_cross_Hz", "zeta", "overshoot", "settling_s"]


@dataclass(frozen=True)
class WallMargins:
    """Margins of the wall loop and the transient they predict.

    Attributes
    ----------
    K_CR : float
        Critical stiffness, N.m/rad: gain margin of G(z) (eq. 16; independent of K and B).
    PM_deg : float
        Phase margin of C(z) G(z), deg (the smallest over all gain crossovers).
    f_cross_Hz : float
        Gain-crossover frequency where that phase margin occurs, Hz.
    zeta : float
        PM / 100 deg (eq. 17).
    overshoot : float
        Predicted step overshoot, fraction (nan when zeta >= 1 or PM <= 0).
    settling_s : float
        4 / (zeta w_cg), s (eq. 18; inf when PM <= 0).
    """

    K_CR: float
    PM_deg: float
    f_cross_Hz: float
    zeta: float
    overshoot: float
    settling_s: float

    def as_dict(self):
        """Return the fields as a dict."""
        return asdict(self)


def discretize(G, rate=1000.0):
    """Return G(z) = Z[H0(s) G(s)] at the sample rate ``rate`` (Hz), eq. (15)."""
    if not rate > 0:
        raise ValueError(f"rate must be > 0 Hz; got {rate!r}")
    return control.c2d(G, 1.0 / rate, "zoh")


def _freq_eval(Gz, T):
    num = np.asarray(Gz.num[0][0], dtype=float)
    den = np.asarray(Gz.den[0][0], dtype=float)

    def f(w):
        z = np.exp(1j * np.asarray(w) * T)
        return np.polyval(num, z) / np.polyval(den, z)

    return f


def _grid(rate):
    return 2 * np.pi * np.logspace(-3, np.log10(0.4999 * rate), 40000)


def _crossings(fun, w):
    """Roots of ``fun`` between sign changes on the grid ``w``, refined with brentq."""
    v = fun(w)
    idx = np.nonzero(np.sign(v[:-1]) * np.sign(v[1:]) < 0)[0]
    return [brentq(fun, w[i], w[i + 1], xtol=1e-12, rtol=1e-12) for i in idx]


def critical_stiffness(Gz, rate):
    """Return the gain margin of G(z) (eq. 16), N.m/rad: the smallest 1/|G| at a phase of -180 deg (mod 360).

    Parameters
    ----------
    Gz : control.TransferFunction
        Discrete-time G(z).
    rate : float
        Sample rate, Hz.

    Returns
    -------
    float
        inf when the phase never reaches -180 deg below the Nyquist frequency.
    """
    T = 1.0 / rate
    f = _freq_eval(Gz, T)
    w = _grid(rate)
    ph = np.unwrap(np.angle(f(w)))
    # phase crossings of -180 - 360 k: use sin(phase) = 0 with cos(phase) < 0
    best = math.inf
    for k in range(-4, 1):
        target = -np.pi + 2 * np.pi * k
        idx = np.nonzero(np.sign(ph[:-1] - target) * np.sign(ph[1:] - target) < 0)[0]
        for i in idx:
            def g(x):
                return np.angle(f(x) * np.exp(-1j * target))
            try:
                wc = brentq(g, w[i], w[i + 1], xtol=1e-12, rtol=1e-12)
            except ValueError:
                wc = 0.5 * (w[i] + w[i + 1])
            best = min(best, 1.0 / abs(f(wc)))
    return best


def wall_margins(G, K=10.0, B=0.0, rate=1000.0):
    """Return the margins of a virtual wall of stiffness K and damping B rendered at ``rate`` on plant G.

    Parameters
    ----------
    G : control.TransferFunction
        Continuous plant phi/tau, rad/(N.m).
    K : float, optional
        Wall stiffness, N.m/rad (default 10).
    B : float, optional
        Wall damping, N.m.s/rad (default 0).
    rate : float, optional
        Haptic loop rate, Hz (default 1000).

    Returns
    -------
    WallMargins
    """
    if not K > 0:
        raise ValueError(f"K must be > 0 N.m/rad; got {K!r}")
    if not B >= 0:
        raise ValueError(f"B must be >= 0 N.m.s/rad; got {B!r}")
    if not rate > 0:
        raise ValueError(f"rate must be > 0 Hz; got {rate!r}")
    T = 1.0 / rate
    Gz = discretize(G, rate)
    g = _freq_eval(Gz, T)

    def L(w):
        z = np.exp(1j * np.asarray(w) * T)
        return (K + B * (1 - 1 / z) / T) * g(w)

    w = _grid(rate)
    wcs = _crossings(lambda x: np.abs(L(x)) - 1.0, w)
    if not wcs:
        pm, wcg = math.inf, math.nan
    else:
        pms = [(180.0 + np.degrees(np.angle(L(wc)))) for wc in wcs]
        pms = [((p + 180.0) % 360.0) - 180.0 for p in pms]
        i = int(np.argmin(pms))
        pm, wcg = float(pms[i]), float(wcs[i])
    kcr = critical_stiffness(Gz, rate)
    zeta = pm / 100.0
    if 0 < zeta < 1:
        overshoot = math.exp(-math.pi * zeta / math.sqrt(1 - zeta**2))
    else:
        overshoot = math.nan
    settling = 4.0 / (zeta * wcg) if zeta > 0 and math.isfinite(wcg) else math.inf
    return WallMargins(float(kcr), pm, wcg / (2 * np.pi), zeta, overshoot, settling)


def margins_table(K=10.0, rate=1000.0, damping=None, users=USERS, positions=POSITIONS):
    """Return the wall margins for every user x position of seed 000 Table I.

    Parameters
    ----------
    K : float, optional
        Wall stiffness, N.m/rad (default 10).
    rate : float, optional
        Loop rate, Hz (default 1000).
    damping : mapping of int to float, optional
        Wall damping B (N.m.s/rad) per position (the adaptive rendering); None = no damping.
    users, positions : sequence of int, optional
        Subset to compute (default all 13 x 6).

    Returns
    -------
    pandas.DataFrame
        Columns ``MARGIN_COLUMNS`` (``model`` = 11 or 7) plus ``B_Nms_per_rad``.
    """
    rows = []
    for u in users:
        for p in positions:
            params = load_user_params(u, p)
            B = 0.0 if damping is None else float(damping.get(p, 0.0))
            m = wall_margins(tf_user(params), K=K, B=B, rate=rate)
            rows.append({
                "user": u, "position": p, "model": params.structure,
                "K_CR_Nm_per_rad": m.K_CR, "PM_deg": m.PM_deg, "f_cross_Hz": m.f_cross_Hz, "zeta": m.zeta,
                "overshoot": m.overshoot, "settling_s": m.settling_s, "B_Nms_per_rad": B,
            })
    return pd.DataFrame(rows)


def position_means(table):
    """Return the per-position means of a `margins_table` (numeric columns, model dropped)."""
    cols = [c for c in MARGIN_COLUMNS[3:]] + (["B_Nms_per_rad"] if "B_Nms_per_rad" in table else [])
    return table.groupby("position")[cols].mean().reset_index()


def adaptive_damping(user=1, K=10.0, rate=1000.0, pm_target=50.0, positions=POSITIONS, resolution=1e-4):
    """Choose the wall damping B per grasp position so that PM >= ``pm_target`` (seed 000 Sec. V-A).

    For each position the smallest B on a grid of step ``resolution`` that reaches the target is returned
    (B = 0 when the undamped wall already meets it, as for positions 1-2 in the paper).

    Parameters
    ----------
    user : int, optional
        Whose models tune the table (default 1, as in the paper).
    K : float, optional
        Wall stiffness, N.m/rad (default 10).
    rate : float, optional
        Loop rate, Hz (default 1000).
    pm_target : float, optional
        Phase margin to reach, deg (default 50, i.e. zeta >= 0.5).
    positions : sequence of int, optional
    resolution : float, optional
        Step of the B grid, N.m.s/rad (default 1e-4).

    Returns
    -------
    dict of int to float
        Position -> B in N.m.s/rad.

    Raises
    ------
    HapticDataError
        No B up to 1 N.m.s/rad reaches the target.
    """
    out = {}
    for p in positions:
        G = tf_user(load_user_params(user, p))

        def pm(B):
            return wall_margins(G, K=K, B=B, rate=rate).PM_deg - pm_target

        if pm(0.0) >= 0:
            out[p] = 0.0
            continue
        # scan upwards (too much damping moves the crossover onto the ~60 Hz mode and destabilises the
        # loop, so PM(B) is not monotonic over a wide range), then bisect the first bracket
        step = 0.005
        lo, hi = 0.0, step
        while pm(hi) < 0:
            lo, hi = hi, hi + step
            if hi > 1.0:
                raise HapticDataError(f"user {user} position {p}: no damping B <= 1 N.m.s/rad gives PM >= {pm_target} deg")
        while hi - lo > resolution:
            mid = 0.5 * (lo + hi)
            if pm(mid) >= 0:
                hi = mid
            else:
                lo = mid
        out[p] = round(math.ceil(hi / resolution - 1e-9) * resolution, 12)
    return out
