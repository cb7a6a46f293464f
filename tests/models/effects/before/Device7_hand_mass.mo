  package Diagnosis "Model variants written by cosim diagnose: the baseline plus one effect (docs/diagnose.md)"
    model Device7_hand_mass "Device + user, 7-parameter form (seed 000 eq. 9, Fig. 5 bottom): m2 (hand lumped in) held by ks, bs"
      extends Device(m1 = 0.0008, m2 = 0.00295, b1 = 0.042, bc = 0.04, kc = 100);
      parameter Real mh(unit = "kg.m2") = 0.006 "Hand inertia at the phi axis (effect hand_mass)";
      parameter Real kh(unit = "N.m/rad") = 3.0 "Stiffness of the hand to the user's reference (effect hand_mass)";
      parameter Real bh(unit = "N.m.s/rad") = 0.2 "Damping of the hand to the user's reference (effect hand_mass)";
      parameter Real b2(unit = "N.m.s/rad") = 0.02 "Viscous friction of m2 to ground (effect hand_mass)";
      parameter Real bs(unit = "N.m.s/rad") = 0.09 "Stylus/skin damping of m2 to the user's reference";
      parameter Real ks(unit = "N.m/rad") = 1.6 "Stylus/skin stiffness of m2 to the user's reference";
      Haptic.Effects.HandMass hand(mh = mh, kh = kh, bh = bh, ks = ks, bs = bs) "Hand mass behind the skin";
    equation
      tau_1 = tau;
      tau_b2 = b2*w2;
      hand.phi_s = phi2;
      hand.w_s = w2;
      hand.phi_ref = phi_ref;
      hand.tau_h = tau_h;
      tau_user = hand.tau;
    end Device7_hand_mass;
  end Diagnosis;
