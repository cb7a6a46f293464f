  package Diagnosis "Model variants written by cosim diagnose: the baseline plus one effect (docs/diagnose.md)"
    model Device11_loop_delay "Device + user, 11-parameter form (seed 000 eq. 2, Fig. 5 top): stylus/skin ks, bs to a hand mass mh held by kh, bh"
      extends Device;
      parameter Real T_d(unit = "s") = 0.001 "Delay of the torque command (effect loop_delay)";
      parameter Real b2(unit = "N.m.s/rad") = 0.02 "Viscous friction of m2 to ground";
      parameter Real bs(unit = "N.m.s/rad") = 0.02 "Stylus/skin damping between m2 and the hand";
      parameter Real ks(unit = "N.m/rad") = 3.5 "Stylus/skin stiffness between m2 and the hand";
      parameter Real mh(unit = "kg.m2") = 0.0042 "Hand inertia at the phi axis";
      parameter Real bh(unit = "N.m.s/rad") = 0.1 "Damping of the hand to the user's reference";
      parameter Real kh(unit = "N.m/rad") = 2.3 "Stiffness of the hand to the user's reference";
      Real phih(unit = "rad", start = 0.0, fixed = true) "Hand angle";
      Real wh(unit = "rad/s", start = 0.0, fixed = true) "Hand angular velocity";
      Haptic.Effects.PadeDelay delay(T = T_d) "Loop delay of the torque command";
    equation
      delay.u = tau;
      tau_1 = delay.y;
      tau_b2 = b2*w2;
      tau_user = ks*(phih - phi2) + bs*(wh - w2);
      der(phih) = wh;
      mh*der(wh) = -tau_user - kh*(phih - phi_ref) - bh*wh + tau_h;
    end Device11_loop_delay;
  end Diagnosis;
