package Haptic "PHANToM Premium 1.0 phi axis held by a user (Puerto et al. 2012, seed 000) and the Fu arm model (seed 001)"
  // Conventions (see docs/haptic.md):
  // - Rotational quantities at the phi axis: angles in rad, torques in N.m, inertias in kg.m2 (Table I prints
  //   g.m2: divide by 1000), dampings N.m.s/rad, stiffnesses N.m/rad.
  // - phi = 0 is the rest position of every spring; the user's grounded elements (kh, bh in the 11-parameter
  //   form, ks, bs in the 7-parameter form, k2, b2 of the arm) attach to a moving reference phi_ref (an input:
  //   the user's intended position, equilibrium-point style) and the hand can also push with an extra torque
  //   tau_h. With phi_ref = 0 and tau_h = 0 the models are exactly the paper's transfer functions (2), (9) and
  //   seed 001's (1).
  // - Effect slots (package Interfaces): in each concrete model the torque command reaches m1 through the
  //   replaceable delay (none by default) and a replaceable side mode hangs on m1 (none by default); Device7's
  //   user is the replaceable hand (the skin only by default). The discrepancy workflow's variants redeclare them
  //   with blocks of package Effects (docs/guide/diagnose.md). The slots are declared in the concrete models, not in
  //   Device: rumoca ignores a redeclare of an element the extended class inherits (docs/compiler.md).
  // - Default parameter values: user 1 at grasp position 3 (11 parameters) / 4 (7 parameters) of Table I,
  //   the nominal X-axis arm of seed 001 Table II. A config loads another row by setting the parameters.

  package Interfaces "Effect slots of the device models: what a block must take and give to fill a replaceable component"
    partial model DelaySlot "Path of the torque command from the controller to m1"
      input Real u(unit = "N.m") "Torque commanded";
      output Real y(unit = "N.m") "Torque applied";
    end DelaySlot;

    partial model ModeSlot "A structure hung on a device inertia"
      input Real phi(unit = "rad") "Angle of the inertia the mode hangs on";
      input Real w(unit = "rad/s") "Angular velocity of that inertia";
      output Real tau(unit = "N.m") "Torque of the mode on that inertia";
    end ModeSlot;

    partial model HandSlot "The user's hand on the stylus (m2)"
      input Real phi_s(unit = "rad") "Stylus angle (m2)";
      input Real w_s(unit = "rad/s") "Stylus angular velocity";
      input Real phi_ref(unit = "rad") "User's intended position";
      input Real tau_h(unit = "N.m") "Extra torque the hand applies (intent)";
      output Real tau(unit = "N.m") "Torque of the hand on the stylus";
      output Real tau_b(unit = "N.m") "Friction torque of the stylus to ground that the hand's model separates from the skin";
    end HandSlot;

    model NoDelay "The torque command acts at once (default of the slot delay)"
      extends DelaySlot;
    equation
      y = u;
    end NoDelay;

    model NoMode "No further vibration mode (default of the slot mode)"
      extends ModeSlot;
    equation
      tau = 0;
    end NoMode;

    model Skin "The 7-parameter user: m2 (hand lumped in) held by the skin ks, bs to the user's reference (default of Device7's slot hand)"
      extends HandSlot;
      parameter Real ks(unit = "N.m/rad", min = 0) = 1.6 "Stylus/skin stiffness of m2 to the user's reference";
      parameter Real bs(unit = "N.m.s/rad", min = 0) = 0.09 "Stylus/skin damping of m2 to the user's reference";
    equation
      tau = -ks*(phi_s - phi_ref) - bs*w_s + tau_h;
      tau_b = 0;
    end Skin;
  end Interfaces;

  package Effects "Candidate missing effects of the discrepancy workflow for the device + user (cosim diagnose, docs/guide/diagnose.md); each fills a slot of package Interfaces, and cosim.diagnose.effects writes the variants that redeclare the slot with it"
    model HandMass "The user's hand as an inertia mh held by kh, bh to the user's reference, gripping the stylus through the skin ks, bs (effect hand_mass: the 11-parameter user of seed 000 eq. 2, Fig. 5 top)"
      // Device7 lumps the hand into m2 and grounds it through ks, bs; this block puts the hand mass between the
      // skin and the user's reference, which adds the pole/zero pair of the hand (seed 000 Sec. II-D); the
      // 11-parameter form also separates the stylus's own viscous friction b2 to ground.
      extends Haptic.Interfaces.HandSlot;
      parameter Real mh(unit = "kg.m2", min = 0) = 0.005 "Hand inertia at the phi axis";
      parameter Real bh(unit = "N.m.s/rad", min = 0) = 0.2 "Damping of the hand to the user's reference";
      parameter Real kh(unit = "N.m/rad", min = 0) = 3 "Stiffness of the hand to the user's reference";
      parameter Real ks(unit = "N.m/rad", min = 0) = 3.5 "Stylus/skin stiffness between the stylus and the hand";
      parameter Real bs(unit = "N.m.s/rad", min = 0) = 0.02 "Stylus/skin damping between the stylus and the hand";
      parameter Real b2(unit = "N.m.s/rad", min = 0) = 0.02 "Viscous friction of the stylus (m2) to ground";
      Real phih(unit = "rad", start = 0.0, fixed = true) "Hand angle";
      Real wh(unit = "rad/s", start = 0.0, fixed = true) "Hand angular velocity";
    equation
      tau = ks*(phih - phi_s) + bs*(wh - w_s);
      der(phih) = wh;
      mh*der(wh) = -tau - kh*(phih - phi_ref) - bh*wh + tau_h;
      tau_b = b2*w_s;
    end HandMass;

    model SideMode "A second vibration mode of the device: an inertia m3 hung on a device inertia by the compliance k3, b3 (effect vibration_mode)"
      // Seen from the encoder, any further lightly damped structural mode (a link, the gimbal, the base) adds an
      // antiresonance/resonance pair; lumped here as a side resonator with its own frequency sqrt(k3/m3).
      extends Haptic.Interfaces.ModeSlot;
      parameter Real m3(unit = "kg.m2", min = 0) = 0.0005 "Modal inertia at the phi axis";
      parameter Real k3(unit = "N.m/rad", min = 0) = 70 "Modal stiffness";
      parameter Real b3(unit = "N.m.s/rad", min = 0) = 0.01 "Modal damping";
      Real phi3(unit = "rad", start = 0.0, fixed = true) "Modal angle";
      Real w3(unit = "rad/s", start = 0.0, fixed = true) "Modal angular velocity";
    equation
      tau = k3*(phi3 - phi) + b3*(w3 - w);
      der(phi3) = w3;
      m3*der(w3) = -tau;
    end SideMode;

    model PadeDelay "Pure delay exp(-s*T) of a torque by its third-order Pade approximation (effect loop_delay: computation and amplifier delay of the torque command)"
      // exp(-sT) ~ N(s)/D(s), D = 1 + sT/2 + (sT)^2/10 + (sT)^3/120, N(s) = D(-s): all-pass (|N/D| = 1 exactly),
      // phase within 0.1 deg of -wT up to wT = 2.1 rad, 1 deg at 3.1 rad (docs/guide/diagnose.md). Written as
      // N/D = 2 (1 + (sT)^2/10)/D - 1 with D(s) z = u. Needs T > 0.
      extends Haptic.Interfaces.DelaySlot;
      parameter Real T(unit = "s", min = 0) = 1e-3 "Delay";
      Real z(unit = "N.m", start = 0.0, fixed = true) "Filter state: D(s) z = u";
      Real dz(unit = "N.m/s", start = 0.0, fixed = true) "der(z)";
      Real ddz(unit = "N.m/s2", start = 0.0, fixed = true) "der(dz)";
    equation
      der(z) = dz;
      der(dz) = ddz;
      T^3/120*der(ddz) = u - z - T/2*dz - T^2/10*ddz;
      y = 2*(z + T^2/10*ddz) - u;
    end PadeDelay;
  end Effects;

  partial model Device "PHANToM phi axis: motor-side mass m1 and stylus-side mass m2 coupled by kc, bc; b1, b2 to ground"
    parameter Real m1(unit = "kg.m2", min = 0) = 0.0009 "Motor-side inertia (Table I m1)";
    parameter Real b1(unit = "N.m.s/rad", min = 0) = 0.04 "Viscous friction of m1 to ground";
    parameter Real bc(unit = "N.m.s/rad", min = 0) = 0.07 "Damping of the coupling m1-m2 (first vibration mode)";
    parameter Real kc(unit = "N.m/rad", min = 0) = 94 "Stiffness of the coupling m1-m2 (first vibration mode)";
    parameter Real m2(unit = "kg.m2", min = 0) = 0.0013 "Stylus-side inertia (with the lumped user in the 7-parameter form)";
    input Real tau(unit = "N.m") "Motor torque mapped to the phi axis";
    input Real phi_ref(unit = "rad") "User's intended position: reference of the user's grounded elements";
    input Real tau_h(unit = "N.m") "Extra torque the user's hand applies (intent)";
    output Real phi(unit = "rad") "Encoder angle (motor side, mapped to phi)";
    output Real w(unit = "rad/s") "Angular velocity of the motor side";
    output Real tau_user(unit = "N.m") "Torque the user applies on the stylus (on m2)";
    Real phi1(unit = "rad", start = 0.0, fixed = true) "Angle of m1";
    Real w1(unit = "rad/s", start = 0.0, fixed = true) "Angular velocity of m1";
    Real phi2(unit = "rad", start = 0.0, fixed = true) "Angle of m2 (stylus side)";
    Real w2(unit = "rad/s", start = 0.0, fixed = true) "Angular velocity of m2";
    Real tau_c(unit = "N.m") "Torque transmitted from m1 to m2 through kc, bc";
    Real tau_b2(unit = "N.m") "Friction torque of m2 to ground";
    Real tau_1(unit = "N.m") "Torque the drive applies to m1 (set by each concrete model through its slots delay and mode)";
  equation
    tau_c = kc*(phi1 - phi2) + bc*(w1 - w2);
    der(phi1) = w1;
    der(phi2) = w2;
    m1*der(w1) = tau_1 - b1*w1 - tau_c;
    m2*der(w2) = tau_c - tau_b2 + tau_user;
    phi = phi1;
    w = w1;
  end Device;

  model Device11 "Device + user, 11-parameter form (seed 000 eq. 2, Fig. 5 top): stylus/skin ks, bs to a hand mass mh held by kh, bh"
    extends Device;
    parameter Real b2(unit = "N.m.s/rad", min = 0) = 0.02 "Viscous friction of m2 to ground";
    parameter Real bs(unit = "N.m.s/rad", min = 0) = 0.02 "Stylus/skin damping between m2 and the hand";
    parameter Real ks(unit = "N.m/rad", min = 0) = 3.5 "Stylus/skin stiffness between m2 and the hand";
    parameter Real mh(unit = "kg.m2", min = 0) = 0.0042 "Hand inertia at the phi axis";
    parameter Real bh(unit = "N.m.s/rad", min = 0) = 0.1 "Damping of the hand to the user's reference";
    parameter Real kh(unit = "N.m/rad", min = 0) = 2.3 "Stiffness of the hand to the user's reference";
    Real phih(unit = "rad", start = 0.0, fixed = true) "Hand angle";
    Real wh(unit = "rad/s", start = 0.0, fixed = true) "Hand angular velocity";
    replaceable Haptic.Interfaces.NoDelay delay constrainedby Haptic.Interfaces.DelaySlot "Loop delay of the torque command (none)";
    replaceable Haptic.Interfaces.NoMode mode constrainedby Haptic.Interfaces.ModeSlot "Second vibration mode, hung on m1 (none)";
  equation
    delay.u = tau;
    mode.phi = phi1;
    mode.w = w1;
    tau_1 = delay.y + mode.tau;
    tau_b2 = b2*w2;
    tau_user = ks*(phih - phi2) + bs*(wh - w2);
    der(phih) = wh;
    mh*der(wh) = -tau_user - kh*(phih - phi_ref) - bh*wh + tau_h;
  end Device11;

  model Device7 "Device + user, 7-parameter form (seed 000 eq. 9, Fig. 5 bottom): m2 (hand lumped in) held by ks, bs"
    extends Device(m1 = 0.0008, m2 = 0.00295, b1 = 0.042, bc = 0.04, kc = 100);
    parameter Real bs(unit = "N.m.s/rad", min = 0) = 0.09 "Stylus/skin damping of m2 to the user's reference";
    parameter Real ks(unit = "N.m/rad", min = 0) = 1.6 "Stylus/skin stiffness of m2 to the user's reference";
    replaceable Haptic.Interfaces.Skin hand(ks = ks, bs = bs) constrainedby Haptic.Interfaces.HandSlot "The user's hand (the skin only)";
    replaceable Haptic.Interfaces.NoDelay delay constrainedby Haptic.Interfaces.DelaySlot "Loop delay of the torque command (none)";
    replaceable Haptic.Interfaces.NoMode mode constrainedby Haptic.Interfaces.ModeSlot "Second vibration mode, hung on m1 (none)";
  equation
    delay.u = tau;
    mode.phi = phi1;
    mode.w = w1;
    tau_1 = delay.y + mode.tau;
    hand.phi_s = phi2;
    hand.w_s = w2;
    hand.phi_ref = phi_ref;
    hand.tau_h = tau_h;
    tau_b2 = hand.tau_b;
    tau_user = hand.tau;
  end Device7;

  model DeviceArm "Device + the Fu arm (seed 001 eq. 1) at point A, r from the phi axis: grasp k1, b1 to the arm mass M held by k2, b2"
    extends Device;
    parameter Real b2(unit = "N.m.s/rad", min = 0) = 0.02 "Viscous friction of m2 to ground";
    parameter Real r(unit = "m", min = 0) = 0.17 "Distance from the phi axis to point A (gimbal centre)";
    parameter Real M(unit = "kg", min = 0) = 0.2179 "Arm mass";
    parameter Real k1(unit = "N/m", min = 0) = 379.5 "Grasp stiffness (stylus to arm mass)";
    parameter Real b1a(unit = "N.s/m", min = 0) = 1.839 "Grasp damping (stylus to arm mass); b1 of seed 001";
    parameter Real k2(unit = "N/m", min = 0) = 78.75 "Arm stiffness (arm mass to the user's reference)";
    parameter Real b2a(unit = "N.s/m", min = 0) = 4.645 "Arm damping (arm mass to ground); b2 of seed 001";
    Real xA(unit = "m") "Stylus position at point A (arc length r*phi2)";
    Real vA(unit = "m/s") "Stylus velocity at point A";
    Real xM(unit = "m", start = 0.0, fixed = true) "Arm mass position";
    Real vM(unit = "m/s", start = 0.0, fixed = true) "Arm mass velocity";
    Real F_grasp(unit = "N") "Force of the arm on the stylus at point A";
    replaceable Haptic.Interfaces.NoDelay delay constrainedby Haptic.Interfaces.DelaySlot "Loop delay of the torque command (none)";
    replaceable Haptic.Interfaces.NoMode mode constrainedby Haptic.Interfaces.ModeSlot "Second vibration mode, hung on m1 (none)";
  equation
    delay.u = tau;
    mode.phi = phi1;
    mode.w = w1;
    tau_1 = delay.y + mode.tau;
    tau_b2 = b2*w2;
    xA = r*phi2;
    vA = r*w2;
    F_grasp = k1*(xM - xA) + b1a*(vM - vA);
    tau_user = r*F_grasp;
    der(xM) = vM;
    M*der(vM) = -F_grasp - k2*(xM - r*phi_ref) - b2a*vM + tau_h/r;
  end DeviceArm;

  model Arm "Fu arm alone (seed 001 eq. 1): force at the stylus in, stylus position out; the stylus point is massless"
    parameter Real M(unit = "kg", min = 0) = 0.2179 "Arm mass";
    parameter Real k1(unit = "N/m", min = 0) = 379.5 "Grasp stiffness (stylus to arm mass)";
    parameter Real b1(unit = "N.s/m", min = 0) = 1.839 "Grasp damping (stylus to arm mass)";
    parameter Real k2(unit = "N/m", min = 0) = 78.75 "Arm stiffness (arm mass to ground)";
    parameter Real b2(unit = "N.s/m", min = 0) = 4.645 "Arm damping (arm mass to ground)";
    input Real F(unit = "N") "Force applied at the stylus (force sensor)";
    output Real x(unit = "m") "Stylus (gimbal centre) position";
    Real x1(unit = "m", start = 0.0, fixed = true) "Stylus point position";
    Real xM(unit = "m", start = 0.0, fixed = true) "Arm mass position";
    Real vM(unit = "m/s", start = 0.0, fixed = true) "Arm mass velocity";
  equation
    // massless stylus point: F = k1 (x1 - xM) + b1 (der(x1) - vM)
    b1*(der(x1) - vM) = F - k1*(x1 - xM);
    der(xM) = vM;
    M*der(vM) = F - k2*xM - b2*vM;
    x = x1;
  end Arm;
end Haptic;
