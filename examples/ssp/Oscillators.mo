package Oscillators "Two masses, each in its own FMU, coupled by a spring through their exchanged positions"
  model Body "A mass on a spring and damper to ground, pulled by a coupling spring towards another body and by a force"
    parameter Real m(unit = "kg") = 1 "mass";
    parameter Real k(unit = "N/m") = 100 "spring to ground";
    parameter Real d(unit = "N.s/m") = 0.5 "damper to ground";
    parameter Real c(unit = "N/m") = 20 "coupling spring";
    parameter Real x0(unit = "m") = 0 "initial position";
    input Real x_other(unit = "m", start = 0) "position of the other body";
    input Real F(unit = "N", start = 0) "external force";
    output Real x(unit = "m") "position";
    output Real v(unit = "m/s") "velocity";
  initial equation
    x = x0;
    v = 0;
  equation
    der(x) = v;
    m*der(v) = -k*x - d*v + c*(x_other - x) + F;
  end Body;
end Oscillators;
