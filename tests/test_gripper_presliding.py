"""The presliding damping of the gripper's bristle friction (``Gripper.Components.BristleFriction``, ``d_pre``)
against the closed form of a damped linear oscillator.

A rotor of inertia J held only by the bristle, started with a speed small enough that the bristle stays in its
elastic range (|s| < s_ba, so alpha = 0 and ds/dt = w/(phi_b + |w| tau_b) ~ w/phi_b), is a linear oscillator of
stiffness k = T_c/phi_b and damping c = d_pre (the fade-out factor exp(-(w/w_pre)^2) is 1 - 1e-4 at these
speeds): w(t) = w0 exp(-zeta wn t) (cos wd t - zeta/sqrt(1 - zeta^2) sin wd t), wn = sqrt(k/J),
zeta = c/(2 sqrt(kJ)), wd = wn sqrt(1 - zeta^2). The Modelica source is lowered as shipped and integrated by
scipy's Radau; without d_pre the ring does not decay.
"""

import shutil

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.integrate import solve_ivp

from cosim.compile import lower
from modelica_support import write_package
from test_gripper_support import ROOT

T_C, PHI_B, J, W0 = 7.88e-3, 1e-3, 1e-5, 0.01


@pytest.fixture(scope="module")
def ring(tmp_path_factory):
    """The rotor on the bristle, lowered from a test package beside a copy of the shipped Gripper package."""
    folder = tmp_path_factory.mktemp("presliding")
    shutil.copy(ROOT / "modelica" / "Gripper" / "package.mo", folder / "Gripper.mo")
    path = write_package(folder, f"""
        model Ring "A rotor held by the motor-side bristle friction alone"
          parameter Real d_pre = 0;
          Gripper.Components.BristleFriction f(T_c = {T_C}, phi_b = {PHI_B}, tau_b = 1e-4, s_ba = 0.5, d_pre = d_pre, w_pre = 1);
          Real phi(start = 0, fixed = true);
          Real w(start = {W0}, fixed = true);
        equation
          der(phi) = w;
          {J}*der(w) = -f.tau_f;
          f.w = w;
        end Ring;
    """)
    return lower(path, "T.Ring")


def _simulate(model, d_pre, t):
    p = model.parameter_values
    p[model.index("parameters", "d_pre")] = d_pre
    x0 = model.initial_state(p)
    sol = solve_ivp(lambda _, x: model.derivatives(x, [], p), (0.0, t[-1]), x0, method="Radau", t_eval=t,
                    rtol=1e-10, atol=1e-12)
    return sol.y[[s.name for s in model.states].index("w")]


@pytest.mark.parametrize("zeta", [0.1, 0.5])
def test_presliding_damping_rings_down_as_a_damped_oscillator(ring, zeta):
    k = T_C / PHI_B
    wn = np.sqrt(k / J)
    d_pre = 2 * zeta * np.sqrt(k * J)
    t = np.linspace(0.0, 6 * 2 * np.pi / wn, 600)
    wd = wn * np.sqrt(1 - zeta ** 2)
    expected = W0 * np.exp(-zeta * wn * t) * (np.cos(wd * t) - zeta / np.sqrt(1 - zeta ** 2) * np.sin(wd * t))
    # 1 % of w0: the bristle's rate is w/(phi_b + |w| tau_b), 0.1 % softer than the linear spring at w0
    assert_allclose(_simulate(ring, d_pre, t), expected, atol=0.01 * W0)


def test_without_presliding_damping_the_ring_does_not_decay(ring):
    wn = np.sqrt(T_C / PHI_B / J)
    t = np.linspace(0.0, 20 * 2 * np.pi / wn, 4000)
    w = _simulate(ring, 0.0, t)
    assert_allclose(np.max(np.abs(w[t > t[-1] - 2 * np.pi / wn])), W0, rtol=0.01)
