  package Diagnosis "Model variants written by cosim diagnose: the baseline plus one effect (docs/diagnose.md)"
    model GripperCurrentDriven_cogging "Whole gripper in current mode with an ideal current loop: the q current is the input (calibration and diagnosis of slow experiments)"
      // The FOC current loop (bandwidth ~1 kHz) is much faster than a 5 s current step, so for the static test the
      // electrical dynamics reduce to i_q = i_ref and the air-gap torque to k_t*i_ref.
      extends Gripper.Parameters.MotorParameters;
      extends Gripper.Parameters.DrivetrainParameters;
      parameter Real T_cog(unit = "N.m") = 0.002 "Cogging torque amplitude (effect cogging)";
      parameter Real phase_cog(unit = "rad") = 0.0 "Cogging phase at theta = 0 (effect cogging)";
      input Real i_ref(unit = "A") "q-axis current held by the current loop";
      output Real theta_m(unit = "rad") "Motor shaft angle";
      output Real w_m(unit = "rad/s") "Motor shaft speed";
      output Real x_jaw(unit = "m") "Jaw displacement, positive closing";
      output Real F_g(unit = "N") "Gripping force (load cell)";
      Real phi(unit = "rad", start = 0.0, fixed = true) "Motor shaft angle";
      Real w(unit = "rad/s", start = 0.0, fixed = true) "Motor shaft speed";
      Gripper.DrivetrainMechanics drive(ratio = ratio, eta_g = eta_g, T_max = T_max, omega_max = omega_max, B_g = B_g, T_c0 = T_c0, phi_b = phi_b, tau_b = tau_b, s_ba = s_ba, d_pre = d_pre, w_pre = w_pre, play = play, c_play = c_play, d_play = d_play, r_p = r_p, J_p = J_p, m_jf = m_jf, eta_grease = eta_grease, S_i = S_i, d_grease = d_grease, F_cj = F_cj, v_s = v_s, gap0 = gap0, t_coat = t_coat, k_f = k_f, k_obj = k_obj, k_P = k_P, k_H_ratio = k_H_ratio, d_lim = d_lim, C_p = C_p, C_h = C_h, w_tr = w_tr) "Gear, jaws and contacts";
    Gripper.Effects.CoggingTorque cog(T_cog = T_cog, phase = phase_cog) "Motor cogging";
    equation
      der(phi) = w;
      cog.theta = phi;
      (J_r + J_g)*der(w) = k_t*i_ref - B_r*w - drive.tau_load - cog.tau;
      drive.theta_m = phi;
      drive.w_m = w;
      theta_m = phi;
      w_m = w;
      x_jaw = drive.x_jaw;
      F_g = drive.F_g;
    end GripperCurrentDriven_cogging;
  end Diagnosis;
