  package Diagnosis "Model variants written by cosim diagnose: the baseline plus one effect (docs/diagnose.md)"
    model Device7_loop_delay "Device + user, 7-parameter form (seed 000 eq. 9, Fig. 5 bottom): m2 (hand lumped in) held by ks, bs"
      extends Device(m1 = 0.0008, m2 = 0.00295, b1 = 0.042, bc = 0.04, kc = 100);
      parameter Real T_d(unit = "s") = 0.001 "Delay of the torque command (effect loop_delay)";
      parameter Real bs(unit = "N.m.s/rad") = 0.09 "Stylus/skin damping of m2 to the user's reference";
      parameter Real ks(unit = "N.m/rad") = 1.6 "Stylus/skin stiffness of m2 to the user's reference";
      Haptic.Effects.PadeDelay delay(T = T_d) "Loop delay of the torque command";
    equation
      delay.u = tau;
      tau_1 = delay.y;
      tau_b2 = 0;
      tau_user = -ks*(phi2 - phi_ref) - bs*w2 + tau_h;
    end Device7_loop_delay;
  end Diagnosis;
