"""Fitting the device + user models (seed 000) and the Fu arm model (seed 001) to frequency responses.

Both estimators follow the fit/predict contract: ``__init__`` stores settings, ``fit`` validates its inputs and
returns ``self``, learned values end in ``_``. The models are written as mechanical state-space systems so
that, with ``fs`` given, the fitted response is the exact zero-order-hold response of the sampled experiment
(the plant input is held by the DAC over each period; fitting a continuous model to sampled data would
absorb the hold's T/2 delay into the parameters).

The cost is a weighted least squares in the complex logarithm, ``sum w (log Hm - log He)``, real and imaginary
parts (log-magnitude and phase), with w the magnitude-squared coherence (seed 001 weights by coherence;
seed 000 does not say); parameters are fitted in log scale (all positive). A parameter is reported as
*informative* when its relative standard error from the Jacobian at the optimum is below ``informative_rse``.
"""

import math

import numpy as np
from scipy.optimize import least_squares

from cosim.fitting import Estimator
from cosim.freqresp import FrequencyResponse, model_response
from cosim.haptic.params import PARAMS_11, PARAMS_7, USERS, load_user_params

__all__ = [
    "device_user_ss",
    "arm_ss",
    "DeviceUserFit",
    "ArmFit",
    "ARM_PARAMS",
]

ARM_PARAMS = ("M", "k1", "k2", "b1", "b2")


def device_user_ss(values, structure):
    """Return (A, B, C, D) of the device + user model, input motor torque (N.m), output phi1 (rad).

    11 parameters: states phi1, phi2, phih, w1, w2, wh; m1 is driven by the torque, coupled to m2 by kc, bc;
    b1 (m1) and b2 (m2) damp to ground; ks, bs couple m2 to the hand mass mh, held to ground by kh, bh.
    7 parameters: states phi1, phi2, w1, w2; m2 is held to ground by ks, bs.

    Parameters
    ----------
    values : mapping of str to float
        SI values at the phi axis.
    structure : {11, 7}

    Returns
    -------
    tuple of numpy.ndarray
    """
    v = values
    if structure == 11:
        m1, b1, bc, kc, m2, b2, bs, ks, mh, bh, kh = (float(v[k]) for k in PARAMS_11)
        K = np.array([[kc, -kc, 0.0], [-kc, kc + ks, -ks], [0.0, -ks, ks + kh]])
        Bm = np.array([[b1 + bc, -bc, 0.0], [-bc, bc + b2 + bs, -bs], [0.0, -bs, bs + bh]])
        Minv = np.diag([1 / m1, 1 / m2, 1 / mh])
    elif structure == 7:
        m1, b1, bc, kc, m2, bs, ks = (float(v[k]) for k in PARAMS_7)
        K = np.array([[kc, -kc], [-kc, kc + ks]])
        Bm = np.array([[b1 + bc, -bc], [-bc, bc + bs]])
        Minv = np.diag([1 / m1, 1 / m2])
    else:
        raise ValueError(f"structure must be 11 or 7; got {structure!r}")
    n = K.shape[0]
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ Bm]])
    B = np.zeros((2 * n, 1))
    B[n, 0] = Minv[0, 0]
    C = np.zeros((1, 2 * n))
    C[0, 0] = 1.0
    return A, B, C, np.zeros((1, 1))


def arm_ss(values):
    """Return (A, B, C, D) of the Fu arm, input force at the stylus (N), output stylus position (m).

    The stylus point x1 is massless: b1 (x1' - xM') + k1 (x1 - xM) = F; M xM'' = k1 (x1 - xM) + b1 (x1' - xM')
    - k2 xM - b2 xM'. States x1, xM, vM; output x1 (seed 001 eq. 1).
    """
    M, k1, k2, b1, b2 = (float(values[k]) for k in ARM_PARAMS)
    # x1' = vM + (F - k1 (x1 - xM)) / b1
    A = np.array([
        [-k1 / b1, k1 / b1, 1.0],
        [0.0, 0.0, 1.0],
        [0.0, -k2 / M, -b2 / M],
    ])
    # M vM' = F - k2 xM - b2 vM (the grasp force equals F: massless stylus point)
    B = np.array([[1 / b1], [0.0], [1 / M]])
    C = np.array([[1.0, 0.0, 0.0]])
    return A, B, C, np.zeros((1, 1))


class _FrequencyFit(Estimator):
    """A parametric model fitted to a measured frequency response (the fitting contract of :mod:`cosim.fitting`);
    subclasses give the parameter ``names``, the state space of given values and the default start."""

    names = ()

    def __init__(self, freq_range, fs=None, weighting="coherence", informative_rse=0.02, x0=None, max_nfev=1000,
                 residual="log", good_rms=0.03):
        self.residual = residual
        self.good_rms = good_rms
        self.freq_range = freq_range
        self.fs = fs
        self.weighting = weighting
        self.informative_rse = informative_rse
        self.x0 = x0
        self.max_nfev = max_nfev

    def _ss(self, values):  # pragma: no cover - abstract
        raise NotImplementedError

    def _default_x0(self):  # pragma: no cover - abstract
        raise NotImplementedError

    def _response(self, values, f):
        return model_response(self._ss(values), f, self.fs)

    def fit(self, response):
        """Fit the model to a measured frequency response.

        Parameters
        ----------
        response : FrequencyResponse
            Estimated response; only ``freq_range`` is used.

        Returns
        -------
        self
        """
        if not isinstance(response, FrequencyResponse):
            raise TypeError(f"response must be a FrequencyResponse; got {type(response).__name__}")
        if self.residual not in ("log", "linear"):
            raise ValueError(f"residual must be 'log' or 'linear'; got {self.residual!r}")
        if self.weighting not in ("coherence", "none"):
            raise ValueError(f"weighting must be 'coherence' or 'none'; got {self.weighting!r}")
        lo, hi = self.freq_range
        data = response.band(lo, hi)
        if len(data.f) < 2 * len(self.names):
            raise ValueError(
                f"only {len(data.f)} frequency points in {lo}-{hi} Hz; need at least {2 * len(self.names)}"
            )
        w = np.sqrt(data.coherence) if self.weighting == "coherence" else np.ones_like(data.f)
        logH = np.log(data.H)
        x0 = self._default_x0() if self.x0 is None else dict(self.x0)
        missing = [n for n in self.names if n not in x0]
        if missing:
            raise ValueError(f"x0 lacks {', '.join(missing)}")
        theta0 = np.log([max(float(x0[n]), 1e-9) for n in self.names])

        scale = float(np.median(np.abs(data.H)))

        def resid(theta):
            vals = dict(zip(self.names, np.exp(theta)))
            Hm = self._response(vals, data.f)
            if self.residual == "linear":
                # seed 001 eq. (2): sum W (H_exp - H_model)^2, scaled to order 1
                d = (Hm - data.H) / scale
            else:
                d = np.log(Hm) - logH
                # keep the phase difference in (-pi, pi]
                d = d.real + 1j * np.angle(np.exp(1j * d.imag))
            return np.concatenate([w * d.real, w * d.imag])

        # parameters may not leave four decades around the start: a value printed as 0 in Table I (< 0.001)
        # would otherwise be chased towards -inf in log scale; a parameter ending on a bound is reported as
        # not informative
        lo_b, hi_b = theta0 - np.log(1e4), theta0 + np.log(1e4)
        best = None
        sign = np.array([1.0 if i % 2 else -1.0 for i in range(len(theta0))])
        rng = np.random.default_rng(0)
        starts = [theta0, theta0 + np.log(0.5) * sign, theta0 + np.log(2.0) * sign]
        starts += [theta0 + rng.normal(0.0, 1.0, len(theta0)) for _ in range(3)]
        for start in starts:
            sol = least_squares(resid, start, bounds=(lo_b, hi_b), method="trf", x_scale=1.0,
                                max_nfev=self.max_nfev, xtol=1e-10, ftol=1e-12, gtol=1e-10)
            if best is None or sol.cost < best.cost:
                best = sol
            if np.sqrt(2 * best.cost / len(data.f)) < self.good_rms:  # a good fit: no further starts
                break
        J = best.jac
        dof = max(len(best.fun) - len(theta0), 1)
        s2 = 2 * best.cost / dof
        try:
            JtJ_inv = np.linalg.pinv(J.T @ J)
            cov = JtJ_inv * s2
            # heteroscedasticity-consistent (sandwich) covariance: the Welch estimate's error is not uniform
            # (leakage bias where the response has slow modes is concentrated in the lowest bins, where the
            # stiffnesses act); take the larger of the two standard errors per parameter
            r = best.fun
            cov_hc = JtJ_inv @ (J.T * r**2) @ J @ JtJ_inv * (len(r) / dof)
            rse = np.sqrt(np.maximum(np.clip(np.diag(cov), 0, None), np.clip(np.diag(cov_hc), 0, None)))
        except np.linalg.LinAlgError:
            rse = np.full(len(theta0), math.inf)
        at_bound = (best.x <= lo_b + 1e-3) | (best.x >= hi_b - 1e-3) | (np.linalg.norm(J, axis=0) == 0)
        rse = np.where(at_bound, math.inf, rse)
        self.parameters_ = dict(zip(self.names, np.exp(best.x)))
        self.relative_se_ = dict(zip(self.names, rse))
        self.rms_log_error_ = float(np.sqrt(2 * best.cost / len(data.f)))
        # a fit that did not reach the noise floor sits in a wrong local minimum: trust none of its values
        self.converged_ = self.rms_log_error_ < self.good_rms
        self.informative_ = tuple(n for n, r in self.relative_se_.items() if r < self.informative_rse and self.converged_)
        self.cost_ = float(best.cost)
        self.n_points_ = len(data.f)
        return self

    @property
    def params_(self):
        """The fitted values, as the paper's scripts name them: ``parameters_``."""
        self._check_fitted("params_")
        return self.parameters_

    def predict(self, f):
        """Return the fitted model's response at ``f`` (Hz), with the ZOH when ``fs`` was given."""
        self._check_fitted("predict")
        return self._response(self.parameters_, np.asarray(f, dtype=float))


class DeviceUserFit(_FrequencyFit):
    """Fit the 11- or 7-parameter device + user model (seed 000 eqs. 2, 9) to a phi/tau response.

    Parameters
    ----------
    structure : {11, 7}, optional
        Model structure (default 11).
    freq_range : (float, float), optional
        Fitted band, Hz (default 0.5-70, seed 000 Sec. II-C).
    fs : float, optional
        Sample rate of the experiment, Hz: the model is compared through a ZOH (default 1000). None fits the
        continuous model.
    weighting : {"coherence", "none"}, optional
        Weight of each point (default coherence).
    informative_rse : float, optional
        Relative standard error below which a parameter is called informative (default 0.02).
    x0 : mapping, optional
        Start values (SI). Default: the median of Table I over the rows of this structure and ``position``.
    position : int, optional
        Grasp position whose Table I median is the default start (default: all positions).
    max_nfev : int, optional
        Function evaluations per start (default 1000). Starts: x0, x0 scaled by 0.5/2 alternately, then three
        random log-normal perturbations (sigma 1, fixed seed), tried in turn while the RMS residual of the best
        fit stays above ``good_rms``.
    good_rms : float, optional
        RMS weighted residual below which no further start is tried (default 0.03; noise-free Welch
        estimates of the paper's experiment fit to ~0.01).
    residual : {"log", "linear"}, optional
        Complex-log difference (default; relative, suits the 2-decade magnitude range) or the plain complex
        difference.

    Attributes
    ----------
    parameters_ : dict
        Fitted values (SI).
    relative_se_ : dict
        Relative standard errors from the Jacobian.
    informative_ : tuple of str
        Parameters with relative_se_ < informative_rse (none when the fit did not converge).
    converged_ : bool
        The RMS residual reached ``good_rms`` (otherwise the fit is in a local minimum: a poor start).
    rms_log_error_ : float
        RMS of the weighted complex-log residual.
    """

    def __init__(self, structure=11, freq_range=(0.5, 70.0), fs=1000.0, weighting="coherence",
                 informative_rse=0.02, x0=None, position=None, max_nfev=1000, residual="log", good_rms=0.03):
        super().__init__(freq_range, fs, weighting, informative_rse, x0, max_nfev, residual, good_rms)
        self.structure = structure
        self.position = position

    @property
    def names(self):
        return PARAMS_11 if self.structure == 11 else PARAMS_7

    def _ss(self, values):
        return device_user_ss(values, self.structure)

    def _default_x0(self):
        if self.structure not in (11, 7):
            raise ValueError(f"structure must be 11 or 7; got {self.structure!r}")
        rows = []
        for u in USERS:
            for p in ([self.position] if self.position else range(1, 7)):
                r = load_user_params(u, p)
                if r.structure == self.structure:
                    rows.append(r.values)
        if not rows:
            rows = [load_user_params(u, p).values for u in USERS for p in range(1, 7) if load_user_params(u, p).structure == self.structure]
        x0 = {}
        for n in self.names:
            vals = np.array([r[n] for r in rows])
            x0[n] = float(np.median(vals[vals > 0])) if np.any(vals > 0) else 1e-3
        return x0


class ArmFit(_FrequencyFit):
    """Fit the five-parameter Fu arm model (seed 001 eq. 1) to a position/force response.

    Parameters
    ----------
    freq_range : (float, float), optional
        Fitted band, Hz (default 0.6-30, seed 001 Sec. II-D).
    fs : float, optional
        Sample rate; the model is compared through a ZOH (default 1000). None fits the continuous model.
    weighting : {"coherence", "none"}, optional
        Default coherence (seed 001 eq. 2 with W_t = coherence).
    informative_rse : float, optional
    x0 : mapping, optional
        Start values; default the Table III means of the X axis (M 0.324 kg, k1 459.4, k2 104.8 N/m,
        b1 2.579, b2 5.920 N.s/m).
    max_nfev : int, optional
    residual : {"linear", "log"}, optional
        ``linear`` (default): the complex difference of seed 001 eq. (2) (scaled by the median |H|); ``log``:
        the complex-log difference used for the device fits.
    good_rms : float, optional
        RMS weighted residual below which no further start is tried (default 0.1).
    """

    names = ARM_PARAMS

    def __init__(self, freq_range=(0.6, 30.0), fs=1000.0, weighting="coherence", informative_rse=0.02, x0=None,
                 max_nfev=1000, residual="linear", good_rms=0.1):
        super().__init__(freq_range, fs, weighting, informative_rse, x0, max_nfev, residual, good_rms)

    def _ss(self, values):
        return arm_ss(values)

    def _default_x0(self):
        return {"M": 0.324, "k1": 459.4, "k2": 104.8, "b1": 2.579, "b2": 5.920}
