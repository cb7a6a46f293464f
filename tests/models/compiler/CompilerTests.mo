package CompilerTests "Models that exercise the compiler; each test has an independent scipy reference"
  connector Flange "Rotational flange"
    Real phi(unit = "rad") "absolute angle";
    flow Real tau(unit = "N.m") "torque into the component";
  end Flange;

  partial model TwoFlange "Component with two flanges"
    Flange a "driving side";
    Flange b "driven side";
  end TwoFlange;

  model Inertia "Rigid rotating body"
    extends TwoFlange;
    parameter Real J(unit = "kg.m2") = 1 "moment of inertia";
    Real phi(unit = "rad", start = 0) "angle";
    Real w(unit = "rad/s", start = 0) "speed";
  equation
    phi = a.phi;
    phi = b.phi;
    w = der(phi);
    J*der(w) = a.tau + b.tau;
  end Inertia;

  model IdealGear "Ideal gear, phi_a = ratio*phi_b"
    extends TwoFlange;
    parameter Real ratio = 2 "transmission ratio";
  equation
    a.phi = ratio*b.phi;
    0 = ratio*a.tau + b.tau;
  end IdealGear;

  model Backlash "Spring with a dead band (play), no events"
    extends TwoFlange;
    parameter Real c(unit = "N.m/rad") = 50 "stiffness in contact";
    parameter Real b_play(unit = "rad") = 0.02 "total play";
    Real d(unit = "rad") "relative angle";
    Real tau(unit = "N.m") "transmitted torque";
  equation
    d = b.phi - a.phi;
    tau = noEvent(if d > b_play/2 then c*(d - b_play/2) else if d < -b_play/2 then c*(d + b_play/2) else 0);
    b.tau = tau;
    a.tau = -tau;
  end Backlash;

  model TanhFriction "Regularised Coulomb friction to ground"
    Flange a;
    parameter Real tau_c(unit = "N.m") = 0.3 "Coulomb torque";
    parameter Real w_s(unit = "rad/s") = 0.1 "regularisation speed";
  equation
    a.tau = tau_c*tanh(der(a.phi)/w_s);
  end TanhFriction;

  model TorqueSource "Torque from an input"
    Flange b;
    input Real tau(unit = "N.m") "applied torque";
  equation
    b.tau = -tau;
  end TorqueSource;

  model MassSpringDamper "m*der(v) = F - k*x - d*v"
    parameter Real m(unit = "kg") = 0.5 "mass";
    parameter Real k(unit = "N/m") = 200 "stiffness";
    parameter Real d(unit = "N.s/m") = 1.5 "damping";
    input Real F(unit = "N", start = 0) "applied force";
    output Real x(unit = "m", start = 0.01) "position";
    Real v(unit = "m/s", start = 0) "velocity";
  equation
    der(x) = v;
    m*der(v) = F - k*x - d*v;
  end MassSpringDamper;

  model Drive "Motor inertia, ideal gear, gear-side inertia, play, load inertia, friction"
    input Real tau_m(unit = "N.m", start = 0) "motor torque";
    output Real w_load(unit = "rad/s") "load speed";
    output Real w_motor(unit = "rad/s") "motor speed";
    TorqueSource src;
    Inertia motor(J = 0.01);
    IdealGear gear(ratio = 4);
    Inertia gearside(J = 0.02);
    Backlash play;
    Inertia load(J = 0.3);
    TanhFriction friction;
  equation
    connect(src.b, motor.a);
    connect(motor.b, gear.a);
    connect(gear.b, gearside.a);
    connect(gearside.b, play.a);
    connect(play.b, load.a);
    connect(load.b, friction.a);
    src.tau = tau_m;
    w_load = load.w;
    w_motor = motor.w;
  end Drive;

  function dqTorque "Electromagnetic torque of a PMSM, amplitude-invariant Park transform"
    input Real i_d;
    input Real i_q;
    input Real p "pole pairs";
    input Real psi "flux linkage";
    input Real Ld;
    input Real Lq;
    output Real tau;
  protected
    Real reluctance;
  algorithm
    reluctance := (Ld - Lq)*i_d*i_q;
    tau := 1.5*p*(psi*i_q + reluctance);
  end dqTorque;

  model PMSM "d-q permanent-magnet synchronous motor with a load torque"
    parameter Integer p = 4 "pole pairs";
    parameter Real Rs(unit = "Ohm") = 0.45 "stator resistance";
    parameter Real Ld(unit = "H") = 0.3e-3 "d inductance";
    parameter Real Lq(unit = "H") = 0.25e-3 "q inductance";
    parameter Real psi(unit = "Wb") = 0.0066 "flux linkage";
    parameter Real J(unit = "kg.m2") = 1e-5 "rotor inertia";
    parameter Real B(unit = "N.m.s/rad") = 1e-5 "viscous damping";
    input Real v_d(unit = "V", start = 0) "d voltage";
    input Real v_q(unit = "V", start = 0) "q voltage";
    input Real tau_load(unit = "N.m", start = 0) "load torque";
    output Real i_d(unit = "A", start = 0) "d current";
    output Real i_q(unit = "A", start = 0) "q current";
    output Real w(unit = "rad/s", start = 0) "mechanical speed";
    Real theta(unit = "rad", start = 0) "mechanical angle";
    Real we(unit = "rad/s") "electrical speed";
    Real tau_e(unit = "N.m") "electromagnetic torque";
  equation
    we = p*w;
    Ld*der(i_d) = v_d - Rs*i_d + we*Lq*i_q;
    Lq*der(i_q) = v_q - Rs*i_q - we*(Ld*i_d + psi);
    tau_e = dqTorque(i_d, i_q, p, psi, Ld, Lq);
    J*der(w) = tau_e - B*w - tau_load;
    der(theta) = w;
  end PMSM;

  model AlgebraicChain "Outputs computed through a chain of algebraic variables"
    input Real u(unit = "1", start = 0) "input";
    output Real x(unit = "1", start = 0.5) "state that is also an output";
    output Real y1(unit = "1") "2 x";
    output Real y2(unit = "1") "y1 + sin(x)";
    output Real y3(unit = "1") "y2 * y1";
    Real a(unit = "1");
  equation
    y3 = y2*y1;
    y2 = y1 + sin(x);
    a = y1/2;
    y1 = 2*x;
    der(x) = -a + u;
  end AlgebraicChain;

  model NonlinearLoop "z + sin(z) = x has no explicit solution: Newton"
    input Real u(unit = "1", start = 0) "input";
    output Real z(unit = "1", start = 0) "implicit variable";
    Real x(unit = "1", start = 1) "state";
    Real w(unit = "1");
  equation
    z + sin(z) + 0.2*w = x;
    w = z^3 + z;
    der(x) = -z + u;
  end NonlinearLoop;

  model DependentParameters "Dependent parameters follow a tunable one"
    parameter Real k(unit = "1/s") = 2 "base rate";
    parameter Real c(unit = "1/s") = k*k + 1 "dependent rate";
    parameter Real c2(unit = "1/s") = 0.5*c "depends on a dependent one";
    output Real x(unit = "1", start = 1) "decays at rate c2";
  equation
    der(x) = -c2*x;
  end DependentParameters;

  partial model Decay "Shared decay law"
    parameter Real x0(unit = "m") = 0.25 "initial position";
    parameter Integer n = 1 "integer rate";
    Real x(unit = "m") "state";
  equation
    der(x) = -n*x + smooth(1, max(0.1, abs(x)))*sign(x)*exp(-x*x) + atan2(x, 2)*sqrt(1 + x*x) - log(1 + x*x) + min(x, 0);
  end Decay;

  model InitialAndInteger "extends a partial model; Integer parameter; initial equation"
    extends Decay(n = 3);
    output Real y(unit = "m") "position";
  initial equation
    x = 2*x0;
  equation
    y = x;
  end InitialAndInteger;

  model PlainIf "An if on a state without noEvent: a state event (a hybrid model)"
    output Real x(unit = "1", start = 1);
  equation
    der(x) = if x > 0.5 then -x else -0.5*x;
  end PlainIf;

  function relaxRate "Rate of a state relaxing towards u over a time constant tc; two locals"
    input Real u;
    input Real x;
    input Real tc;
    output Real r;
  protected
    Real e;
    Real g;
  algorithm
    e := u - x;
    g := 1/tc;
    r := g*e*abs(e);
  end relaxRate;

  model TwoCalls "One function called at two sites with different arguments (each inlined with its own)"
    parameter Real u1 = 1.0;
    parameter Real u2 = -0.5;
    output Real x1(start = 0.2, fixed = true);
    output Real x2(start = 0.3, fixed = true);
  equation
    der(x1) = relaxRate(u1, x1, 0.5);
    der(x2) = relaxRate(u2, x2, 2.0);
  end TwoCalls;
end CompilerTests;
