  package Diagnosis "Model variants written by cosim diagnose: the baseline plus one effect (docs/diagnose.md)"
    model DeviceArm_loop_delay "Device + the Fu arm (seed 001 eq. 1) at point A, r from the phi axis: grasp k1, b1 to the arm mass M held by k2, b2"
      extends Device;
      parameter Real T_d(unit = "s") = 0.001 "Delay of the torque command (effect loop_delay)";
      parameter Real b2(unit = "N.m.s/rad") = 0.02 "Viscous friction of m2 to ground";
      parameter Real r(unit = "m") = 0.17 "Distance from the phi axis to point A (gimbal centre)";
      parameter Real M(unit = "kg") = 0.2179 "Arm mass";
      parameter Real k1(unit = "N/m") = 379.5 "Grasp stiffness (stylus to arm mass)";
      parameter Real b1a(unit = "N.s/m") = 1.839 "Grasp damping (stylus to arm mass); b1 of seed 001";
      parameter Real k2(unit = "N/m") = 78.75 "Arm stiffness (arm mass to the user's reference)";
      parameter Real b2a(unit = "N.s/m") = 4.645 "Arm damping (arm mass to ground); b2 of seed 001";
      Real xA(unit = "m") "Stylus position at point A (arc length r*phi2)";
      Real vA(unit = "m/s") "Stylus velocity at point A";
      Real xM(unit = "m", start = 0.0, fixed = true) "Arm mass position";
      Real vM(unit = "m/s", start = 0.0, fixed = true) "Arm mass velocity";
      Real F_grasp(unit = "N") "Force of the arm on the stylus at point A";
      Haptic.Effects.PadeDelay delay(T = T_d) "Loop delay of the torque command";
    equation
      delay.u = tau;
      tau_1 = delay.y;
      tau_b2 = b2*w2;
      xA = r*phi2;
      vA = r*w2;
      F_grasp = k1*(xM - xA) + b1a*(vM - vA);
      tau_user = r*F_grasp;
      der(xM) = vM;
      M*der(vM) = -F_grasp - k2*(xM - r*phi_ref) - b2a*vM + tau_h/r;
    end DeviceArm_loop_delay;
  end Diagnosis;
