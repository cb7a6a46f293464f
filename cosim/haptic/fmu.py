"""The haptic FMUs from the analysis side: parameter sets for a Table I row, linearisation, sampled simulation.

* `fmu_parameters`: the FMU parameter dict for a user x position row (or a Fu arm) and the FMU that fits it.
* `linearize_fmu`: A, B, C, D by central finite differences of the FMU's derivative and output functions
  around a state (FMI 3 Model Exchange through `cosim.fmi.FmuInstance`).
* `simulate_fmu`: drive the FMU with input samples held over each period (ZOH) and sample one output, with
  fixed-step RK4 substeps; used to run the identification experiments through the FMU.
"""

from pathlib import Path

import numpy as np

from cosim.haptic.params import ArmParams, HapticParams, R_POINT_A

__all__ = ["FMU_NAMES", "fmu_parameters", "linearize_fmu", "simulate_fmu"]

FMU_NAMES = {11: "HapticDevice11", 7: "HapticDevice7", "arm": "HapticDeviceArm", "arm_alone": "HapticArm"}


def fmu_parameters(params, device=None, r=R_POINT_A):
    """Return (FMU name, parameter dict) for a Table I row or for the Fu arm.

    Parameters
    ----------
    params : HapticParams or ArmParams
        A row from `load_user_params` (-> HapticDevice11 / HapticDevice7), or an arm from `load_arm_params`
        (-> HapticDeviceArm when ``device`` is given, HapticArm otherwise).
    device : mapping, optional
        m1, b1, bc, kc, m2, b2 of the device (SI, phi axis) to carry the arm.
    r : float, optional
        Lever arm of point A, m (default 0.17).

    Returns
    -------
    (str, dict)
    """
    if isinstance(params, HapticParams):
        return FMU_NAMES[params.structure], dict(params.values)
    if isinstance(params, ArmParams):
        arm = {"M": params.M, "k1": params.k1, "k2": params.k2}
        if device is None:
            return FMU_NAMES["arm_alone"], {**arm, "b1": params.b1, "b2": params.b2}
        dev = {k: float(device[k]) for k in ("m1", "b1", "bc", "kc", "m2", "b2")}
        return FMU_NAMES["arm"], {**dev, **arm, "b1a": params.b1, "b2a": params.b2, "r": r}
    raise TypeError(f"params must be HapticParams or ArmParams; got {type(params).__name__}")


def linearize_fmu(path, parameters=None, inputs=("tau",), output="phi", x0=None, u0=None, rel_step=1e-6):
    """Linearise an ME FMU by central finite differences: dx/dt = A x + B u, y = C x + D u.

    Parameters
    ----------
    path : path-like
        The FMU.
    parameters : dict, optional
        Parameter values to set before initialisation.
    inputs : sequence of str, optional
        Inputs to differentiate against (default ``("tau",)``); other inputs stay at 0.
    output : str, optional
        Output variable (default ``"phi"``).
    x0, u0 : array_like, optional
        Operating point (default: the initial states, zero inputs).
    rel_step : float, optional
        Step relative to max(1, |value|) (default 1e-6; the model is linear, so truncation error vanishes).

    Returns
    -------
    (A, B, C, D) : numpy.ndarray
        Shapes (n, n), (n, m), (1, n), (1, m).
    """
    from cosim.fmi import FmuInstance, derivatives

    with FmuInstance(path, name=Path(path).stem) as fmu:
        fmu.setup(parameters=parameters or {})
        n = fmu.n_states
        uport = fmu.port(list(inputs))
        yport = fmu.port([output])
        xbase = fmu.x.copy() if x0 is None else np.asarray(x0, dtype=float).copy()
        ubase = np.zeros(len(inputs)) if u0 is None else np.asarray(u0, dtype=float)

        def evaluate(x, u):
            uport.values[:] = u
            fmu.set(uport)
            dx = derivatives(fmu, 0.0, x)
            fmu.get(yport)
            return dx, float(yport.values[0])

        m = len(inputs)
        A = np.zeros((n, n))
        B = np.zeros((n, m))
        C = np.zeros((1, n))
        D = np.zeros((1, m))
        for i in range(n):
            h = rel_step * max(1.0, abs(xbase[i]))
            xp, xm = xbase.copy(), xbase.copy()
            xp[i] += h
            xm[i] -= h
            (fp, yp), (fm, ym) = evaluate(xp, ubase), evaluate(xm, ubase)
            A[:, i] = (fp - fm) / (2 * h)
            C[0, i] = (yp - ym) / (2 * h)
        for j in range(m):
            h = rel_step * max(1.0, abs(ubase[j]))
            up, um = ubase.copy(), ubase.copy()
            up[j] += h
            um[j] -= h
            (fp, yp), (fm, ym) = evaluate(xbase, up), evaluate(xbase, um)
            B[:, j] = (fp - fm) / (2 * h)
            D[0, j] = (yp - ym) / (2 * h)
    return A, B, C, D


def simulate_fmu(path, u, fs, parameters=None, input="tau", output="phi", substeps=4):
    """Drive an ME FMU with samples ``u`` held over each period 1/fs and return ``output`` at each sample.

    Parameters
    ----------
    path : path-like
    u : array_like, shape (n,)
        Input samples; ``u[k]`` acts on [k/fs, (k+1)/fs).
    fs : float
        Sample rate, Hz.
    parameters : dict, optional
    input, output : str, optional
        Variable names (defaults ``tau`` and ``phi``).
    substeps : int, optional
        RK4 steps per sample period (default 4).

    Returns
    -------
    numpy.ndarray, shape (n,)
        ``y[k]`` at t = k/fs, before ``u[k]`` acts (as a sampled encoder read at the start of the period).
    """
    from cosim.fmi import FmuInstance, rk4_steps

    u = np.asarray(u, dtype=float)
    h = 1.0 / fs / substeps
    y = np.empty(len(u))
    with FmuInstance(path, name=Path(path).stem) as fmu:
        fmu.setup(parameters=parameters or {})
        uport = fmu.port([input])
        yport = fmu.port([output])
        x = fmu.x.copy()
        for k in range(len(u)):
            t0 = k / fs
            fmu.set_time(t0)
            fmu.x[:] = x
            fmu.push_states()
            fmu.get(yport)
            y[k] = yport.values[0]
            uport.values[0] = u[k]
            fmu.set(uport)
            x = rk4_steps(fmu, t0, x, h, substeps)
    return y
