package Hybrid "Hybrid test models; each test has an independent reference (closed form, scipy, hand-computed)"
  model BouncingBall "Ball dropped from h = 1 m; restitution e; counts its bounces"
    parameter Real e = 0.8 "coefficient of restitution";
    parameter Real g(unit = "m/s2") = 9.81 "gravity";
    Real h(unit = "m", start = 1, fixed = true) "height";
    Real v(unit = "m/s", start = 0, fixed = true) "velocity";
    output Integer bounces(start = 0) "number of bounces";
  equation
    der(h) = v;
    der(v) = -g;
    when h < 0 then
      reinit(v, -e*pre(v));
      bounces = pre(bounces) + 1;
    end when;
  end BouncingBall;

  model Thermostat "Room heated on/off between Tlo and Thi (hysteresis); counts the switchings"
    parameter Real Tlo(unit = "degC") = 19 "heater on below";
    parameter Real Thi(unit = "degC") = 21 "heater off above";
    parameter Real P(unit = "K/s") = 2 "heating rate";
    parameter Real k(unit = "1/s") = 0.1 "loss rate";
    parameter Real Ta(unit = "degC") = 10 "ambient";
    Real T(unit = "degC", start = 20, fixed = true) "room temperature";
    Boolean on(start = false) "heater on";
    output Integer switches(start = 0) "number of switchings";
  equation
    der(T) = (if on then P else 0) - k*(T - Ta);
    when {T < Tlo, initial()} then
      on = true;
    elsewhen T > Thi then
      on = false;
    end when;
    when change(on) then
      switches = pre(switches) + 1;
    end when;
  end Thermostat;

  model SampleHold "x = exp(-t) sampled at 0.1 + 0.2 k and held"
    Real x(start = 1, fixed = true);
    discrete Real s(start = 0) "held sample";
    output Real y "the held sample, as a continuous output";
  equation
    der(x) = -x;
    when sample(0.1, 0.2) then
      s = x;
    end when;
    y = s;
  end SampleHold;

  model StepCounter "Counts the instants period, 2 period, ... with a relation on time and a discrete Real"
    parameter Real period(unit = "s") = 0.25;
    discrete Real next(unit = "s", start = 0.25) "next instant";
    output Integer steps(start = 0) "instants passed";
  equation
    when time >= next then
      next = pre(next) + period;
      steps = pre(steps) + 1;
    end when;
  end StepCounter;

  model TimeSwitch "A plain if on time: x = max(0, t - t_on)"
    parameter Real t_on(unit = "s") = 0.35;
    Real x(start = 0, fixed = true);
  equation
    der(x) = if time > t_on then 1 else 0;
  end TimeSwitch;

  model StateIf "A plain if on a state: der(x) = -x above 0.5, -0.5 x below"
    output Real x(start = 1, fixed = true);
  equation
    der(x) = if x > 0.5 then -x else -0.5*x;
  end StateIf;

  model Overheat "T rises at 1 K/s; the assert fails at T = 0.5, a when-clause would terminate at 0.7"
    Real T(start = 0, fixed = true);
  equation
    der(T) = 1;
    assert(T < 0.5, "temperature above limit");
    when T > 0.7 then
      terminate("done heating");
    end when;
  end Overheat;

  model Stop "terminate() in a when-clause at T = 0.7"
    Real T(start = 0, fixed = true);
  equation
    der(T) = 1;
    when T > 0.7 then
      terminate("done heating");
    end when;
  end Stop;

  type Direction = enumeration(Up "rising", Down "falling");

  model Relay "x runs between 0.1 and 0.9 at 1/s; the direction (an enumeration) flips where y = 2 x leaves
    [0.2, 1.8] (a vector when on an algebraic variable); rises counts the edges of up"
    Real x(start = 0.5, fixed = true);
    Real y "an algebraic variable the events read";
    Direction dir(start = Direction.Up);
    Boolean up "dir == Up, a Boolean without when";
    Integer rises(start = 0);
    Boolean late "time > 0.9";
  equation
    y = 2*x;
    der(x) = if dir == Direction.Up then 1 else -1;
    when {y > 1.8, y < 0.2} then
      dir = if y > 1 then Direction.Down else Direction.Up;
    end when;
    up = dir == Direction.Up;
    when edge(up) then
      rises = pre(rises) + 1;
    end when;
    late = time > 0.9;
  end Relay;

  model LoopEvent "z + 0.5 sin(z) = x (Newton) with x = t; the when-clause samples x where z passes 0.5"
    Real x(start = 0, fixed = true);
    Real z(start = 0);
    discrete Real xc(start = -1) "x where z passed 0.5";
  equation
    der(x) = 1;
    z + 0.5*sin(z) = x;
    when z > 0.5 then
      xc = x;
    end when;
  end LoopEvent;

  model NoEvents "noEvent and smooth: relations evaluated directly; the model stays continuous"
    Real x(start = 1, fixed = true);
  equation
    der(x) = noEvent(if x > 0.5 then -x else -0.5*x) + smooth(0, if x > 2 then x - 2 else 0);
  end NoEvents;

  model Branches "elsewhen with a discrete Real and a reinit in each branch; an if inside an algorithm when
    (a guard) on sample(0, 0.3); x = 1 - t"
    Real x(start = 1, fixed = true);
    Real v(start = 2, fixed = true);
    discrete Real d(start = 0);
    Integer ticks(start = 0);
    Integer low(start = 0) "ticks with x < 0.5";
  equation
    der(x) = -1;
    der(v) = 0;
    when x < 0.5 then
      d = pre(x);
      reinit(v, 3);
    elsewhen x < 0.2 then
      d = 2;
      reinit(v, 4);
    end when;
  algorithm
    when sample(0, 0.3) then
      ticks := pre(ticks) + 1;
      if x < 0.5 then
        low := pre(low) + 1;
      end if;
    end when;
  end Branches;

  model InitialWhen "when initial() fires once, at initialisation"
    Real x(start = 0, fixed = true);
    Integer n(start = 5);
  equation
    der(x) = 1;
    when initial() then
      n = pre(n) + 1;
    end when;
  end InitialWhen;

  model IfEquation "An if-equation with a branch on a state and one on time"
    Real x(start = 1, fixed = true);
    Real y;
  equation
    der(x) = -y;
    if x > 0.5 then
      y = x;
    elseif time < 0.9 then
      y = 0;
    else
      y = 0.5*x;
    end if;
  end IfEquation;

  model InitialValues "Initial equations of discrete variables: an Integer from a parameter, a Real from a state"
    parameter Integer k0 = 3;
    Real x(start = 1.5, fixed = true);
    Integer k;
    discrete Real d;
  initial equation
    k = k0;
    d = 2*x;
  equation
    der(x) = -x;
    when x < 1 then
      k = pre(k) + 1;
      d = x;
    end when;
  end InitialValues;

  model Inputs "Boolean and Integer inputs: a when on a Boolean input, an Integer input in an equation"
    input Boolean b;
    input Integer k;
    output Integer n(start = 0) "rising edges of b";
    Real x(start = 0, fixed = true);
  equation
    der(x) = k;
    when b then
      n = pre(n) + 1;
    end when;
  end Inputs;

  model Terminal "when terminal(): the last value of x = exp(-t) kept, a counter raised once"
    Real x(start = 1, fixed = true);
    discrete output Real x_end(start = 0, fixed = true);
    output Integer n_end(start = 0, fixed = true);
    output Real y = 2 * x_end;
  equation
    der(x) = -x;
    when terminal() then
      x_end = x;
    end when;
    when terminal() then
      n_end = pre(n_end) + 1;
    end when;
  end Terminal;
end Hybrid;
