model DcDrive
  "24 V permanent-magnet DC motor, 28:1 gear head with losses and play, load inertia and load torque; all MSL 4.1.0 components"
  // Motor: the order of a 24 V Maxon RE-series brushed motor of 35-40 mm (data sheets of the RE 35 / RE 40 class:
  // terminal resistance 0.3-1.1 Ohm, terminal inductance 0.08-0.3 mH, torque constant 20-40 mN.m/A, rotor inertia
  // 70-140 g.cm2). Round values in those ranges, not one data sheet: change them to your motor's.
  parameter Modelica.Units.SI.Resistance R = 1.0 "armature (terminal) resistance";
  parameter Modelica.Units.SI.Inductance L = 2e-4 "armature (terminal) inductance";
  parameter Real k(unit="N.m/A") = 0.03 "torque constant = back-EMF constant (V.s/rad)";
  parameter Modelica.Units.SI.Inertia J_m = 1e-5 "rotor inertia (100 g.cm2)";
  parameter Modelica.Units.SI.Voltage V_nom = 24 "nominal voltage (the supply)";
  parameter Modelica.Units.SI.Current I_nom = 2 "nominal (max. continuous) current";
  // Gear head: a two-stage planetary gear of ratio 28 (Maxon GP 32 class). Its losses as a viscous torque on the
  // motor shaft: d_g = 1.7e-5 N.m.s/rad takes 0.007 N.m at 4000 rpm, about 17 % of the rated-point torque, i.e. the
  // 80-85 % efficiency such a gear head gives at its rated point (MSL LossyGear does not build with cosim yet).
  parameter Real ratio = 28 "gear ratio, motor speed / output speed";
  parameter Modelica.Units.SI.RotationalDampingConstant d_g = 1.7e-5 "gear loss, viscous, at the motor shaft";
  // Gear play and output stiffness: the no-load backlash of a small planetary head is 0.7-1 deg at the output;
  // stiffness and damping of the output shaft are assumptions (no data sheet gives them).
  parameter Modelica.Units.SI.RotationalSpringConstant c_g = 1000 "output torsional stiffness (assumption)";
  parameter Modelica.Units.SI.RotationalDampingConstant d_c = 1 "output torsional damping (assumption)";
  // Load: a 0.33 kg, 0.3 m link swung about its end (m l^2 / 3 = 0.01 kg.m2), and a load torque step (a payload).
  parameter Modelica.Units.SI.Inertia J_L = 0.01 "load inertia";
  parameter Modelica.Units.SI.Torque T_L = 1 "load torque from t_L on, opposing positive rotation";
  parameter Modelica.Units.SI.Time t_L = 0.2 "time of the load torque step";

  Modelica.Electrical.Machines.BasicMachines.DCMachines.DC_PermanentMagnet dcpm(
    VaNominal=V_nom, IaNominal=I_nom, wNominal=(V_nom - R*I_nom)/k, TaNominal=293.15, Ra=R, TaRef=293.15,
    alpha20a=0, La=L, Jr=J_m, useSupport=false, Js=J_m, TaOperational=293.15,
    phiMechanical(fixed=true), wMechanical(fixed=true), ia(fixed=true))
    "wNominal is chosen so that the machine's flux (V_nom - R I_nom) / wNominal is k; no friction, core, stray or brush losses";
  Modelica.Electrical.Analog.Sources.SignalVoltage source "the H-bridge (averaged over a PWM period)";
  Modelica.Electrical.Analog.Basic.Ground ground;
  Modelica.Mechanics.Rotational.Components.IdealGear gear(ratio=ratio);
  Modelica.Mechanics.Rotational.Components.Damper gearLoss(d=d_g);
  Modelica.Mechanics.Rotational.Components.Fixed housing;
  Modelica.Mechanics.Rotational.Components.ElastoBacklash backlash(c=c_g, d=d_c, b=0.0175)
    "play b = 1 deg (0.0175 rad) at the output";
  Modelica.Mechanics.Rotational.Components.Inertia load(J=J_L, phi(start=0, fixed=true), w(start=0, fixed=true));
  Modelica.Mechanics.Rotational.Sources.TorqueStep loadTorque(stepTorque=-T_L, startTime=t_L);
  input Real v(unit="V") "armature voltage";
  output Real i_a(unit="A") "armature current (what the current loop measures)";
  output Real w_m(unit="rad/s") "motor speed (what the speed loop measures)";
  output Real phi_load(unit="rad") "load angle";
equation
  source.v = v;
  connect(source.p, dcpm.pin_ap);
  connect(source.n, dcpm.pin_an);
  connect(source.n, ground.p);
  connect(dcpm.flange, gear.flange_a);
  connect(dcpm.flange, gearLoss.flange_a);
  connect(gearLoss.flange_b, housing.flange);
  connect(gear.flange_b, backlash.flange_a);
  connect(backlash.flange_b, load.flange_a);
  connect(load.flange_b, loadTorque.flange);
  i_a = dcpm.ia;
  w_m = dcpm.wMechanical;
  phi_load = load.phi;
end DcDrive;
