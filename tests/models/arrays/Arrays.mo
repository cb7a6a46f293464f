package Arrays "Array, loop, function and initialisation test models of the compiler (tests/test_compiler_arrays.py, tests/test_compiler_initial.py)"

  function horner "Polynomial c[1]*x^(n-1) + ... + c[n], by Horner's rule over the array argument"
    input Real c[:];
    input Real x;
    output Real y;
  algorithm
    y := 0;
    for i in 1:size(c, 1) loop
      y := y*x + c[i];
    end for;
  end horner;

  function norm2 "Euclidean norm with a local accumulator"
    input Real v[:];
    output Real n;
  protected
    Real s;
  algorithm
    s := 0;
    for i in 1:size(v, 1) loop
      s := s + v[i]^2;
    end for;
    n := sqrt(s);
  end norm2;

  function clip "Saturation by an if statement"
    input Real x;
    input Real lim;
    output Real y;
  algorithm
    if x > lim then
      y := lim;
    elseif x < -lim then
      y := -lim;
    else
      y := x;
    end if;
  end clip;

  function cumulative "Running sums: an array result assigned element by element in a loop"
    input Real v[:];
    output Real w[size(v, 1)];
  algorithm
    w[1] := v[1];
    for i in 2:size(v, 1) loop
      w[i] := w[i - 1] + v[i];
    end for;
  end cumulative;

  function positives "Sum and product of the positive elements, and twice each element in a local array"
    input Real v[:];
    output Real total;
    output Real prod;
  protected
    Real t[size(v, 1)];
  algorithm
    total := 0;
    prod := 1;
    for i in 1:size(v, 1) loop
      t[i] := 2*v[i];
      if v[i] > 0 then
        total := total + v[i];
        prod := prod*v[i];
      end if;
    end for;
    total := total + sum(t);
  end positives;

  function pairs "Nested loops, and an if statement whose branch reads a value it assigned"
    input Real v[:];
    output Real a;
    output Real b;
  algorithm
    a := 0;
    b := 0;
    for i in 1:size(v, 1) loop
      for j in 1:i loop
        a := a + v[i]*v[j];
      end for;
      if v[i] > 0 then
        b := b + v[i];
        a := a + b;
      else
        b := b - 1;
      end if;
    end for;
  end pairs;

  model Rod "Heat conduction along a rod of N cells: held temperature at the left end, loss to ambient at the right"
    parameter Integer N = 10 "number of cells";
    parameter Real C = 2.0 "heat capacity of one cell [J/K]";
    parameter Real G = 5.0 "thermal conductance between neighbouring cells [W/K]";
    parameter Real G_amb = 0.5 "conductance from the last cell to ambient [W/K]";
    parameter Real T_left = 400 "temperature held at the left end [K]";
    parameter Real T_amb = 300 "ambient temperature [K]";
    Real T[N](each start = 300) "cell temperatures [K]";
    Real Q_left "heat flow into the left end [W]";
    Real T_mean "mean temperature [K]";
  equation
    Q_left = G*(T_left - T[1]);
    C*der(T[1]) = Q_left - G*(T[1] - T[2]);
    for i in 2:N - 1 loop
      C*der(T[i]) = G*(T[i - 1] - 2*T[i] + T[i + 1]);
    end for;
    C*der(T[N]) = G*(T[N - 1] - T[N]) - G_amb*(T[N] - T_amb);
    T_mean = sum(T)/N;
  end Rod;

  model RodSteady "The rod started at its steady state"
    extends Rod;
  initial equation
    der(T) = zeros(N);
  end RodSteady;

  model LinearSystem "Matrix-vector products, array parameters and the array built-ins"
    parameter Integer n = 3;
    parameter Real A[n, n] = [-2, 1, 0; 0.5, -3, 1; 0, 1, -1.5];
    parameter Real b[n] = linspace(1, 2, n);
    parameter Real c[n] = {1, -1, 2};
    parameter Real w[n] = fill(0.25, n);
    input Real u;
    Real x[n](start = {1, 0.5, -0.5});
    output Real y "c'x";
    output Real s "sum(x) + w'x";
    output Real last "x[n] through a parameter subscript";
    output Real row[n] "A[2, :] .* x elementwise, in a for equation";
    output Real pair[2] "A[1:2, 2:3]*x[2:3]";
  equation
    der(x) = A*x + b*u;
    y = c*x;
    s = sum(x) + w*x + sum(ones(n)) - size(A, 1) + sum(zeros(n));
    last = x[n];
    for i in 1:n loop
      row[i] = A[2, i]*x[i];
    end for;
    pair = A[1:2, 2:3]*x[2:3];
  end LinearSystem;

  model MoreArrays "cat, skew, a reduction, a matrix row, matrix states, nested for-equations, an if on the loop index"
    parameter Integer N = 4;
    parameter Real A[2, 2] = [1, 2; 3, 4];
    parameter Real v[3] = {1, 2, 3};
    Real m[2, 2](start = [1, 0; 0.5, 2]);
    Real chain[N](each start = 1);
    output Real joined[5];
    output Real weighted;
    output Real row[2];
    output Real sk[3, 3];
    output Real grid[2, 3];
  equation
    der(m) = -A*m;
    for i in 1:N loop
      if i == 1 then
        der(chain[i]) = -chain[i];
      else
        der(chain[i]) = chain[i - 1] - chain[i];
      end if;
    end for;
    joined = cat(1, v, {7, 8});
    weighted = sum(chain[i]*i for i in 1:N);
    row = A[2];
    sk = skew(v);
    for i in 1:2 loop
      for j in 1:3 loop
        grid[i, j] = i*10 + j + m[i, 1];
      end for;
    end for;
  end MoreArrays;

  model FunctionLoops "Functions with for loops over array arguments, if statements and array results"
    parameter Real c[4] = {0.5, -1, 2, 3};
    Real x(start = 0.2);
    output Real p "horner(c, x)";
    output Real n "norm2({x, 2x, cos(time)})";
    output Real k "clip(x, 0.3)";
    output Real cs[4] "cumulative(c)";
    output Real tot;
    output Real prod;
    output Real pa;
    output Real pb;
  equation
    der(x) = 1 - x + 0.5*sin(3*time);
    (pa, pb) = pairs({x, -2*x, 3, x - 2});
    p = horner(c, x);
    n = norm2({x, 2*x, cos(time)});
    k = clip(x, 0.3);
    cs = cumulative(c);
    (tot, prod) = positives({x - 0.5, 2, -1, x});
  end FunctionLoops;

  model Tank "Tank with outflow through an orifice, started at its level of equilibrium (a nonlinear initial problem)"
    parameter Real A = 2.0 "cross-section [m2]";
    parameter Real q = 0.3 "inflow [m3/s]";
    parameter Real a = 0.2 "outflow coefficient [m2.5/s]";
    Real h(start = 1) "level [m]";
    Real q_out "outflow [m3/s]";
  equation
    q_out = a*sqrt(h);
    A*der(h) = q - q_out;
  initial equation
    der(h) = 0;
  end Tank;

  model Mixed "Initial equations mixing a state, derivatives, an algebraic variable and parameters"
    parameter Real m = 1.5;
    parameter Real k = 100;
    parameter Real d = 3;
    parameter Real F = 5;
    Real x(start = 0.3);
    Real v(start = 1);
    Real w(start = 0, fixed = true);
    Real spring "spring force [N]";
  equation
    der(x) = v;
    m*der(v) = F - spring - d*v;
    spring = k*x;
    der(w) = -w + x;
  initial equation
    der(v) = 0;
    spring + 2*der(x) = F;
  end Mixed;

  model Indirect "An initial equation on der() of an expression and one on an algebraic variable: the states they
    depend on through them are determined, in declaration order"
    parameter Real k = 2;
    Real x1(start = 1);
    Real x2(start = 0.5);
    Real y(start = 3);
    Real z(start = 1);
    Real power "algebraic";
  equation
    der(x1) = -k*x1 + 1;
    der(x2) = x1 - x2;
    power = y^2;
    der(y) = -y;
    der(z) = -z;
  initial equation
    der(x1 - x2) = 0;
    power = 4*k;
  end Indirect;

  model Explicit "Initial equations that fix states from parameters (solved explicitly, as before)"
    parameter Real x0 = 0.4;
    Real x;
    Real y(start = 2);
  equation
    der(x) = -x;
    der(y) = -2*y;
  initial equation
    x = 2*x0;
  end Explicit;

  model DerExpression "der() of expressions: two inertias coupled by a spring-damper on der(phi2 - phi1), and der(k*z)"
    parameter Real J1 = 0.5 "inertia 1 [kg.m2]";
    parameter Real J2 = 1.5 "inertia 2 [kg.m2]";
    parameter Real c = 40 "spring stiffness [N.m/rad]";
    parameter Real d = 0.8 "damping [N.m.s/rad]";
    parameter Real k = 2;
    parameter Real tau = 1 "torque on inertia 1 [N.m]";
    Real phi1(start = 0);
    Real phi2(start = 0.1);
    Real w1(start = 0);
    Real w2(start = 0);
    Real rate "relative speed der(phi2 - phi1) [rad/s]";
    Real z(start = 1);
  equation
    der(phi1) = w1;
    der(phi2) = w2;
    rate = der(phi2 - phi1);
    J1*der(w1) = tau + c*(phi2 - phi1) + d*rate;
    J2*der(w2) = -c*(phi2 - phi1) - d*rate;
    der(k*z) = -z;
  end DerExpression;

end Arrays;
