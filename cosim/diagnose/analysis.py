"""Residual analysis of the discrepancy workflow: noise level from the data themselves, natural segments of the
experiment, where the residual is significant and its shape, whiteness and cross-correlation with the input."""

from dataclasses import dataclass

import numpy as np
from scipy import stats

from cosim.experiment import constant_runs

__all__ = ["Segment", "in_segment", "noise_level", "hold_segments", "impact_phases", "frequency_bands",
           "segment_table", "gap_shown", "band_shape", "whiteness", "cross_correlation", "branch_shapes"]


@dataclass(frozen=True)
class Segment:
    """One natural piece of the experiment.

    Attributes
    ----------
    index : int
    label : str
        e.g. ``"step 3 up: i_ref 0.75 -> 1 A"`` or ``"impact"``.
    kind : str
        ``up``, ``down``, ``hold`` (staircase) or ``approach``/``impact``/``tightening``/``steady``.
    t0, t1 : float
        Start and end [s].
    level : float
        The input level held in the segment (staircase), else nan.
    """

    index: int
    label: str
    kind: str
    t0: float
    t1: float
    level: float


def noise_level(time, measured, mask):
    """Noise standard deviation of each signal from the data: differences of consecutive samples inside the
    steady windows (``mask``), robust scale (MAD), divided by sqrt(2). Slow trends cancel in the differences.
    Consecutive means one sampling interval apart (the median interval of the masked samples): differences do
    not span the gap between two windows.

    Returns ndarray, shape (n_signals,)."""
    measured = np.atleast_2d(measured)
    index = np.flatnonzero(mask)
    dt = np.diff(time[index])
    inside = dt < 1.5 * np.median(dt) if dt.size else dt.astype(bool)
    out = []
    for y in measured:
        d = np.diff(y[index])[inside]
        if d.size < 5:
            out.append(0.0)
            continue
        out.append(float(1.4826 * np.median(np.abs(d - np.median(d))) / np.sqrt(2)))
    return np.array(out)


def hold_segments(time, inputs, min_hold_s=0.1):
    """The natural segments of a staircase: each hold of at least ``min_hold_s`` [s] with the ramp before it,
    kind ``up``, ``down`` or ``hold`` by the level it holds against the one before.

    Returns list of Segment."""
    segments = []
    holds = [(a, b) for a, b in constant_runs(inputs) if time[b - 1] - time[a] + 1e-9 >= min_hold_s]
    previous, start = None, 0
    for k, (a, b) in enumerate(holds):
        level = float(inputs[a, 0])
        if previous is None:
            direction, text = "hold", f"start: {level:g}"
        else:
            direction = "up" if level > previous else "down" if level < previous else "hold"
            text = f"{direction} {previous:g} -> {level:g}"
        end = holds[k + 1][0] if k + 1 < len(holds) else len(time)
        segments.append(Segment(k, f"step {k} {text}", direction, float(time[start]), float(time[end - 1]), level))
        previous, start = level, end
    return segments


def impact_phases(time, force, noise):
    """The natural segments of an impact, from its measured ``force`` and its ``noise`` level: approach, impact
    (from the first sample above 5 noise levels to the peak), tightening, steady (settled within 5 % of the final
    force); a phase without samples is left out.

    Returns list of Segment."""
    y = np.asarray(force, float)
    sigma = max(float(noise), 1e-12)
    above = np.flatnonzero(y > y[0] + 5 * sigma)
    contact = above[0] if above.size else len(y) - 1
    peak = contact + int(np.argmax(y[contact:])) if above.size else contact
    final = np.median(y[-max(len(y) // 10, 1):])
    outside = np.flatnonzero(np.abs(y[peak:] - final) > max(0.05 * abs(final), 3 * sigma))
    settle = peak + (outside[-1] + 1 if outside.size else 0)
    settle = min(max(settle, peak + 1), len(y) - 1)
    marks = [0, contact, min(peak + 1, len(y) - 1), settle, len(y) - 1]
    names = ["approach", "impact", "tightening", "steady"]
    return [Segment(k, names[k], names[k], float(time[marks[k]]), float(time[marks[k + 1]]), float("nan"))
            for k in range(4) if marks[k + 1] > marks[k]]


def quiet_phases(time, force, noise):
    """The samples of an impact's approach and steady hold: the measured force is flat there, so its
    sample-to-sample differences are noise, while those of the impact and the tightening between them are mostly
    signal (:func:`impact_phases` finds the phases with the rough ``noise`` level).

    Returns boolean ndarray, shape (N,)."""
    quiet = np.zeros(len(time), bool)
    for seg in impact_phases(time, force, noise):
        if seg.kind in ("approach", "steady"):
            quiet |= in_segment(time, seg)
    return quiet


def frequency_bands(frequency, magnitude_db, per_decade=6.0, min_points=8):
    """The segments of a frequency response: bands of equal width on a log axis (``per_decade`` of them per
    decade, edges at 1 Hz x 10^(k/per_decade)), a band with fewer than ``min_points`` frequencies merged into the
    next one. Narrow interleaved bands, rather than one band per resonance, let both folds of the cross-validation
    see the flanks of every feature. A band's label names the measured peak or notch it holds (an interior
    extremum of the magnitude at least 1 dB beyond both ends of the band).

    Returns list of Segment (``t0``, ``t1``: the band's first and last frequency [Hz]; kind ``band``)."""
    f = np.asarray(frequency, float)
    edges = 10.0 ** (np.floor(np.log10(f[0]) * per_decade) / per_decade
                     + np.arange(int(np.ceil(np.log10(f[-1] / f[0]) * per_decade)) + 2) / per_decade)
    which = np.searchsorted(edges, f, side="right")
    groups = [np.flatnonzero(which == k) for k in np.unique(which)]
    merged = []
    for g in groups:
        if merged and len(merged[-1]) < min_points:
            merged[-1] = np.concatenate([merged[-1], g])
        else:
            merged.append(g)
    if len(merged) > 1 and len(merged[-1]) < min_points:
        merged[-2:] = [np.concatenate(merged[-2:])]
    segments = []
    for k, g in enumerate(merged):
        m = np.asarray(magnitude_db, float)[g]
        feature = ""
        if len(g) >= 3:
            top, low = int(np.argmax(m)), int(np.argmin(m))
            if 0 < top < len(g) - 1 and m[top] > max(m[0], m[-1]) + 1.0:
                feature = f", peak at {f[g[top]]:.3g} Hz"
            elif 0 < low < len(g) - 1 and m[low] < min(m[0], m[-1]) - 1.0:
                feature = f", notch at {f[g[low]]:.3g} Hz"
        segments.append(Segment(k, f"band {k}: {f[g[0]]:.3g}-{f[g[-1]]:.3g} Hz{feature}", "band",
                                float(f[g[0]]), float(f[g[-1]]), float("nan")))
    return segments


def in_segment(time, seg):
    """Which instants of ``time`` lie in ``seg`` (ends included)."""
    return (time >= seg.t0 - 1e-9) & (time <= seg.t1 + 1e-9)


def segment_table(time, residual, predicted, measured, mask, segments, noise, threshold=3.0, shape=None):
    """Per segment and signal: samples, bias, RMSE, max error, significance and shape.

    A segment's gap is *significant* when the RMS of its residual on the cost samples exceeds ``threshold``
    noise levels (a model error larger than the scatter of the measurement; ``noise``: one level per signal, or
    one per sample, shape (n_signals, N), whose RMS over the segment counts). Shape (time-domain default):
    ``bias`` (mean dominates), ``peak error`` (transient maximum well above the steady RMS), ``oscillation`` (the
    detrended residual changes sign often and is large), ``phase lag`` (measured and predicted best aligned at a
    nonzero lag); ``shape`` replaces that classification (same arguments), e.g. :func:`band_shape`.
    """
    shape = shape or _shape
    rows = []
    sampled = np.all(np.isfinite(measured), axis=0)  # multi-rate data: the instants every channel has
    for seg in segments:
        inside = in_segment(time, seg) & sampled
        cost = inside & mask
        for j in range(residual.shape[0]):
            r_all, r = residual[j, inside], residual[j, cost]
            if r.size == 0:
                continue
            level = noise[j] if np.ndim(noise) == 1 else float(np.sqrt(np.mean(noise[j, cost] ** 2)))
            rmse = float(np.sqrt(np.mean(r ** 2)))
            bias = float(np.mean(r))
            row = {"segment": seg.label, "kind": seg.kind, "t0": seg.t0, "t1": seg.t1, "level": seg.level,
                   "signal": j, "samples": int(r.size), "bias": bias, "rmse": rmse,
                   "max_error": float(np.max(np.abs(r_all))), "significant": bool(rmse > threshold * level),
                   "noise": level,
                   "sigmas": rmse / level if level > 0 else float("inf")}
            row["shape"] = shape(r_all, r, predicted[j, inside], measured[j, inside], level) \
                if row["significant"] else "within noise"
            rows.append(row)
    return rows


def gap_shown(significant, mean_square, chance):
    """The rule by which a residual shows a gap, the baseline's and the one a finding leaves: a segment above the
    noise (``significant``: each segment's flag) *and* a whole residual beyond chance (``mean_square``, in noise
    levels squared, above ``chance``: a lone segment at 3 sigma is also what noise gives over many segments)."""
    return any(significant) and bool(mean_square > chance)


def _shape(r_all, r_steady, pred, meas, sigma):
    rms = np.sqrt(np.mean(r_steady ** 2))
    if abs(np.mean(r_steady)) > 0.7 * rms and np.max(np.abs(r_all)) < 3 * rms:
        return "bias"
    if np.max(np.abs(r_all)) > 3 * rms:
        return "peak error"
    if len(r_all) > 8:
        detrended = r_all - np.linspace(r_all[0], r_all[-1], len(r_all))
        crossings = np.mean(np.diff(np.sign(detrended)) != 0)
        lag = _best_lag(np.diff(meas), np.diff(pred))
        if lag != 0 and np.std(np.diff(meas)) > 3 * sigma:
            return f"phase lag ({lag} samples)"
        if crossings > 0.2 and np.std(detrended) > 3 * sigma:
            return "oscillation"
    return "bias" if abs(np.mean(r_steady)) > 0.5 * rms else "drift"


def band_shape(r_all, r, pred, meas, sigma):
    """Shape of a frequency band's residual (model - measured, dB or deg): ``offset`` (its mean dominates: a
    gain or phase offset), ``tilt`` (a straight trend across the band dominates: a slope, e.g. the phase of a
    delay), else ``local`` (a resonance or antiresonance the model misses or misplaces)."""
    rms = np.sqrt(np.mean(r ** 2))
    side = "model above" if np.mean(r) > 0 else "model below"
    if abs(np.mean(r)) > 0.7 * rms:
        return f"offset ({side})"
    x = np.arange(len(r), dtype=float)
    trend = np.polyval(np.polyfit(x, r, 1), x) if len(r) > 2 else r
    if np.mean(trend ** 2) > 0.7 * rms ** 2:
        return "tilt (model falls behind with frequency)" if trend[-1] < trend[0] else "tilt (model rises)"
    return "local (resonance or antiresonance)"


def _best_lag(a, b, max_lag=10):
    """Shift of ``a`` against ``b`` [samples] that correlates them best; 0 when the records are too short or no
    shifted window varies (a quantised angle can stand still over a whole segment's window)."""
    if len(a) < 3 * max_lag:
        return 0
    lags = np.arange(-max_lag, max_lag + 1)
    fixed = b[max_lag:len(b) - max_lag]
    scores = np.array([_correlation(a[max_lag + k:len(a) - max_lag + k], fixed) for k in lags])
    return 0 if np.isnan(scores).all() else int(lags[np.nanargmax(scores)])


def _correlation(x, y):
    """Pearson correlation; NaN when either does not vary (where np.corrcoef warns of a division by zero)."""
    sx, sy = np.std(x), np.std(y)
    if sx == 0 or sy == 0:
        return np.nan
    return float(np.mean((x - np.mean(x)) * (y - np.mean(y))) / (sx * sy))


def branch_shapes(segments, rows):
    """Shapes across segments of a staircase: *hysteresis width* (the up and down holds at the same level
    disagree with the model differently by more than three noise levels of their rows)."""
    findings = []
    by_level = {}
    for row in rows:
        if row["signal"] == 0 and row["kind"] in ("up", "down"):
            by_level.setdefault(round(row["level"], 6), {})[row["kind"]] = row
    widths = [(lvl, d["down"]["bias"] - d["up"]["bias"], max(d["down"]["noise"], d["up"]["noise"]))
              for lvl, d in sorted(by_level.items()) if "up" in d and "down" in d]
    wide = [(lvl, w) for lvl, w, level in widths if abs(w) > 3 * level]
    if wide:
        findings.append({"shape": "hysteresis width",
                         "detail": "residual differs between the rising and the falling branch at "
                                   + ", ".join(f"{lvl:g} ({w:+.3g})" for lvl, w in wide)})
    return findings


def _acf(x, lags):
    x = x - np.mean(x)
    d = float(x @ x)
    return np.array([float(x[:-k] @ x[k:]) / d if d > 0 else 0.0 for k in range(1, lags + 1)])


def whiteness(residual, lags=20):
    """Autocorrelation of a residual (1-D, the cost samples in order) at lags 1..``lags`` with the 95 % band
    +-1.96/sqrt(N) and the Ljung-Box test. Returns a dict (``acf``, ``band``, ``outside``, ``q``, ``p_value``,
    ``white``: p >= 0.01)."""
    n = len(residual)
    lags = min(lags, max(n // 4, 1))
    rho = _acf(residual, lags)
    q = float(n * (n + 2) * np.sum(rho ** 2 / (n - np.arange(1, lags + 1))))
    p = float(stats.chi2.sf(q, lags))
    band = 1.96 / np.sqrt(n)
    return {"acf": rho.tolist(), "band": band, "outside": int(np.sum(np.abs(rho) > band)), "q": q,
            "p_value": p, "white": p >= 0.01}


def cross_correlation(residual, u, lags=20):
    """Correlation of the residual with the input at lags 0..``lags`` (residual after input); values outside
    +-1.96/sqrt(N) say the residual still depends on the input (an input-driven effect is missing)."""
    n = len(residual)
    lags = min(lags, max(n // 4, 1))
    r, u = residual - np.mean(residual), u - np.mean(u)
    d = np.sqrt(float(r @ r) * float(u @ u))
    cc = np.array([float(r[k:] @ u[:n - k]) / d if d > 0 else 0.0 for k in range(0, lags + 1)])
    band = 1.96 / np.sqrt(n)
    return {"ccf": cc.tolist(), "band": band, "outside": int(np.sum(np.abs(cc) > band)),
            "independent": bool(np.all(np.abs(cc) <= band))}


def rmse_per_signal(predicted, measured, mask):
    """RMS and largest error of each signal on ``mask``: two lists, one value per row of ``predicted`` and
    ``measured`` (n_signals, N)."""
    r = (predicted - measured)[:, mask]
    return [float(np.sqrt(np.mean(x ** 2))) for x in r], [float(np.max(np.abs(x))) for x in r]
