  package Diagnosis "Model variants written by cosim diagnose: the baseline plus one effect (docs/diagnose.md)"
    model Device11_vibration_mode "Device + user, 11-parameter form (seed 000 eq. 2, Fig. 5 top): stylus/skin ks, bs to a hand mass mh held by kh, bh"
      extends Device;
      parameter Real m3(unit = "kg.m2") = 0.0005 "Modal inertia of the second mode (effect vibration_mode)";
      parameter Real k3(unit = "N.m/rad") = 70.0 "Modal stiffness of the second mode (effect vibration_mode)";
      parameter Real b3(unit = "N.m.s/rad") = 0.01 "Modal damping of the second mode (effect vibration_mode)";
      parameter Real b2(unit = "N.m.s/rad") = 0.02 "Viscous friction of m2 to ground";
      parameter Real bs(unit = "N.m.s/rad") = 0.02 "Stylus/skin damping between m2 and the hand";
      parameter Real ks(unit = "N.m/rad") = 3.5 "Stylus/skin stiffness between m2 and the hand";
      parameter Real mh(unit = "kg.m2") = 0.0042 "Hand inertia at the phi axis";
      parameter Real bh(unit = "N.m.s/rad") = 0.1 "Damping of the hand to the user's reference";
      parameter Real kh(unit = "N.m/rad") = 2.3 "Stiffness of the hand to the user's reference";
      Real phih(unit = "rad", start = 0.0, fixed = true) "Hand angle";
      Real wh(unit = "rad/s", start = 0.0, fixed = true) "Hand angular velocity";
      Haptic.Effects.SideMode mode(m3 = m3, k3 = k3, b3 = b3) "Second vibration mode, hung on m1";
    equation
      mode.phi = phi1;
      mode.w = w1;
      tau_1 = tau + mode.tau;
      tau_b2 = b2*w2;
      tau_user = ks*(phih - phi2) + bs*(wh - w2);
      der(phih) = wh;
      mh*der(wh) = -tau_user - kh*(phih - phi_ref) - bh*wh + tau_h;
    end Device11_vibration_mode;
  end Diagnosis;
