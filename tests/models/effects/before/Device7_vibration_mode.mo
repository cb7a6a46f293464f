  package Diagnosis "Model variants written by cosim diagnose: the baseline plus one effect (docs/diagnose.md)"
    model Device7_vibration_mode "Device + user, 7-parameter form (seed 000 eq. 9, Fig. 5 bottom): m2 (hand lumped in) held by ks, bs"
      extends Device(m1 = 0.0008, m2 = 0.00295, b1 = 0.042, bc = 0.04, kc = 100);
      parameter Real m3(unit = "kg.m2") = 0.0005 "Modal inertia of the second mode (effect vibration_mode)";
      parameter Real k3(unit = "N.m/rad") = 70.0 "Modal stiffness of the second mode (effect vibration_mode)";
      parameter Real b3(unit = "N.m.s/rad") = 0.01 "Modal damping of the second mode (effect vibration_mode)";
      parameter Real bs(unit = "N.m.s/rad") = 0.09 "Stylus/skin damping of m2 to the user's reference";
      parameter Real ks(unit = "N.m/rad") = 1.6 "Stylus/skin stiffness of m2 to the user's reference";
      Haptic.Effects.SideMode mode(m3 = m3, k3 = k3, b3 = b3) "Second vibration mode, hung on m1";
    equation
      mode.phi = phi1;
      mode.w = w1;
      tau_1 = tau + mode.tau;
      tau_b2 = 0;
      tau_user = -ks*(phi2 - phi_ref) - bs*w2 + tau_h;
    end Device7_vibration_mode;
  end Diagnosis;
