package Lookup "a stand-in for the MSL's table lookups: a parameter bound to a lookup in an array argument"
  function getTable1DValueNoDer2 "linear interpolation between the first two rows of table"
    input Real table[:, :];
    input Integer icol;
    input Real u;
    output Real y;
  algorithm
    y := table[1, icol + 1] + (u - table[1, 1])*(table[2, icol + 1] - table[1, icol + 1])/(table[2, 1] - table[1, 1]);
  end getTable1DValueNoDer2;

  model Ramp "x = p*t with p the table's value at u = 0.5 (0.6)"
    parameter Real tableID[:, 2] = [0, 0.5; 1, 0.7];
    final parameter Real p = getTable1DValueNoDer2(tableID, 1, 0.5) "slope";
    Real x(start = 0, fixed = true);
  equation
    der(x) = p;
  end Ramp;
end Lookup;
