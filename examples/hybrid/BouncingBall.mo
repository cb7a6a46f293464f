model BouncingBall "A ball dropped from 1 m onto a floor: a state event, reinit and an Integer output"
  parameter Real e = 0.8 "coefficient of restitution";
  parameter Real g(unit = "m/s2") = 9.81 "gravity";
  output Real h(unit = "m", start = 1, fixed = true) "height above the floor";
  Real v(unit = "m/s", start = 0, fixed = true) "velocity, upwards";
  output Integer bounces(start = 0) "impacts so far";
equation
  der(h) = v;
  der(v) = -g;
  when h < 0 then
    reinit(v, -e*pre(v));
    bounces = pre(bounces) + 1;
  end when;
end BouncingBall;
