package Gripper "Electric gripper of Sec. 2-3 of the gripper paper: PMSM, 28:1 planetary gear with efficiency and play, rack-and-pinion jaws, coated finger contacts"
  // Conventions (see docs/models/gripper.md):
  // - Positive motor rotation closes the jaws; x (jaw displacement) is positive towards the object.
  // - Components are causal blocks (inputs/outputs) wired by explicit equations. Acausal flanges would
  //   need either speed in the connector (rumoca rejects it: unbalanced connector) or der(phi) in each
  //   element (redundant states through rigid couplings, hence index reduction). With blocks, only the
  //   rigid bodies (PMSM rotor with the gear input, jaw mass) and internal states (bristles) use der().
  // - Torques and forces named tau_load / tau_f / F act against positive motion unless stated.
  // - d-q quantities use the power-invariant Park transform: T = P*(Psi_m*i_q + (L_d - L_q)*i_d*i_q),
  //   k_t = P*Psi_m, electrical power v_d*i_d + v_q*i_q.

  package Interfaces "Effect slots: what a block must take and give to fill a replaceable component of the models (docs/models/gripper.md); the default of each slot is today's law or a block that does nothing, cosim diagnose redeclares it with a block of Effects"
    partial model DriveFrictionSlot "Friction of the drive at the motor shaft (the motor's and the gear's no-load drag)"
      parameter Real T_c(unit = "N.m", min = 0) = 7.88e-3 "Coulomb friction torque level";
      parameter Real phi_b(unit = "rad", min = 0) = 1e-3 "Presliding angle (bristle deflection at the Coulomb level)";
      parameter Real tau_b(unit = "s", min = 0) = 1e-4 "Bristle relaxation time at high speed (bounds the state's rate)";
      parameter Real s_ba(unit = "1", min = 0, max = 1) = 0.5 "Elastic fraction of the bristle range";
      parameter Real d_pre(unit = "N.m.s/rad", min = 0) = 0 "Presliding damping (LuGre's sigma_1), faded out above w_pre; 0: none";
      parameter Real w_pre(unit = "rad/s", min = 0) = 1 "Speed scale above which the presliding damping fades out";
      input Real w(unit = "rad/s") "Shaft speed relative to the housing";
      output Real tau_f(unit = "N.m") "Friction torque against the motion";
    end DriveFrictionSlot;

    partial model MeshSlot "Gear mesh loss at the gear input"
      input Real w(unit = "rad/s") "Input shaft speed";
      input Real tau_out(unit = "N.m") "Torque passed on towards the load, in input-side units";
      output Real tau_f(unit = "N.m") "Loss torque against the motion (added to the input torque)";
    end MeshSlot;

    partial model GuideSlot "Jaw-guide friction"
      parameter Real F_c(unit = "N", min = 0) = 0.0785 "Coulomb (sliding) friction level";
      parameter Real v_s(unit = "m/s", min = 0) = 1e-4 "Regularisation velocity at rest (a law that holds its friction by a bristle ignores it)";
      input Real v(unit = "m/s") "Jaw velocity, positive closing";
      output Real F(unit = "N") "Friction force against the motion";
    end GuideSlot;

    partial model LoadFrictionSlot "Jaw-guide friction that depends on the gripping force, on top of the guide friction"
      input Real v(unit = "m/s") "Jaw velocity, positive closing";
      input Real F_n(unit = "N") "Gripping (normal) force";
      output Real F(unit = "N") "Friction force against the motion";
    end LoadFrictionSlot;

    partial model ContactSlot "Finger contact on the object"
      input Real x(unit = "m") "Jaw displacement, positive closing";
      input Real v(unit = "m/s") "Jaw velocity, positive closing";
      output Real F(unit = "N") "Contact (gripping) force, >= 0";
      output Real delta_c(unit = "m") "Coating deflection";
    end ContactSlot;

    partial model CoggingSlot "Torque on the rotor periodic in its angle"
      input Real theta(unit = "rad") "Rotor angle";
      output Real tau(unit = "N.m") "Cogging torque against positive rotation";
    end CoggingSlot;

    partial model LoadCellSlot "Load cell between the gripping force and the measured force"
      input Real F(unit = "N") "True force";
      output Real F_meas(unit = "N") "Force the load cell reports";
    end LoadCellSlot;
  end Interfaces;

  package Components "One physical effect per block; blocks are wired by explicit equations (see the header note)"
    model PMSM "Permanent magnet synchronous motor in the rotor d-q frame with its rotor, eqs. (3)-(7), power-invariant Park transform"
      parameter Real R_s(unit = "Ohm", min = 0) = 0.45 "Stator phase resistance";
      parameter Real L_d(unit = "H", min = 0) = 2.5e-4 "d-axis inductance";
      parameter Real L_q(unit = "H", min = 0) = 2.5e-4 "q-axis inductance";
      parameter Integer p = 4 "Number of pole pairs";
      parameter Real Psi_m(unit = "Wb", min = 0) = 0.009848 "Permanent magnet flux linkage (k_t = p*Psi_m)";
      parameter Real J(unit = "kg.m2", min = 0) = 1.01e-5 "Inertia of the rotor and of everything rigidly attached to it";
      parameter Real B_r(unit = "N.m.s/rad", min = 0) = 1.01e-5 "Rotor viscous damping, eq. (6)";
      input Real v_d(unit = "V") "d-axis stator voltage";
      input Real v_q(unit = "V") "q-axis stator voltage";
      input Real tau_load(unit = "N.m") "Load torque on the shaft, against positive rotation";
      Real i_d(unit = "A", start = 0.0, fixed = true) "d-axis stator current";
      Real i_q(unit = "A", start = 0.0, fixed = true) "q-axis stator current";
      Real phi(unit = "rad", start = 0.0, fixed = true) "Mechanical rotor angle";
      Real w(unit = "rad/s", start = 0.0, fixed = true) "Mechanical rotor speed";
      Real tau_e(unit = "N.m") "Electromagnetic (air-gap) torque, eq. (5)";
    equation
      L_d*der(i_d) = v_d - R_s*i_d + p*w*L_q*i_q;
      L_q*der(i_q) = v_q - R_s*i_q - p*w*(L_d*i_d + Psi_m);
      tau_e = p*(Psi_m*i_q + (L_d - L_q)*i_d*i_q);
      der(phi) = w;
      J*der(w) = tau_e - B_r*w - tau_load;
    end PMSM;

    function bristleRate "Rate of a normalised elasto-plastic bristle state (Dupont et al. 2002), rate-limited"
      // ds/dt = (w - alpha(s, w)*|w|*s)/(phi_b + |w|*tau_b). alpha = 0 while the bristle unloads (s*w <= 0)
      // or stays within the elastic fraction s_ba of its range: a pure spring there, so small oscillations
      // about a held load trace closed loops and do not ratchet (a Dahl/LuGre bristle drifts). alpha rises
      // smoothly to 1 at |s| = 1, so steady sliding gives s = sign(w). The rate is bounded by about 4/tau_b.
      input Real w(unit = "rad/s") "Sliding speed";
      input Real s(unit = "1") "Normalised bristle deflection";
      input Real phi_b(unit = "rad") "Presliding angle at the Coulomb level";
      input Real tau_b(unit = "s") "Bristle relaxation time at high speed";
      input Real s_ba(unit = "1") "Elastic (breakaway) fraction of the bristle range, 0 <= s_ba < 1";
      output Real ds(unit = "1/s") "Time derivative of s";
    protected
      Real a(unit = "1") "Absolute deflection";
      Real alpha(unit = "1") "Plastic fraction of the motion";
    algorithm
      a := abs(s);
      alpha := noEvent(if s*w <= 0 then 0 else if a <= s_ba then 0 else if a >= 1 then 1 else 0.5 + 0.5*sin(3.14159265358979*(a - 0.5*(1 + s_ba))/(1 - s_ba)));
      ds := (w - alpha*abs(w)*s)/(phi_b + abs(w)*tau_b);
    end bristleRate;

    model BristleFriction "Coulomb friction carried by an elasto-plastic bristle state: holds a static torque without creep or drift (default of the slot drag)"
      extends Gripper.Interfaces.DriveFrictionSlot;
      Real s(unit = "1", start = 0.0, fixed = true) "Normalised bristle deflection, in [-1, 1]";
      Real ds(unit = "1/s") "Rate of the bristle deflection";
    equation
      // The bristle alone is a lossless spring in presliding: a shaft held on it rings at sqrt(k/J) with only the
      // rotor's viscous loss to damp it. d_pre*phi_b*ds is the bristle damping (sigma_1*dz/dt) of LuGre (Canudas
      // de Wit et al. 1995): d_pre*w in presliding, nothing at rest nor in steady sliding (ds = 0 there); the
      // factor exp(-(w/w_pre)^2) keeps it out of fast reversals (Olsson's velocity-dependent sigma_1).
      ds = Gripper.Components.bristleRate(w, s, phi_b, tau_b, s_ba);
      der(s) = ds;
      tau_f = T_c*s + d_pre*phi_b*ds*exp(-(w/w_pre)^2);
    end BristleFriction;

    model MeshEfficiency "Gear mesh loss: efficiency eta by the direction of power flow, held by an elasto-plastic bristle (input side)"
      // A loss torque at the gear input of Coulomb type whose level is (1 - eta)*N with
      // N = max(|tau_in|, |tau_out|): driving gives tau_out = eta*tau_in, back-driving gives
      // tau_in = eta*tau_out, and at standstill any tau_in between eta*tau_out and tau_out/eta is held
      // (the stuck mode of Modelica's LossyGear). tau_in = tau_out + tau_f.
      extends Gripper.Interfaces.MeshSlot;
      parameter Real eta(unit = "1", min = 0, max = 1) = 0.68 "Mesh efficiency";
      parameter Real phi_b(unit = "rad", min = 0) = 1e-3 "Presliding angle of the mesh bristle (input side)";
      parameter Real tau_b(unit = "s", min = 0) = 1e-4 "Bristle relaxation time at high speed";
      parameter Real s_ba(unit = "1", min = 0, max = 1) = 0.5 "Elastic fraction of the bristle range";
      Real s(unit = "1", start = 0.0, fixed = true) "Normalised bristle deflection, in [-1, 1]";
      Real N(unit = "N.m") "Transmitted load max(|tau_in|, |tau_out|)";
    equation
      N = noEvent(if s*tau_out > 0 then abs(tau_out)/(1 - (1 - eta)*abs(s)) else abs(tau_out));
      der(s) = Gripper.Components.bristleRate(w, s, phi_b, tau_b, s_ba);
      tau_f = (1 - eta)*N*s;
    end MeshEfficiency;

    model IdealGear "Ideal reduction gear kinematics and statics, no inertia and no loss"
      parameter Real ratio(unit = "1", min = 0) = 28 "Reduction ratio input speed / output speed";
      input Real phi_in(unit = "rad") "Input angle";
      input Real w_in(unit = "rad/s") "Input speed";
      input Real tau_load_out(unit = "N.m") "Load torque at the output";
      output Real phi_out(unit = "rad") "Output angle";
      output Real w_out(unit = "rad/s") "Output speed";
      output Real tau_load_in(unit = "N.m") "Load torque referred to the input";
    equation
      phi_out = phi_in/ratio;
      w_out = w_in/ratio;
      tau_load_in = tau_load_out/ratio;
    end IdealGear;

    model RotationalDamper "Viscous damper to the housing"
      parameter Real d(unit = "N.m.s/rad", min = 0) = 0.05191 "Damping coefficient";
      input Real w(unit = "rad/s") "Shaft speed";
      output Real tau(unit = "N.m") "Damping torque against the motion";
    equation
      tau = d*w;
    end RotationalDamper;

    model ElastoBacklash "Shaft play as an elastic-damped hard stop, force-continuous at contact (cf. MSL ElastoBacklash)"
      parameter Real b(unit = "rad", min = 0) = 0.013962634 "Total play (torque is zero for |phi_rel| <= b/2)";
      parameter Real c(unit = "N.m/rad", min = 0) = 1000 "Stiffness at the stops";
      parameter Real d(unit = "N.m.s/rad", min = 0) = 0.05 "Damping at the stops (limited so that it cannot pull)";
      input Real phi_rel(unit = "rad") "Driving-side angle minus driven-side angle";
      input Real w_rel(unit = "rad/s") "Driving-side speed minus driven-side speed";
      output Real tau(unit = "N.m") "Torque transmitted from the driving to the driven side";
      Real tau_c(unit = "N.m") "Elastic torque";
      Real tau_d(unit = "N.m") "Damping torque before limiting";
    equation
      tau_c = c*(max(phi_rel - b/2, 0) + min(phi_rel + b/2, 0));
      tau_d = d*w_rel;
      tau = noEvent(if phi_rel > b/2 then max(0, tau_c + min(tau_c, tau_d)) else if phi_rel < -b/2 then min(0, tau_c + max(tau_c, tau_d)) else 0);
    end ElastoBacklash;

    model RackPinion "Pinion driving n synchronised racks (jaws) symmetrically"
      parameter Real r_p(unit = "m", min = 0) = 0.008957 "Pinion pitch radius";
      parameter Integer n = 2 "Number of racks (jaws) driven by the pinion";
      input Real tau(unit = "N.m") "Torque on the pinion";
      input Real x(unit = "m") "Jaw displacement";
      input Real v(unit = "m/s") "Jaw velocity";
      output Real F(unit = "N") "Actuation force on each jaw";
      output Real phi(unit = "rad") "Pinion angle";
      output Real w(unit = "rad/s") "Pinion speed";
    equation
      F = tau/(n*r_p);
      phi = x/r_p;
      w = v/r_p;
    end RackPinion;

    model JawMass "Jaw-finger mass of one jaw (rigid body; carries its share of the pinion inertia)"
      parameter Real m(unit = "kg", min = 0) = 0.085 "Moving mass of one jaw";
      input Real F(unit = "N") "Net force on the jaw, positive closing";
      Real x(unit = "m", start = 0.0, fixed = true) "Jaw displacement, positive closing";
      Real v(unit = "m/s", start = 0.0, fixed = true) "Jaw velocity, positive closing";
    equation
      der(x) = v;
      m*der(v) = F;
    end JawMass;

    model GreaseViscous "Viscous grease force on the guide surfaces, eq. (11): sum eta*S_i/d * v"
      parameter Real eta(unit = "Pa.s", min = 0) = 0.2 "Grease dynamic viscosity";
      parameter Real S(unit = "m2", min = 0) = 2e-4 "Area of one sliding surface";
      parameter Real d(unit = "m", min = 0) = 5e-5 "Grease layer thickness";
      parameter Integer n_s = 4 "Number of sliding surfaces of one jaw";
      input Real v(unit = "m/s") "Jaw velocity";
      output Real F(unit = "N") "Viscous force against the motion";
    equation
      F = n_s*eta*S/d*v;
    end GreaseViscous;

    model RegularisedCoulomb "Coulomb friction on the guide surfaces, eq. (11), regularised by tanh (creeps at rest)"
      extends Gripper.Interfaces.GuideSlot;
    equation
      F = F_c*tanh(v/v_s);
    end RegularisedCoulomb;

    model FingerContact "Finger (cantilever) in series with an optional two-region coating and the object; opens when the gap opens"
      extends Gripper.Interfaces.ContactSlot;
      // Elastic part: springs in series, k_f (finger), k_P/k_H (coating regions), k_obj (object), solved
      // explicitly (massless intermediate nodes). Damping acts on the total penetration rate with a coefficient
      // that blends from C_p to C_h across the coating's region boundary, limited as in ElastoBacklash so that
      // the force is continuous at first touch and the contact cannot pull.
      parameter Real gap0(unit = "m") = 0.002 "Gap between the bare finger surface and the object at x = 0";
      parameter Real t_coat(unit = "m", min = 0) = 0 "Coating thickness (0 for bare fingers)";
      parameter Real k_f(unit = "N/m", min = 0) = 1.46e6 "Finger stiffness (FEM)";
      parameter Real k_obj(unit = "N/m", min = 0) = 3.53e7 "Object stiffness on one side (cylinder)";
      parameter Real k_P(unit = "N/m", min = 0) = 1e12 "Coating first-region stiffness (1e12: no coating)";
      parameter Real k_H_ratio(unit = "1", min = 0) = 100 "Coating second-region stiffness / first-region stiffness";
      parameter Real d_lim(unit = "m", min = 0) = 0.0015 "Coating deflection at the region boundary";
      parameter Real C_p(unit = "N.s/m", min = 0) = 2000 "Contact damping, first region";
      parameter Real C_h(unit = "N.s/m", min = 0) = 2000 "Contact damping, second region";
      parameter Real w_tr(unit = "m", min = 0) = 5e-6 "Width of the damping blend across the region boundary";
      parameter Real k_H(unit = "N/m") = k_H_ratio*k_P "Coating second-region stiffness";
      parameter Real c_1(unit = "m/N") = 1/k_f + 1/k_obj + 1/k_P "Series compliance, coating first region";
      parameter Real c_2(unit = "m/N") = 1/k_f + 1/k_obj + 1/k_H "Series compliance, coating second region";
      parameter Real F_lim(unit = "N") = k_P*d_lim "Force at the coating region boundary";
      parameter Real p_lim(unit = "m") = F_lim*c_1 "Penetration at the coating region boundary";
      Real pen(unit = "m") "Penetration of the (coated) finger into the object";
      Real F_s(unit = "N") "Elastic contact force";
      Real C(unit = "N.s/m") "Current damping coefficient";
      Real F_d(unit = "N") "Damping force before limiting";
    equation
      pen = x - (gap0 - t_coat);
      F_s = max(pen, 0)/c_1 - max(pen - p_lim, 0)*(1/c_1 - 1/c_2);
      delta_c = F_s/k_P - max(F_s - F_lim, 0)*(1/k_P - 1/k_H);
      C = C_p + (C_h - C_p)*0.5*(1 + tanh((delta_c - d_lim)/w_tr));
      F_d = C*v;
      F = max(0, F_s + min(F_s, F_d));
    end FingerContact;

    model AngleReconstruction "Co-simulation input reconstruction: angle integrated from the speed input, pulled to the angle input"
      // Under a zero-order hold the angle input is a staircase; fed straight into a stiff compliance it makes
      // the lightly preloaded play chatter. Integrating the (held) speed gives a smooth angle, and the
      // correction k_c*(theta_in - theta) removes drift. In a monolithic model theta = theta_in exactly.
      parameter Real k_c(unit = "1/s", min = 0) = 2000 "Correction rate towards the angle input";
      input Real theta_in(unit = "rad") "Angle input (sampled)";
      input Real w_in(unit = "rad/s") "Speed input (sampled)";
      output Real theta(unit = "rad", start = 0.0, fixed = true) "Reconstructed angle";
    equation
      der(theta) = w_in + k_c*(theta_in - theta);
    end AngleReconstruction;

    model NoLoadFriction "No guide friction that depends on the gripping force (default of the slot lfric)"
      extends Gripper.Interfaces.LoadFrictionSlot;
    equation
      F = 0;
    end NoLoadFriction;

    model NoCogging "No cogging torque (default of the slot cog)"
      extends Gripper.Interfaces.CoggingSlot;
    equation
      tau = 0;
    end NoCogging;

    model IdealLoadCell "A load cell that reports the force as it is (default of the slot lc)"
      extends Gripper.Interfaces.LoadCellSlot;
    equation
      F_meas = F;
    end IdealLoadCell;
  end Components;

  package Effects "Candidate missing effects of the discrepancy workflow (cosim diagnose, docs/guide/diagnose.md); each fills a slot of package Interfaces, and cosim.diagnose.effects writes the variants that redeclare the slot with it"
    model DirectionalMeshEfficiency "Gear mesh loss with one efficiency when the motor drives the load and another when the load back-drives the motor (effect backdrive_efficiency)"
      // As Components.MeshEfficiency, but the loss level of the back-driven branch is (1 - eta_b)*|tau_out|:
      // driving gives tau_out = eta*tau_in, back-driving tau_in = eta_b*tau_out; at standstill any tau_in between
      // eta_b*tau_out and tau_out/eta is held. Both branches vanish at s*tau_out = 0 (continuous).
      extends Gripper.Interfaces.MeshSlot;
      parameter Real eta(unit = "1", min = 0, max = 1) = 0.68 "Mesh efficiency, motor driving the load";
      parameter Real eta_b(unit = "1", min = 0, max = 1) = 0.68 "Mesh efficiency, load back-driving the motor";
      parameter Real phi_b(unit = "rad", min = 0) = 1e-3 "Presliding angle of the mesh bristle (input side)";
      parameter Real tau_b(unit = "s", min = 0) = 1e-4 "Bristle relaxation time at high speed";
      parameter Real s_ba(unit = "1", min = 0, max = 1) = 0.5 "Elastic fraction of the bristle range";
      Real s(unit = "1", start = 0.0, fixed = true) "Normalised bristle deflection, in [-1, 1]";
      Real N(unit = "N.m") "Transmitted load max(|tau_in|, |tau_out|)";
    equation
      N = noEvent(if s*tau_out > 0 then abs(tau_out)/(1 - (1 - eta)*abs(s)) else abs(tau_out));
      der(s) = Gripper.Components.bristleRate(w, s, phi_b, tau_b, s_ba);
      tau_f = noEvent(if s*tau_out > 0 then 1 - eta else 1 - eta_b)*N*s;
    end DirectionalMeshEfficiency;

    model LoadDependentFriction "Jaw-guide friction proportional to the gripping force (effect load_dependent_friction): the clamped finger tilts the jaw in its guides"
      // Coulomb level mu_F*F_n carried by an elasto-plastic bristle (Components.bristleRate with a presliding
      // displacement in m), so a clamped jaw holds its friction at rest. The presliding displacement is 0.1 um:
      // with 1 um, the jaw's um-scale motions in the hold stayed on the bristle's elastic range and the fitted
      // variant missed the held friction of the hidden-effect truth (docs/guide/diagnose.md).
      extends Gripper.Interfaces.LoadFrictionSlot;
      parameter Real mu_F(unit = "1", min = 0) = 0.05 "Friction force per unit gripping force";
      parameter Real x_b(unit = "m", min = 0) = 1e-7 "Presliding displacement of the bristle";
      parameter Real tau_b(unit = "s", min = 0) = 1e-4 "Bristle relaxation time at high speed";
      parameter Real s_ba(unit = "1", min = 0, max = 1) = 0.5 "Elastic fraction of the bristle range";
      Real s(unit = "1", start = 0.0, fixed = true) "Normalised bristle deflection, in [-1, 1]";
    equation
      der(s) = Gripper.Components.bristleRate(v, s, x_b, tau_b, s_ba);
      F = mu_F*F_n*s;
    end LoadDependentFriction;

    model StribeckGuide "Jaw-guide friction with stiction and a Stribeck drop, carried by an elasto-plastic bristle (effect stiction); replaces the regularised Coulomb guide"
      // The friction is the bristle's force F_s*s (s: deflection over the presliding range x_b at the static
      // level), so it is continuous in time: a jaw that stops keeps the force it slid with and takes up more
      // load elastically, up to F_s. The bristle turns plastic at s_ba of the current sliding level g*F_s and
      // slides at g*F_s. g follows the Stribeck curve F_c + (F_s - F_c)*exp(-(v_p/v_st)^2) of the *sliding*
      // velocity v_p (the jaw's less the bristle's deflection rate) with a short lag tau_g (frictional memory,
      // which also keeps g off an algebraic loop): a jaw at rest taking up load has v_p ~ 0 and keeps g = 1.
      // Measured on the slide truth (a Karnopp guide): with the level multiplying a bristle state normalised to
      // it, the friction jumped to F_s when a sliding jaw stopped and pushed it back; with the jaw velocity v in
      // the curve, the bristle's own loading motion dropped the level and the jaw never stuck; with s_ba = 0.5
      // the plastic creep under a slowly rising load broke the jaw free at 0.5-0.85 F_s. tau_b = 1e-6 s puts the
      // bristle's rate limit x_b/tau_b = 0.1 m/s above the speed at which the play's flank hits the jaw, so a
      // stuck jaw holds the hit up to F_s (with tau_b = 1e-4 s the hit counted as sliding); the state is stiff
      // (an implicit solver in the master). g is floored at 1e-3 in the bristle's rate so that F_c = 0 cannot
      // divide by zero.
      extends Gripper.Interfaces.GuideSlot;
      parameter Real F_s(unit = "N", min = 0) = 0.3 "Static (breakaway) friction level, > 0";
      parameter Real v_st(unit = "m/s", min = 0) = 1e-4 "Stribeck velocity";
      parameter Real x_b(unit = "m", min = 0) = 1e-7 "Presliding displacement of the bristle at the static level";
      parameter Real tau_b(unit = "s", min = 0) = 1e-6 "Bristle relaxation time at high speed";
      parameter Real tau_g(unit = "s", min = 0) = 1e-4 "Lag of the sliding level behind the sliding velocity";
      parameter Real s_ba(unit = "1", min = 0, max = 1) = 0.9 "Elastic fraction of the bristle range";
      Real s(unit = "1", start = 0.0, fixed = true) "Bristle deflection over x_b, in [-1, 1]";
      Real g(unit = "1", start = 1.0, fixed = true) "Sliding level over F_s";
      Real v_p(unit = "m/s") "Sliding (plastic) part of the jaw velocity";
    equation
      der(s) = Gripper.Components.bristleRate(v, s/max(g, 1e-3), x_b, tau_b, s_ba);
      v_p = v - x_b*der(s);
      der(g) = ((F_c + (F_s - F_c)*exp(-(v_p/v_st)^2))/F_s - g)/tau_g;
      F = F_s*s;
    end StribeckGuide;

    model CoggingTorque "Motor cogging (detent) torque, periodic in the rotor angle (effect cogging)"
      extends Gripper.Interfaces.CoggingSlot;
      parameter Real T_cog(unit = "N.m") = 1e-3 "Cogging torque amplitude";
      parameter Real n_cog(unit = "1", min = 0) = 24 "Cogging periods per revolution";
      parameter Real phase(unit = "rad") = 0 "Cogging phase at theta = 0";
    equation
      tau = T_cog*sin(n_cog*theta + phase);
    end CoggingTorque;

    model LoadCell "Load-cell first-order low-pass and offset (effect loadcell_filter)"
      extends Gripper.Interfaces.LoadCellSlot;
      parameter Real tau_lc(unit = "s", min = 0) = 0.01 "Low-pass time constant";
      parameter Real F_off(unit = "N") = 0 "Offset (zero error)";
      Real F_f(unit = "N", start = 0.0, fixed = true) "Filtered force";
    equation
      tau_lc*der(F_f) = F - F_f;
      F_meas = F_f + F_off;
    end LoadCell;

    model HuntCrossleyContact "Components.FingerContact with a Hunt-Crossley damping term lambda_hc*F_s*v added to the linear damping (effect contact_damping)"
      extends Gripper.Interfaces.ContactSlot;
      // As Components.FingerContact (copied: equations cannot be changed by extends); the damping force is
      // (C + lambda_hc*F_s)*v, Hunt and Crossley's damping proportional to the elastic force (dissipation grows
      // with penetration, no force jump at first touch), on top of the linear term.
      // Elastic part: springs in series, k_f (finger), k_P/k_H (coating regions), k_obj (object), solved
      // explicitly (massless intermediate nodes). Damping acts on the total penetration rate with a coefficient
      // that blends from C_p to C_h across the coating's region boundary, limited as in ElastoBacklash so that
      // the force is continuous at first touch and the contact cannot pull.
      parameter Real gap0(unit = "m") = 0.002 "Gap between the bare finger surface and the object at x = 0";
      parameter Real t_coat(unit = "m", min = 0) = 0 "Coating thickness (0 for bare fingers)";
      parameter Real k_f(unit = "N/m", min = 0) = 1.46e6 "Finger stiffness (FEM)";
      parameter Real k_obj(unit = "N/m", min = 0) = 3.53e7 "Object stiffness on one side (cylinder)";
      parameter Real k_P(unit = "N/m", min = 0) = 1e12 "Coating first-region stiffness (1e12: no coating)";
      parameter Real k_H_ratio(unit = "1", min = 0) = 100 "Coating second-region stiffness / first-region stiffness";
      parameter Real d_lim(unit = "m", min = 0) = 0.0015 "Coating deflection at the region boundary";
      parameter Real C_p(unit = "N.s/m", min = 0) = 2000 "Contact damping, first region";
      parameter Real C_h(unit = "N.s/m", min = 0) = 2000 "Contact damping, second region";
      parameter Real w_tr(unit = "m", min = 0) = 5e-6 "Width of the damping blend across the region boundary";
      parameter Real lambda_hc(unit = "s/m", min = 0) = 0.1 "Hunt-Crossley damping per unit elastic force";
      parameter Real k_H(unit = "N/m") = k_H_ratio*k_P "Coating second-region stiffness";
      parameter Real c_1(unit = "m/N") = 1/k_f + 1/k_obj + 1/k_P "Series compliance, coating first region";
      parameter Real c_2(unit = "m/N") = 1/k_f + 1/k_obj + 1/k_H "Series compliance, coating second region";
      parameter Real F_lim(unit = "N") = k_P*d_lim "Force at the coating region boundary";
      parameter Real p_lim(unit = "m") = F_lim*c_1 "Penetration at the coating region boundary";
      Real pen(unit = "m") "Penetration of the (coated) finger into the object";
      Real F_s(unit = "N") "Elastic contact force";
      Real C(unit = "N.s/m") "Current damping coefficient";
      Real F_d(unit = "N") "Damping force before limiting";
    equation
      pen = x - (gap0 - t_coat);
      F_s = max(pen, 0)/c_1 - max(pen - p_lim, 0)*(1/c_1 - 1/c_2);
      delta_c = F_s/k_P - max(F_s - F_lim, 0)*(1/k_P - 1/k_H);
      C = C_p + (C_h - C_p)*0.5*(1 + tanh((delta_c - d_lim)/w_tr));
      F_d = (C + lambda_hc*F_s)*v;
      F = max(0, F_s + min(F_s, F_d));
    end HuntCrossleyContact;
    model RelaxingCoatingContact "Components.FingerContact whose coating relaxes: a Maxwell branch (spring k_rel*k_P, time constant tau_rel) in parallel with the coating's elastic element, a standard linear solid (effect coating_relaxation)"
      extends Gripper.Interfaces.ContactSlot;
      // The coating force is F_el(delta_c) + k_rel*k_P*(delta_c - z): the elastic two-region element plus a Maxwell
      // branch whose dashpot (k_rel*k_P*tau_rel) yields at rate der(z) = (delta_c - z)/tau_rel. Right after an impact
      // the coating is stiffer by k_rel*k_P; held still, its force relaxes to F_el with time constant ~tau_rel.
      // The massless coating node balances k_s*(pen - delta_c) = F_el(delta_c) + k_rel*k_P*(delta_c - z), with k_s
      // the finger and object in series; F_el is piecewise linear, so delta_c is explicit in each region. Bare
      // fingers (k_P = 1e12) give delta_c ~ 0 and the baseline force: the branch has nothing to relax.
      // Damping as in Components.FingerContact. k_rel = 0 is Components.FingerContact.
      parameter Real gap0(unit = "m") = 0.002 "Gap between the bare finger surface and the object at x = 0";
      parameter Real t_coat(unit = "m", min = 0) = 0 "Coating thickness (0 for bare fingers)";
      parameter Real k_f(unit = "N/m", min = 0) = 1.46e6 "Finger stiffness (FEM)";
      parameter Real k_obj(unit = "N/m", min = 0) = 3.53e7 "Object stiffness on one side (cylinder)";
      parameter Real k_P(unit = "N/m", min = 0) = 1e12 "Coating first-region stiffness (1e12: no coating)";
      parameter Real k_H_ratio(unit = "1", min = 0) = 100 "Coating second-region stiffness / first-region stiffness";
      parameter Real d_lim(unit = "m", min = 0) = 0.0015 "Coating deflection at the region boundary";
      parameter Real C_p(unit = "N.s/m", min = 0) = 2000 "Contact damping, first region";
      parameter Real C_h(unit = "N.s/m", min = 0) = 2000 "Contact damping, second region";
      parameter Real w_tr(unit = "m", min = 0) = 5e-6 "Width of the damping blend across the region boundary";
      parameter Real k_rel(unit = "1", min = 0) = 1 "Maxwell branch stiffness / coating first-region stiffness";
      parameter Real tau_rel(unit = "s", min = 0) = 0.1 "Relaxation time constant of the Maxwell branch";
      parameter Real k_H(unit = "N/m") = k_H_ratio*k_P "Coating second-region stiffness";
      parameter Real k_s(unit = "N/m") = 1/(1/k_f + 1/k_obj) "Finger and object in series";
      parameter Real k_m(unit = "N/m") = k_rel*k_P "Maxwell branch stiffness";
      Real z(unit = "m", start = 0.0, fixed = true) "Dashpot displacement of the Maxwell branch";
      Real pen(unit = "m") "Penetration of the (coated) finger into the object";
      Real delta_1(unit = "m") "Coating deflection if it stays in the first region";
      Real F_s(unit = "N") "Elastic contact force (negative: not touching)";
      Real C(unit = "N.s/m") "Current damping coefficient";
      Real F_d(unit = "N") "Damping force before limiting";
    equation
      pen = x - (gap0 - t_coat);
      delta_1 = (k_s*max(pen, 0) + k_m*z)/(k_s + k_P + k_m);
      delta_c = noEvent(if delta_1 <= d_lim then delta_1 else (k_s*max(pen, 0) + k_m*z + (k_H - k_P)*d_lim)/(k_s + k_H + k_m));
      der(z) = (delta_c - z)/tau_rel;
      F_s = k_s*(max(pen, 0) - delta_c);
      C = C_p + (C_h - C_p)*0.5*(1 + tanh((delta_c - d_lim)/w_tr));
      F_d = C*v;
      F = noEvent(if pen > 0 then max(0, F_s + min(F_s, F_d)) else 0);
    end RelaxingCoatingContact;
  end Effects;

  package Forms "Alternative forms of laws the baseline already has (issue 42): each fills the slot of the law it replaces, with the form's source cited; where it can, it equals the baseline's law at a neutral value of its parameters (said in each block)"
    model PowerLawSeries "The coating's first region as a power law F = F_lim*(delta_c/d_lim)^n through (d_lim, F_lim = k_P*d_lim), its second region linear (slope k_H), in series with the finger and the object: the elastic force and the coating deflection at a penetration"
      // The massless coating node balances k_s*(p - delta_c) = F_el(delta_c) with k_s the finger and object in
      // series. In the first region delta_c comes from six Newton steps from min(p, d_lim), to the right of the
      // root, where Newton on this convex increasing residual converges monotonically (exact in one step at
      // n = 1); the second region is linear, so explicit.
      parameter Real k_s(unit = "N/m") "Finger and object in series";
      parameter Real k_P(unit = "N/m") "Coating first-region stiffness at d_lim (secant)";
      parameter Real k_H(unit = "N/m") "Coating second-region stiffness";
      parameter Real d_lim(unit = "m") "Coating deflection at the region boundary";
      parameter Real n(unit = "1") "Exponent of the first region";
      parameter Real F_lim(unit = "N") = k_P*d_lim "Force at the coating region boundary";
      parameter Real p_lim(unit = "m") = d_lim + F_lim/k_s "Penetration at the coating region boundary";
      input Real p(unit = "m") "Penetration, >= 0";
      output Real F_s(unit = "N") "Elastic contact force";
      output Real delta_c(unit = "m") "Coating deflection";
      Real d0(unit = "m") "Newton start";
      Real d1(unit = "m");
      Real d2(unit = "m");
      Real d3(unit = "m");
      Real d4(unit = "m");
      Real d5(unit = "m");
      Real d6(unit = "m") "Coating deflection in the first region";
    equation
      d0 = min(p, d_lim);
      d1 = Gripper.Forms.powerLawStep(d0, p, F_lim, d_lim, n, k_s);
      d2 = Gripper.Forms.powerLawStep(d1, p, F_lim, d_lim, n, k_s);
      d3 = Gripper.Forms.powerLawStep(d2, p, F_lim, d_lim, n, k_s);
      d4 = Gripper.Forms.powerLawStep(d3, p, F_lim, d_lim, n, k_s);
      d5 = Gripper.Forms.powerLawStep(d4, p, F_lim, d_lim, n, k_s);
      d6 = Gripper.Forms.powerLawStep(d5, p, F_lim, d_lim, n, k_s);
      delta_c = noEvent(if p <= p_lim then d6 else (k_s*p + (k_H - k_P)*d_lim)/(k_s + k_H));
      F_s = k_s*(p - delta_c);
    end PowerLawSeries;

    function powerLawStep "One Newton step on k_s*(p - d) = F_lim*(d/d_lim)^n for the coating deflection d"
      input Real d(unit = "m") "Current iterate (>= the root)";
      input Real p(unit = "m") "Penetration (>= 0)";
      input Real F_lim(unit = "N");
      input Real d_lim(unit = "m");
      input Real n(unit = "1");
      input Real k_s(unit = "N/m");
      output Real d_next(unit = "m");
    protected
      Real r(unit = "1") "d/d_lim, floored so that its powers stay finite";
    algorithm
      r := max(d/d_lim, 1e-12);
      d_next := d - (F_lim*r^n + k_s*(d - p))/(n*F_lim/d_lim*r^(n - 1) + k_s);
    end powerLawStep;

    model PowerLawCoatingContact "Components.FingerContact whose coating's first region follows a power law F = F_lim*(delta_c/d_lim)^n_c (Hertz-type), n_c = 1 the baseline"
      extends Gripper.Interfaces.ContactSlot;
      // Source: the force of an elastic indentation grows as a power of its depth, F ~ delta^(3/2) for a sphere
      // on a flat (Hertz 1882), delta^2 for a cone (Sneddon 1965), delta^1 for a flat punch (Johnson, Contact
      // Mechanics, 1985, ch. 3-5); soft robotic fingertips: Xydas and Kao, Int. J. Robotics Research 18 (1999)
      // 941-950 (a power law of a nonlinear elastic finger). n_c in [1, 3] spans those (a coating that softens
      // under compression, n_c < 1, would buckle). The power law passes through (d_lim, F_lim = k_P*d_lim), so the
      // second region (slope k_H) and the damping are the baseline's; the series balance is PowerLawSeries'.
      parameter Real gap0(unit = "m") = 0.002 "Gap between the bare finger surface and the object at x = 0";
      parameter Real t_coat(unit = "m", min = 0) = 0 "Coating thickness (0 for bare fingers)";
      parameter Real k_f(unit = "N/m", min = 0) = 1.46e6 "Finger stiffness (FEM)";
      parameter Real k_obj(unit = "N/m", min = 0) = 3.53e7 "Object stiffness on one side (cylinder)";
      parameter Real k_P(unit = "N/m", min = 0) = 1e12 "Coating first-region stiffness at d_lim (secant; 1e12: no coating)";
      parameter Real k_H_ratio(unit = "1", min = 0) = 100 "Coating second-region stiffness / first-region stiffness";
      parameter Real d_lim(unit = "m", min = 0) = 0.0015 "Coating deflection at the region boundary";
      parameter Real C_p(unit = "N.s/m", min = 0) = 2000 "Contact damping, first region";
      parameter Real C_h(unit = "N.s/m", min = 0) = 2000 "Contact damping, second region";
      parameter Real w_tr(unit = "m", min = 0) = 5e-6 "Width of the damping blend across the region boundary";
      parameter Real n_c(unit = "1", min = 1, max = 3) = 1 "Exponent of the coating's first region (1: linear, the baseline)";
      Gripper.Forms.PowerLawSeries law(k_s = 1/(1/k_f + 1/k_obj), k_P = k_P, k_H = k_H_ratio*k_P, d_lim = d_lim, n = n_c);
      Real pen(unit = "m") "Penetration of the (coated) finger into the object";
      Real C(unit = "N.s/m") "Current damping coefficient";
      Real F_d(unit = "N") "Damping force before limiting";
    equation
      pen = x - (gap0 - t_coat);
      law.p = max(pen, 0);
      delta_c = law.delta_c;
      C = C_p + (C_h - C_p)*0.5*(1 + tanh((delta_c - d_lim)/w_tr));
      F_d = C*v;
      F = noEvent(if pen > 0 then max(0, law.F_s + min(law.F_s, F_d)) else 0);
    end PowerLawCoatingContact;

    model HuntCrossleyContact "Finger, coating and object whose dissipation is Hunt and Crossley's: F = F_s*(1 + lambda_c*v), no linear damping; the elastic part is PowerLawSeries'"
      extends Gripper.Interfaces.ContactSlot;
      // Source: Hunt and Crossley, J. Applied Mechanics 42 (1975) 440-445: a damping force proportional to the
      // elastic force times the penetration rate, which vanishes at first touch and at separation, so the force
      // neither jumps nor pulls; with the Hertz exponent, Marhefka and Orin, IEEE Trans. SMC-A 29 (1999) 566-572.
      // lambda_c relates to the coefficient of restitution e at impact speed v_i as lambda_c = 3*(1 - e)/(2*v_i)
      // (Hunt and Crossley's small-loss result): e in [0.3, 1] at the jaws' 1-100 mm/s gives lambda_c in [0, 1e3]
      // s/m. The baseline's linear damping C*v is gone, so this form does not contain the baseline: the fit
      // judges it by its cost, not by a score test at a neutral value.
      parameter Real gap0(unit = "m") = 0.002 "Gap between the bare finger surface and the object at x = 0";
      parameter Real t_coat(unit = "m", min = 0) = 0 "Coating thickness (0 for bare fingers)";
      parameter Real k_f(unit = "N/m", min = 0) = 1.46e6 "Finger stiffness (FEM)";
      parameter Real k_obj(unit = "N/m", min = 0) = 3.53e7 "Object stiffness on one side (cylinder)";
      parameter Real k_P(unit = "N/m", min = 0) = 1e12 "Coating first-region stiffness at d_lim (secant; 1e12: no coating)";
      parameter Real k_H_ratio(unit = "1", min = 0) = 100 "Coating second-region stiffness / first-region stiffness";
      parameter Real d_lim(unit = "m", min = 0) = 0.0015 "Coating deflection at the region boundary";
      parameter Real C_p(unit = "N.s/m", min = 0) = 2000 "Unused: this form has no linear damping (kept for the slot's modifiers)";
      parameter Real C_h(unit = "N.s/m", min = 0) = 2000 "Unused: this form has no linear damping (kept for the slot's modifiers)";
      parameter Real w_tr(unit = "m", min = 0) = 5e-6 "Unused (kept for the slot's modifiers)";
      parameter Real n_c(unit = "1", min = 1, max = 3) = 1 "Exponent of the coating's first region";
      parameter Real lambda_c(unit = "s/m", min = 0) = 10 "Hunt-Crossley damping per unit elastic force";
      Gripper.Forms.PowerLawSeries law(k_s = 1/(1/k_f + 1/k_obj), k_P = k_P, k_H = k_H_ratio*k_P, d_lim = d_lim, n = n_c);
      Real pen(unit = "m") "Penetration of the (coated) finger into the object";
    equation
      pen = x - (gap0 - t_coat);
      law.p = max(pen, 0);
      delta_c = law.delta_c;
      F = noEvent(if pen > 0 then max(0, law.F_s*(1 + lambda_c*v)) else 0);
    end HuntCrossleyContact;

    model HystereticCoatingContact "Components.FingerContact with a rate-independent hysteresis of the contact (Bouc-Wen): a fraction a_h of the elastic force carried by a hysteretic element, a_h = 0 the baseline"
      extends Gripper.Interfaces.ContactSlot;
      // Source: Bouc (1967), Wen, J. Eng. Mech. Div. ASCE 102 (1976) 249-263; the form and its parameters as
      // reviewed by Ismail, Ikhouane and Rodellar, Arch. Comput. Methods Eng. 16 (2009) 161-188. The contact force
      // is (1 - a_h)*F_el(pen) + a_h*z/c_1: z follows the penetration while loading, saturates at the yield
      // penetration z_y, and on unloading drops faster than the elastic path, a loop that does not depend on
      // the rate (the filled elastomer's Mullins/Payne-type loss). Exponent 1 and beta = gamma = 1/(2*z_y) (the
      // review's standard shape): der(z) = v*(1 - (sign(v*z) + 1)/2*|z|/z_y). Out of contact z returns to 0 with
      // a 1 ms time constant. a_h in [0, 1]; z_y from 1 um (a hard contact) to 1 mm (the coating's thickness).
      // Damping as in Components.FingerContact.
      parameter Real gap0(unit = "m") = 0.002 "Gap between the bare finger surface and the object at x = 0";
      parameter Real t_coat(unit = "m", min = 0) = 0 "Coating thickness (0 for bare fingers)";
      parameter Real k_f(unit = "N/m", min = 0) = 1.46e6 "Finger stiffness (FEM)";
      parameter Real k_obj(unit = "N/m", min = 0) = 3.53e7 "Object stiffness on one side (cylinder)";
      parameter Real k_P(unit = "N/m", min = 0) = 1e12 "Coating first-region stiffness (1e12: no coating)";
      parameter Real k_H_ratio(unit = "1", min = 0) = 100 "Coating second-region stiffness / first-region stiffness";
      parameter Real d_lim(unit = "m", min = 0) = 0.0015 "Coating deflection at the region boundary";
      parameter Real C_p(unit = "N.s/m", min = 0) = 2000 "Contact damping, first region";
      parameter Real C_h(unit = "N.s/m", min = 0) = 2000 "Contact damping, second region";
      parameter Real w_tr(unit = "m", min = 0) = 5e-6 "Width of the damping blend across the region boundary";
      parameter Real a_h(unit = "1", min = 0, max = 1) = 0 "Fraction of the contact force carried by the hysteretic element (0: the baseline)";
      parameter Real z_y(unit = "m", min = 0) = 1e-4 "Yield penetration of the hysteretic element";
      parameter Real k_H(unit = "N/m") = k_H_ratio*k_P "Coating second-region stiffness";
      parameter Real c_1(unit = "m/N") = 1/k_f + 1/k_obj + 1/k_P "Series compliance, coating first region";
      parameter Real c_2(unit = "m/N") = 1/k_f + 1/k_obj + 1/k_H "Series compliance, coating second region";
      parameter Real F_lim(unit = "N") = k_P*d_lim "Force at the coating region boundary";
      parameter Real p_lim(unit = "m") = F_lim*c_1 "Penetration at the coating region boundary";
      Real z(unit = "m", start = 0.0, fixed = true) "Hysteretic penetration";
      Real pen(unit = "m") "Penetration of the (coated) finger into the object";
      Real F_el(unit = "N") "Elastic contact force of the baseline's law";
      Real F_s(unit = "N") "Elastic and hysteretic contact force";
      Real C(unit = "N.s/m") "Current damping coefficient";
      Real F_d(unit = "N") "Damping force before limiting";
    equation
      pen = x - (gap0 - t_coat);
      der(z) = noEvent(if pen > 0 then v*(1 - 0.5*(1 + sign(v*z))*abs(z)/z_y) else -z/1e-3);
      F_el = max(pen, 0)/c_1 - max(pen - p_lim, 0)*(1/c_1 - 1/c_2);
      F_s = (1 - a_h)*F_el + a_h*z/c_1;
      delta_c = F_el/k_P - max(F_el - F_lim, 0)*(1/k_P - 1/k_H);
      C = C_p + (C_h - C_p)*0.5*(1 + tanh((delta_c - d_lim)/w_tr));
      F_d = C*v;
      F = noEvent(if pen > 0 then max(0, F_s + min(F_s, F_d)) else 0);
    end HystereticCoatingContact;

    model StribeckCurveGuide "Jaw-guide friction on a Stribeck curve with viscous friction, regularised at rest: F_c = F_sg and d_vg = 0 the baseline"
      extends Gripper.Interfaces.GuideSlot;
      // Source: Stribeck (1902); the curve F(v) = (F_c + (F_sg - F_c)*exp(-(v/v_sg)^2))*sgn(v) + d_vg*v as in
      // Armstrong-Helouvry, Dupont and Canudas de Wit, Automatica 30 (1994) 1083-1138, eq. (3) with delta = 2; the
      // sign regularised by tanh(v/v_s) as the baseline's (Karnopp's stick band, Karnopp 1985, needs the applied
      // force, which the slot does not have). A memoryless curve: unlike the stiction effect's bristle, a jaw at
      // rest creeps. v_sg: 10 um/s to 10 mm/s (the survey's range for lubricated metal contacts).
      parameter Real F_sg(unit = "N", min = 0) = 0.0785 "Static friction level (F_c: no Stribeck rise, the baseline)";
      parameter Real v_sg(unit = "m/s", min = 0) = 1e-3 "Stribeck velocity";
      parameter Real d_vg(unit = "N.s/m", min = 0) = 0 "Viscous friction coefficient";
    equation
      F = (F_c + (F_sg - F_c)*exp(-(v/v_sg)^2))*tanh(v/v_s) + d_vg*v;
    end StribeckCurveGuide;

    model DahlGuide "Jaw-guide friction of Dahl's bristle form: the friction force is a state that follows the motion, dF/dt = (F_c/x_d)*(v - |v|*F/F_c)"
      extends Gripper.Interfaces.GuideSlot;
      // Source: Dahl, "A solid friction model", Aerospace Corp. TOR-0158(3107-18)-1 (1968), with exponent 1;
      // as written by Olsson, Astrom, Canudas de Wit, Gafvert and Lischinsky, Eur. J. Control 4 (1998) 176-195,
      // eq. (9). Presliding: a spring of stiffness F_c/x_d; sliding: F -> F_c*sgn(v) over the distance x_d. No
      // neutral value gives the baseline's creeping law; it is its limit as x_d -> 0. x_d: 0.1-100 um (the
      // presliding displacements the survey reports for metal contacts).
      parameter Real x_d(unit = "m", min = 0) = 1e-5 "Presliding displacement to reach F_c";
      Real F_b(unit = "N", start = 0.0, fixed = true) "Bristle (friction) force";
    equation
      der(F_b) = F_c/x_d*(v - abs(v)*F_b/max(F_c, 1e-9));
      F = F_b;
    end DahlGuide;

    model StribeckDrag "Drive friction on a Stribeck curve, held by the baseline's elasto-plastic bristle: breakaway T_s falling to T_c above w_s, plus viscous d_v*w; T_s = T_c and d_v = 0 the baseline"
      extends Gripper.Interfaces.DriveFrictionSlot;
      // Source: Armstrong-Helouvry, Control of Machines with Friction (Kluwer 1991), and Armstrong-Helouvry,
      // Dupont and Canudas de Wit, Automatica 30 (1994) 1083-1138, eq. (3) with delta = 2: in steady sliding
      // T(w) = (T_c + (T_s - T_c)*exp(-(w/w_s)^2))*sgn(w) + d_v*w. The torque is the bristle's, T_c*s, with the
      // bristle of Components.BristleFriction (stiffness T_c/phi_b, Dupont et al. 2002) whose plastic limit is
      // r = g(w)/T_c instead of 1: a shaft that stops keeps the torque it slid with and takes up more load
      // elastically up to T_s (no jump at the stop). At r = 1 the rate is BristleFriction's, exactly. The curve
      // follows the shaft speed, which includes the bristle's presliding motion: at presliding speeds well below
      // w_s the level is the static one. Ranges: T_s from T_c to 3*T_c (the survey's static over Coulomb levels of
      // lubricated metal contacts, 1-3); w_s 0.01-10 rad/s at the motor shaft (the survey's 1e-5 to 1e-2 m/s of
      // sliding speed at the 1-10 mm radii of the motor's bearings and the gear's sun); d_v from 0 to the 1e-4
      // N.m.s/rad of a greased bearing at the motor (Harris and Kotzalas, Rolling Bearing Analysis, 2006).
      parameter Real T_s(unit = "N.m", min = 0) = 7.88e-3 "Breakaway (static) friction torque (T_c: no Stribeck excess)";
      parameter Real w_s(unit = "rad/s", min = 0) = 1 "Stribeck speed";
      parameter Real d_v(unit = "N.m.s/rad", min = 0) = 0 "Viscous friction coefficient";
      Real s(unit = "1", start = 0.0, fixed = true) "Bristle deflection over phi_b (the torque is T_c*s)";
      Real r(unit = "1") "Plastic limit of s: the Stribeck level over T_c";
      Real ds(unit = "1/s") "Rate of the bristle deflection";
    equation
      r = max((T_c + (T_s - T_c)*exp(-(w/w_s)^2))/max(T_c, 1e-9), 1e-3);
      ds = r*Gripper.Components.bristleRate(w, s/r, r*phi_b, tau_b, s_ba);
      der(s) = ds;
      tau_f = T_c*s + d_pre*phi_b*ds*exp(-(w/w_pre)^2) + d_v*w;
    end StribeckDrag;

    model LuGreDrag "Drive friction of the LuGre form: a bristle that is plastic from the first motion, its level on a Stribeck curve, plus viscous d_v*w"
      extends Gripper.Interfaces.DriveFrictionSlot;
      // Source: Canudas de Wit, Olsson, Astrom and Lischinsky, IEEE Trans. Automatic Control 40 (1995) 419-425,
      // eqs. (1)-(4): dz/dt = w - sigma_0*|w|*z/g(w), T = sigma_0*z + sigma_1*dz/dt + sigma_2*w, with
      // g(w) = T_c + (T_s - T_c)*exp(-(w/w_s)^2). Written in s = z/phi_b (sigma_0 = T_c/phi_b, the baseline's
      // bristle stiffness); sigma_1 is the slot's d_pre with BristleFriction's fade above w_pre, sigma_2 = d_v. The
      // rate is divided by phi_b + |w|*tau_b instead of phi_b (the baseline's bound on the state's rate, Dupont et
      // al. 2002): the same steady sliding, a non-stiff state above phi_b/tau_b = 10 rad/s. Unlike the baseline's
      // elasto-plastic bristle, LuGre's has no elastic range: a shaft held under a load that oscillates creeps
      // (Dupont et al. 2002). No value gives the baseline: at T_s = T_c it differs by that elastic range, and both
      // are Coulomb's law in the limit of stiff bristles (phi_b -> 0). Ranges as Forms.StribeckDrag's.
      parameter Real T_s(unit = "N.m", min = 0) = 7.88e-3 "Breakaway (static) friction torque";
      parameter Real w_s(unit = "rad/s", min = 0) = 1 "Stribeck speed";
      parameter Real d_v(unit = "N.m.s/rad", min = 0) = 0 "Viscous friction coefficient (LuGre's sigma_2)";
      Real s(unit = "1", start = 0.0, fixed = true) "Bristle deflection over phi_b (the torque is T_c*s)";
      Real g(unit = "N.m") "Stribeck level";
      Real ds(unit = "1/s") "Rate of the bristle deflection";
    equation
      g = max(T_c + (T_s - T_c)*exp(-(w/w_s)^2), 1e-9);
      ds = (w - abs(w)*s*T_c/g)/(phi_b + abs(w)*tau_b);
      der(s) = ds;
      tau_f = T_c*s + d_pre*phi_b*ds*exp(-(w/w_pre)^2) + d_v*w;
    end LuGreDrag;

    model LoadExponentMeshLoss "Gear mesh loss that grows as a power n_L of the transmitted torque (an efficiency that varies with the load), held by the baseline's bristle: n_L = 1 the baseline's constant efficiency"
      extends Gripper.Interfaces.MeshSlot;
      // Source: the load-dependent gear loss of ISO/TR 14179-2 (2001), whose mean mesh friction coefficient
      // (Schlenk 1994) grows as the tooth load to the power 0.2, so the loss as the torque to the power 1.2; the
      // load-dependent torque of rolling bearings, M_1 = f_1*P*d_m with f_1 ~ (P/C_0)^0.5 for ball bearings
      // (Palmgren 1959; Harris and Kotzalas, Rolling Bearing Analysis, 2006), a power 1.5; a constant friction
      // coefficient, the baseline, a power 1. n_L in [0.5, 2] spans those and a mixed-film friction coefficient
      // that falls with the load (n_L < 1). The loss fraction is k = (1 - eta)*(|tau_out|/T_n)^(n_L - 1), so eta
      // is the efficiency at T_n (the rated torque at which a datasheet quotes it, here the motor's 0.13 N.m);
      // k is kept below 0.95 (n_L < 1 at a vanishing load). With k in place of 1 - eta, as
      // Components.MeshEfficiency: N = max(|tau_in|, |tau_out|), the loss k*N*s held by the bristle s.
      parameter Real eta(unit = "1", min = 0, max = 1) = 0.68 "Mesh efficiency at the torque T_n";
      parameter Real phi_b(unit = "rad", min = 0) = 1e-3 "Presliding angle of the mesh bristle (input side)";
      parameter Real tau_b(unit = "s", min = 0) = 1e-4 "Bristle relaxation time at high speed";
      parameter Real s_ba(unit = "1", min = 0, max = 1) = 0.5 "Elastic fraction of the bristle range";
      parameter Real n_L(unit = "1", min = 0.5, max = 2) = 1 "Power of the transmitted torque the loss grows with (1: the baseline)";
      parameter Real T_n(unit = "N.m", min = 0) = 0.13 "Input torque at which the efficiency is eta";
      Real s(unit = "1", start = 0.0, fixed = true) "Normalised bristle deflection, in [-1, 1]";
      Real k(unit = "1") "Loss fraction at the transmitted torque";
      Real N(unit = "N.m") "Transmitted load max(|tau_in|, |tau_out|)";
    equation
      k = min((1 - eta)*(max(abs(tau_out), 1e-12)/T_n)^(n_L - 1), 0.95);
      N = noEvent(if s*tau_out > 0 then abs(tau_out)/(1 - k*abs(s)) else abs(tau_out));
      der(s) = Gripper.Components.bristleRate(w, s, phi_b, tau_b, s_ba);
      tau_f = k*N*s;
    end LoadExponentMeshLoss;
  end Forms;

  package Parameters "Shared top-level parameter declarations (values and sources: docs/models/gripper.md)"
    partial model MotorParameters "PMSM parameters"
      parameter Real R_s(unit = "Ohm", min = 0) = 0.45 "Stator phase resistance (estimate)";
      parameter Real L_d(unit = "H", min = 0) = 2.5e-4 "d-axis inductance (estimate)";
      parameter Real L_q(unit = "H", min = 0) = 2.5e-4 "q-axis inductance (estimate)";
      parameter Integer p = 4 "Number of pole pairs (estimate)";
      parameter Real k_t(unit = "N.m/A", min = 0) = 0.0393939394 "Torque constant T/i_q = 0.13 N.m / 3.3 A";
      parameter Real J_r(unit = "kg.m2", min = 0) = 1e-5 "Rotor inertia (estimate)";
      parameter Real J_g(unit = "kg.m2", min = 0) = 1e-7 "Gearbox inertia at the motor side (estimate), rigid with the rotor";
      parameter Real B_r(unit = "N.m.s/rad", min = 0) = 1.01e-5 "Rotor viscous damping, eq. (6) (estimate)";
      parameter Real Psi_m(unit = "Wb") = k_t/p "Flux linkage, power-invariant Park: k_t = p*Psi_m";
    end MotorParameters;

    partial model DrivetrainParameters "Gear, play, rack-and-pinion, jaw and contact parameters"
      parameter Real ratio(unit = "1", min = 0) = 28 "Gear reduction ratio (paper)";
      parameter Real eta_g(unit = "1", min = 0, max = 1) = 0.68 "Gear efficiency by direction of power flow (0.68 calibrated, 0.75 datasheet)";
      parameter Real T_max(unit = "N.m", min = 0) = 0.13 "Motor max torque in eq. (9) (estimate)";
      parameter Real omega_max(unit = "rad/s", min = 0) = 628.3185 "Gear max continuous input speed 6000 rpm (paper)";
      parameter Real B_g(unit = "N.m.s/rad") = T_max*(1 - eta_g)*ratio^2/omega_max "Bearing damping at the gear output, eq. (9)";
      parameter Real T_c0(unit = "N.m", min = 0) = 7.88e-3 "No-load Coulomb drag at the motor shaft (0.2 A dead zone)";
      parameter Real phi_b(unit = "rad", min = 0) = 1e-3 "Presliding angle of the bristle frictions (motor side)";
      parameter Real tau_b(unit = "s", min = 0) = 1e-4 "Bristle relaxation time at high speed";
      parameter Real s_ba(unit = "1", min = 0, max = 1) = 0.5 "Elastic fraction of the bristle range (elasto-plastic friction)";
      parameter Real d_pre(unit = "N.m.s/rad", min = 0) = 0 "Presliding damping of the motor-side drag, faded out above w_pre (0: none)";
      parameter Real w_pre(unit = "rad/s", min = 0) = 1 "Speed scale above which the presliding damping fades out";
      parameter Real play(unit = "rad", min = 0) = 0.013962634 "Total gear shaft play 0.8 deg (paper)";
      parameter Real c_play(unit = "N.m/rad", min = 0) = 1000 "Stiffness at the play stops (gear output)";
      parameter Real d_play(unit = "N.m.s/rad", min = 0) = 0.05 "Damping at the play stops (gear output)";
      parameter Real r_p(unit = "m", min = 0) = 0.008957 "Pinion pitch radius (estimate)";
      parameter Real J_p(unit = "kg.m2", min = 0) = 7.94e-7 "Pinion inertia (estimate)";
      parameter Real m_jf(unit = "kg", min = 0) = 0.08 "Jaw + finger mass, each (estimate)";
      parameter Real eta_grease(unit = "Pa.s", min = 0) = 0.2 "Grease dynamic viscosity (estimate)";
      parameter Real S_i(unit = "m2", min = 0) = 2e-4 "Area of each of the 4 sliding surfaces of a jaw (estimate)";
      parameter Real d_grease(unit = "m", min = 0) = 5e-5 "Grease layer thickness (estimate)";
      parameter Real F_cj(unit = "N", min = 0) = 0.0785 "Guide Coulomb friction per jaw, mu*R (estimate: 0.1*m_jf*g)";
      parameter Real v_s(unit = "m/s", min = 0) = 1e-4 "Regularisation velocity of the guide Coulomb friction";
      parameter Real gap0(unit = "m") = 0.002 "Initial gap bare finger - object, per jaw (condition)";
      parameter Real t_coat(unit = "m", min = 0) = 0 "Coating thickness (condition: 0 bare, 0.0025 P1-P3)";
      parameter Real k_f(unit = "N/m", min = 0) = 1.46e6 "Finger stiffness, FEM (paper)";
      parameter Real k_obj(unit = "N/m", min = 0) = 3.53e7 "Object stiffness per side (condition: ABS 3.53e7, aluminium 1.2e9)";
      parameter Real k_P(unit = "N/m", min = 0) = 1e12 "Coating first-region stiffness (condition: 1e12 bare)";
      parameter Real k_H_ratio(unit = "1", min = 0) = 100 "Coating second/first region stiffness ratio (paper)";
      parameter Real d_lim(unit = "m", min = 0) = 0.0015 "Coating deflection at the region boundary (estimate)";
      parameter Real C_p(unit = "N.s/m", min = 0) = 2000 "Contact damping, first region (condition: 10 coatings, 2000 bare)";
      parameter Real C_h(unit = "N.s/m", min = 0) = 2000 "Contact damping, second region (paper)";
      parameter Real w_tr(unit = "m", min = 0) = 5e-6 "Width of the damping blend across the coating region boundary";
    end DrivetrainParameters;
  end Parameters;

  model DrivetrainMechanics "Motor-side drag, gear mesh loss, 28:1 gear, bearing damping, play, rack-and-pinion, jaws, guide friction, contacts"
    extends Gripper.Parameters.DrivetrainParameters;
    input Real theta_m(unit = "rad") "Motor shaft angle";
    input Real w_m(unit = "rad/s") "Motor shaft speed";
    output Real tau_load(unit = "N.m") "Load torque on the motor shaft, against positive rotation";
    output Real F_g(unit = "N") "Gripping force (load cell)";
    output Real x_jaw(unit = "m") "Jaw displacement, positive closing";
    replaceable Gripper.Components.BristleFriction drag(T_c = T_c0, phi_b = phi_b, tau_b = tau_b, s_ba = s_ba, d_pre = d_pre, w_pre = w_pre) constrainedby Gripper.Interfaces.DriveFrictionSlot "No-load drag at the motor shaft";
    replaceable Gripper.Components.MeshEfficiency mesh(eta = eta_g, phi_b = phi_b, tau_b = tau_b, s_ba = s_ba) constrainedby Gripper.Interfaces.MeshSlot "Gear efficiency by power-flow direction";
    Gripper.Components.IdealGear gear(ratio = ratio) "Planetary gear kinematics";
    Gripper.Components.RotationalDamper bearing(d = B_g) "Gear bearing damping at the output";
    Gripper.Components.ElastoBacklash backlash(b = play, c = c_play, d = d_play) "Gear shaft play";
    Gripper.Components.RackPinion rack(r_p = r_p, n = 2) "Pinion driving both racks";
    Gripper.Components.JawMass jaw(m = m_jf + J_p/(2*r_p^2)) "One jaw with half the pinion inertia";
    Gripper.Components.GreaseViscous grease(eta = eta_grease, S = S_i, d = d_grease, n_s = 4) "Grease on the 4 guide surfaces";
    replaceable Gripper.Components.RegularisedCoulomb guide(F_c = F_cj, v_s = v_s) constrainedby Gripper.Interfaces.GuideSlot "Guide Coulomb friction";
    replaceable Gripper.Components.NoLoadFriction lfric constrainedby Gripper.Interfaces.LoadFrictionSlot "Guide friction that depends on the gripping force (none)";
    replaceable Gripper.Components.FingerContact contact(gap0 = gap0, t_coat = t_coat, k_f = k_f, k_obj = k_obj, k_P = k_P, k_H_ratio = k_H_ratio, d_lim = d_lim, C_p = C_p, C_h = C_h, w_tr = w_tr) constrainedby Gripper.Interfaces.ContactSlot "Finger, coating and object";
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
    lfric.v = jaw.v;
    lfric.F_n = contact.F;
    contact.x = jaw.x;
    contact.v = jaw.v;
    jaw.F = rack.F - grease.F - guide.F - contact.F - lfric.F;
    F_g = contact.F;
    x_jaw = jaw.x;
  end DrivetrainMechanics;

  model GripperPlant "Whole gripper plant: inputs d-q voltages, outputs currents, motor angle and speed, jaw position, gripping force"
    extends Gripper.Parameters.MotorParameters;
    extends Gripper.Parameters.DrivetrainParameters;
    input Real v_d(unit = "V") "d-axis stator voltage";
    input Real v_q(unit = "V") "q-axis stator voltage";
    output Real i_d(unit = "A") "d-axis stator current";
    output Real i_q(unit = "A") "q-axis stator current";
    output Real theta_m(unit = "rad") "Motor shaft angle";
    output Real w_m(unit = "rad/s") "Motor shaft speed";
    output Real x_jaw(unit = "m") "Jaw displacement, positive closing";
    output Real F_g(unit = "N") "Gripping force (load cell)";
    Gripper.Components.PMSM motor(R_s = R_s, L_d = L_d, L_q = L_q, p = p, Psi_m = Psi_m, J = J_r + J_g, B_r = B_r) "Motor with the gear input inertia";
    replaceable Gripper.DrivetrainMechanics drive(ratio = ratio, eta_g = eta_g, T_max = T_max, omega_max = omega_max, B_g = B_g, T_c0 = T_c0, phi_b = phi_b, tau_b = tau_b, s_ba = s_ba, d_pre = d_pre, w_pre = w_pre, play = play, c_play = c_play, d_play = d_play, r_p = r_p, J_p = J_p, m_jf = m_jf, eta_grease = eta_grease, S_i = S_i, d_grease = d_grease, F_cj = F_cj, v_s = v_s, gap0 = gap0, t_coat = t_coat, k_f = k_f, k_obj = k_obj, k_P = k_P, k_H_ratio = k_H_ratio, d_lim = d_lim, C_p = C_p, C_h = C_h, w_tr = w_tr) "Gear, jaws and contacts";
  equation
    motor.v_d = v_d;
    motor.v_q = v_q;
    motor.tau_load = drive.tau_load;
    drive.theta_m = motor.phi;
    drive.w_m = motor.w;
    i_d = motor.i_d;
    i_q = motor.i_q;
    theta_m = motor.phi;
    w_m = motor.w;
    x_jaw = drive.x_jaw;
    F_g = drive.F_g;
  end GripperPlant;

  model PMSM "Split FMU: the motor with the gear input inertia, driven by a load torque"
    extends Gripper.Parameters.MotorParameters;
    input Real v_d(unit = "V") "d-axis stator voltage";
    input Real v_q(unit = "V") "q-axis stator voltage";
    input Real tau_load(unit = "N.m") "Load torque of the drivetrain on the motor shaft, against positive rotation";
    output Real i_d(unit = "A") "d-axis stator current";
    output Real i_q(unit = "A") "q-axis stator current";
    output Real w_m(unit = "rad/s") "Motor shaft speed";
    output Real theta_m(unit = "rad") "Motor shaft angle";
    Gripper.Components.PMSM motor(R_s = R_s, L_d = L_d, L_q = L_q, p = p, Psi_m = Psi_m, J = J_r + J_g, B_r = B_r) "Motor with the gear input inertia";
  equation
    motor.v_d = v_d;
    motor.v_q = v_q;
    motor.tau_load = tau_load;
    i_d = motor.i_d;
    i_q = motor.i_q;
    w_m = motor.w;
    theta_m = motor.phi;
  end PMSM;

  model Drivetrain "Split FMU: everything after the motor shaft, driven by the motor angle and speed through the compliant play"
    extends Gripper.Parameters.DrivetrainParameters;
    input Real theta_m(unit = "rad") "Motor shaft angle";
    input Real w_m(unit = "rad/s") "Motor shaft speed";
    output Real tau_load(unit = "N.m") "Load torque on the motor shaft, against positive rotation";
    output Real F_g(unit = "N") "Gripping force (load cell)";
    output Real x_jaw(unit = "m") "Jaw displacement, positive closing";
    parameter Real k_c(unit = "1/s", min = 0) = 2000 "Correction rate of the motor-angle reconstruction";
    Gripper.Components.AngleReconstruction shaft(k_c = k_c) "Motor angle between communication points";
    replaceable Gripper.DrivetrainMechanics drive(ratio = ratio, eta_g = eta_g, T_max = T_max, omega_max = omega_max, B_g = B_g, T_c0 = T_c0, phi_b = phi_b, tau_b = tau_b, s_ba = s_ba, d_pre = d_pre, w_pre = w_pre, play = play, c_play = c_play, d_play = d_play, r_p = r_p, J_p = J_p, m_jf = m_jf, eta_grease = eta_grease, S_i = S_i, d_grease = d_grease, F_cj = F_cj, v_s = v_s, gap0 = gap0, t_coat = t_coat, k_f = k_f, k_obj = k_obj, k_P = k_P, k_H_ratio = k_H_ratio, d_lim = d_lim, C_p = C_p, C_h = C_h, w_tr = w_tr) "Gear, jaws and contacts";
  equation
    shaft.theta_in = theta_m;
    shaft.w_in = w_m;
    drive.theta_m = shaft.theta;
    drive.w_m = w_m;
    tau_load = drive.tau_load;
    F_g = drive.F_g;
    x_jaw = drive.x_jaw;
  end Drivetrain;

  model GripperCurrentDriven "Whole gripper in current mode with an ideal current loop: the q current is the input (calibration and diagnosis of slow experiments)"
    // The FOC current loop (bandwidth ~1 kHz) is much faster than a 5 s current step, so for the static test the
    // electrical dynamics reduce to i_q = i_ref and the air-gap torque to k_t*i_ref.
    extends Gripper.Parameters.MotorParameters;
    extends Gripper.Parameters.DrivetrainParameters;
    input Real i_ref(unit = "A") "q-axis current held by the current loop";
    output Real theta_m(unit = "rad") "Motor shaft angle";
    output Real w_m(unit = "rad/s") "Motor shaft speed";
    output Real x_jaw(unit = "m") "Jaw displacement, positive closing";
    output Real F_g(unit = "N") "Gripping force (load cell)";
    Real phi(unit = "rad", start = 0.0, fixed = true) "Motor shaft angle";
    Real w(unit = "rad/s", start = 0.0, fixed = true) "Motor shaft speed";
    replaceable Gripper.DrivetrainMechanics drive(ratio = ratio, eta_g = eta_g, T_max = T_max, omega_max = omega_max, B_g = B_g, T_c0 = T_c0, phi_b = phi_b, tau_b = tau_b, s_ba = s_ba, d_pre = d_pre, w_pre = w_pre, play = play, c_play = c_play, d_play = d_play, r_p = r_p, J_p = J_p, m_jf = m_jf, eta_grease = eta_grease, S_i = S_i, d_grease = d_grease, F_cj = F_cj, v_s = v_s, gap0 = gap0, t_coat = t_coat, k_f = k_f, k_obj = k_obj, k_P = k_P, k_H_ratio = k_H_ratio, d_lim = d_lim, C_p = C_p, C_h = C_h, w_tr = w_tr) "Gear, jaws and contacts";
    replaceable Gripper.Components.NoCogging cog constrainedby Gripper.Interfaces.CoggingSlot "Motor cogging (none)";
    replaceable Gripper.Components.IdealLoadCell lc constrainedby Gripper.Interfaces.LoadCellSlot "Load cell (ideal)";
  equation
    der(phi) = w;
    cog.theta = phi;
    (J_r + J_g)*der(w) = k_t*i_ref - B_r*w - drive.tau_load - cog.tau;
    drive.theta_m = phi;
    drive.w_m = w;
    theta_m = phi;
    w_m = w;
    x_jaw = drive.x_jaw;
    lc.F = drive.F_g;
    F_g = lc.F_meas;
  end GripperCurrentDriven;

  model GripperSpeedControlled "Whole gripper under a PI speed loop around an ideal current loop: the speed reference is the input (diagnosis of cogging at slow, steady motion)"
    // An identification run, not the paper's 100 Hz velocity PID: a continuous PI of ~30 Hz bandwidth holds slow
    // speeds, so a torque periodic in the rotor angle shows as a ripple of the current it takes (docs/guide/diagnose.md).
    extends Gripper.Parameters.MotorParameters;
    extends Gripper.Parameters.DrivetrainParameters;
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
    replaceable Gripper.DrivetrainMechanics drive(ratio = ratio, eta_g = eta_g, T_max = T_max, omega_max = omega_max, B_g = B_g, T_c0 = T_c0, phi_b = phi_b, tau_b = tau_b, s_ba = s_ba, d_pre = d_pre, w_pre = w_pre, play = play, c_play = c_play, d_play = d_play, r_p = r_p, J_p = J_p, m_jf = m_jf, eta_grease = eta_grease, S_i = S_i, d_grease = d_grease, F_cj = F_cj, v_s = v_s, gap0 = gap0, t_coat = t_coat, k_f = k_f, k_obj = k_obj, k_P = k_P, k_H_ratio = k_H_ratio, d_lim = d_lim, C_p = C_p, C_h = C_h, w_tr = w_tr) "Gear, jaws and contacts";
    replaceable Gripper.Components.NoCogging cog constrainedby Gripper.Interfaces.CoggingSlot "Motor cogging (none)";
    replaceable Gripper.Components.IdealLoadCell lc constrainedby Gripper.Interfaces.LoadCellSlot "Load cell (ideal)";
  equation
    der(phi) = w;
    cog.theta = phi;
    (J_r + J_g)*der(w) = k_t*i_ref - B_r*w - drive.tau_load - cog.tau;
    der(e_w) = w_ref - w;
    i_ref = K_pw*(w_ref - w) + K_iw*e_w;
    i_q = i_ref;
    drive.theta_m = phi;
    drive.w_m = w;
    theta_m = phi;
    w_m = w;
    x_jaw = drive.x_jaw;
    lc.F = drive.F_g;
    F_g = lc.F_meas;
  end GripperSpeedControlled;
end Gripper;
