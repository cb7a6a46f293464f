package ExportTests "Small models with closed-form solutions for the FMU exporter's tests (tests/test_export.py)"
  model Linear "A decay and an undamped oscillator: y = exp(-a t) + sin(w t) / w"
    parameter Real a = 2 "Decay rate";
    parameter Real w = 3 "Angular frequency";
    parameter Real x10 = 1 "Initial value of x1";
    Real x1(start = x10, fixed = true) "Decaying state";
    Real q(start = 0, fixed = true) "Oscillator position";
    Real v(start = 1, fixed = true) "Oscillator velocity";
    output Real y "Decay plus position";
  equation
    der(x1) = -a * x1;
    der(q) = v;
    der(v) = -w ^ 2 * q;
    y = x1 + q;
  end Linear;

  model Stateless "No states: the output is a function of an input and time"
    input Real u(start = 0) "An input";
    output Real y "2 u + 3 time";
  equation
    y = 2 * u + 3 * time;
  end Stateless;

  model Annotated "A decay run as its experiment annotation says: x = exp(-(time - 0.5)) from StartTime 0.5"
    Real x(start = 1, fixed = true) "Decaying state";
  equation
    der(x) = -x;  // not experiment(StopTime = 99): a comment is no annotation
    annotation(experiment(StartTime = 0.5, StopTime = 2.5, Interval = 0.25, Tolerance = 1e-7),
      Documentation(info = "<html>experiment(StopTime = 7)</html>"));
  end Annotated;
end ExportTests;
