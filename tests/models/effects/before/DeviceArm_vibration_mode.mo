  package Diagnosis "Model variants written by cosim diagnose: the baseline plus one effect (docs/diagnose.md)"
    model DeviceArm_vibration_mode "Device + the Fu arm (seed 001 eq. 1) at point A, r from the phi axis: grasp k1, b1 to the arm mass M held by k2, b2"
      extends Device;
      parameter Real m3(unit = "kg.m2") = 0.0005 "Modal inertia of the second mode (effect vibration_mode)";
      parameter Real k3(unit = "N.m/rad") = 70.0 "Modal stiffness of the second mode (effect vibration_mode)";
      parameter Real b3(unit = "N.m.s/rad") = 0.01 "Modal damping of the second mode (effect vibration_mode)";
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
      Haptic.Effects.SideMode mode(m3 = m3, k3 = k3, b3 = b3) "Second vibration mode, hung on m1";
    equation
      mode.phi = phi1;
      mode.w = w1;
      tau_1 = tau + mode.tau;
      tau_b2 = b2*w2;
      xA = r*phi2;
      vA = r*w2;
      F_grasp = k1*(xM - xA) + b1a*(vM - vA);
      tau_user = r*F_grasp;
      der(xM) = vM;
      M*der(vM) = -F_grasp - k2*(xM - r*phi_ref) - b2a*vM + tau_h/r;
    end DeviceArm_vibration_mode;
  end Diagnosis;
