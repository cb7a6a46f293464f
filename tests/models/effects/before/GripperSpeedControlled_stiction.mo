  package Diagnosis "Model variants written by cosim diagnose: the baseline plus one effect (docs/diagnose.md)"
    model DrivetrainMechanics_stiction "Motor-side drag, gear mesh loss, 28:1 gear, bearing damping, play, rack-and-pinion, jaws, guide friction, contacts"
      extends Gripper.Parameters.DrivetrainParameters;
      parameter Real F_sj(unit = "N") = 1.0 "Static (breakaway) guide friction per jaw (effect stiction)";
      input Real theta_m(unit = "rad") "Motor shaft angle";
      input Real w_m(unit = "rad/s") "Motor shaft speed";
      output Real tau_load(unit = "N.m") "Load torque on the motor shaft, against positive rotation";
      output Real F_g(unit = "N") "Gripping force (load cell)";
      output Real x_jaw(unit = "m") "Jaw displacement, positive closing";
      Gripper.Components.BristleFriction drag(T_c = T_c0, phi_b = phi_b, tau_b = tau_b, s_ba = s_ba, d_pre = d_pre, w_pre = w_pre) "No-load drag at the motor shaft";
      Gripper.Components.MeshEfficiency mesh(eta = eta_g, phi_b = phi_b, tau_b = tau_b, s_ba = s_ba) "Gear efficiency by power-flow direction";
      Gripper.Components.IdealGear gear(ratio = ratio) "Planetary gear kinematics";
      Gripper.Components.RotationalDamper bearing(d = B_g) "Gear bearing damping at the output";
      Gripper.Components.ElastoBacklash backlash(b = play, c = c_play, d = d_play) "Gear shaft play";
      Gripper.Components.RackPinion rack(r_p = r_p, n = 2) "Pinion driving both racks";
      Gripper.Components.JawMass jaw(m = m_jf + J_p/(2*r_p^2)) "One jaw with half the pinion inertia";
      Gripper.Components.GreaseViscous grease(eta = eta_grease, S = S_i, d = d_grease, n_s = 4) "Grease on the 4 guide surfaces";
      Gripper.Effects.StribeckGuide guide(F_c = F_cj, F_s = F_sj) "Guide Coulomb friction";
      Gripper.Components.FingerContact contact(gap0 = gap0, t_coat = t_coat, k_f = k_f, k_obj = k_obj, k_P = k_P, k_H_ratio = k_H_ratio, d_lim = d_lim, C_p = C_p, C_h = C_h, w_tr = w_tr) "Finger, coating and object";
    equation
      // motor shaft -> drag and mesh loss -> ideal gear -> bearing + play -> pinion -> jaws
      drag.w = w_m;
      mesh.w = w_m;
      gear.phi_in = theta_m;
      gear.w_in = w_m;
      bearing.w = gear.w_out;
      backlash.phi_rel = gear.phi_out - rack.phi;
      backlash.w_rel = gear.w_out - rack.w;
      gear.tau_load_out = backlash.tau + bearing.tau;
      mesh.tau_out = gear.tau_load_in;
      tau_load = gear.tau_load_in + mesh.tau_f + drag.tau_f;
      rack.tau = backlash.tau;
      rack.x = jaw.x;
      rack.v = jaw.v;
      grease.v = jaw.v;
      guide.v = jaw.v;
      contact.x = jaw.x;
      contact.v = jaw.v;
      jaw.F = rack.F - grease.F - guide.F - contact.F;
      F_g = contact.F;
      x_jaw = jaw.x;
    end DrivetrainMechanics_stiction;
    model GripperSpeedControlled_stiction "Whole gripper under a PI speed loop around an ideal current loop: the speed reference is the input (diagnosis of cogging at slow, steady motion)"
      // An identification run, not the paper's 100 Hz velocity PID: a continuous PI of ~30 Hz bandwidth holds slow
      // speeds, so a torque periodic in the rotor angle shows as a ripple of the current it takes (docs/diagnose.md).
      extends Gripper.Parameters.MotorParameters;
      extends Gripper.Parameters.DrivetrainParameters;
      parameter Real F_sj(unit = "N") = 1.0 "Static (breakaway) guide friction per jaw (effect stiction)";
      parameter Real K_pw(unit = "A.s/rad") = 0.05 "Speed loop proportional gain";
      parameter Real K_iw(unit = "A/rad") = 2.5 "Speed loop integral gain";
      input Real w_ref(unit = "rad/s") "Motor speed reference";
      output Real i_q(unit = "A") "q-axis current held by the current loop";
      output Real theta_m(unit = "rad") "Motor shaft angle";
      output Real w_m(unit = "rad/s") "Motor shaft speed";
      output Real x_jaw(unit = "m") "Jaw displacement, positive closing";
      output Real F_g(unit = "N") "Gripping force (load cell)";
      Real phi(unit = "rad", start = 0.0, fixed = true) "Motor shaft angle";
      Real w(unit = "rad/s", start = 0.0, fixed = true) "Motor shaft speed";
      Real e_w(unit = "rad", start = 0.0, fixed = true) "Integral of the speed error";
      Real i_ref(unit = "A") "q current the speed loop asks for";
      Gripper.Diagnosis.DrivetrainMechanics_stiction drive(F_sj = F_sj, ratio = ratio, eta_g = eta_g, T_max = T_max, omega_max = omega_max, B_g = B_g, T_c0 = T_c0, phi_b = phi_b, tau_b = tau_b, s_ba = s_ba, d_pre = d_pre, w_pre = w_pre, play = play, c_play = c_play, d_play = d_play, r_p = r_p, J_p = J_p, m_jf = m_jf, eta_grease = eta_grease, S_i = S_i, d_grease = d_grease, F_cj = F_cj, v_s = v_s, gap0 = gap0, t_coat = t_coat, k_f = k_f, k_obj = k_obj, k_P = k_P, k_H_ratio = k_H_ratio, d_lim = d_lim, C_p = C_p, C_h = C_h, w_tr = w_tr) "Gear, jaws and contacts";
    equation
      der(phi) = w;
      (J_r + J_g)*der(w) = k_t*i_ref - B_r*w - drive.tau_load;
      der(e_w) = w_ref - w;
      i_ref = K_pw*(w_ref - w) + K_iw*e_w;
      i_q = i_ref;
      drive.theta_m = phi;
      drive.w_m = w;
      theta_m = phi;
      w_m = w;
      x_jaw = drive.x_jaw;
      F_g = drive.F_g;
    end GripperSpeedControlled_stiction;
  end Diagnosis;
