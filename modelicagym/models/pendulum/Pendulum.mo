within ;
model Pendulum
  "Pendulum swung up by a geared DC motor through a compliant shaft, with LuGre friction in the motor bearing (the equations of model.c)"
  import Modelica.Units.SI;
  import Modelica.Constants.g_n;
  parameter SI.Mass mass = 1 "Point mass at the end of the pendulum";
  parameter SI.Length length = 0.5 "Pendulum length (pivot to mass)";
  parameter SI.RotationalDampingConstant damping = 0.01 "Viscous damping of the pendulum pivot";
  parameter Real gear_ratio = 15 "Motor turns per pendulum turn";
  parameter SI.ElectricalTorqueConstant k_motor = 0.03 "Torque constant (= back-EMF constant)";
  parameter SI.Resistance resistance = 1 "Armature resistance";
  parameter SI.Inductance inductance = 5e-4 "Armature inductance";
  parameter SI.Inertia j_motor = 2e-5 "Rotor inertia";
  parameter SI.RotationalSpringConstant k_shaft = 50 "Torsional stiffness of the shaft";
  parameter SI.RotationalDampingConstant d_shaft = 0.02 "Torsional damping of the shaft";
  parameter SI.Torque t_coulomb = 5e-3 "Coulomb friction torque of the motor bearing";
  parameter SI.Torque t_stiction = 8e-3 "Static friction torque";
  parameter SI.AngularVelocity v_stribeck = 5 "Stribeck velocity";
  parameter Real sigma0(unit="N.m/rad") = 2 "LuGre bristle stiffness";
  parameter SI.RotationalDampingConstant sigma1 = 5e-3 "LuGre bristle damping";
  parameter SI.RotationalDampingConstant sigma2 = 1e-5 "LuGre viscous friction";
  parameter SI.Angle theta_0 = Modelica.Constants.pi "Initial angle (0 upright)";
  parameter SI.AngularVelocity omega_0 = 0 "Initial angular velocity";
  input SI.Voltage u "Armature voltage";
  output SI.Angle theta(start = theta_0, fixed = true) "Angle from upright";
  output SI.AngularVelocity omega(start = omega_0, fixed = true);
  output SI.Angle twist(start = 0, fixed = true) "Gearbox output angle minus pendulum angle";
  output SI.AngularVelocity omega_m(start = gear_ratio * omega_0, fixed = true) "Motor speed";
  output SI.Current current(start = 0, fixed = true) "Armature current";
  output SI.Angle z(start = 0, fixed = true) "LuGre bristle deflection";
  output Real cos_theta = cos(theta);
  output Real sin_theta = sin(theta);
  SI.Torque friction_torque "LuGre friction on the motor";
  SI.Torque shaft_torque;
protected
  Real g_stribeck(unit="N.m") = t_coulomb + (t_stiction - t_coulomb) * exp(-(omega_m / v_stribeck)^2);
equation
  der(theta) = omega;
  mass * length^2 * der(omega) = mass * g_n * length * sin(theta) - damping * omega + shaft_torque;
  der(twist) = omega_m / gear_ratio - omega;
  shaft_torque = k_shaft * twist + d_shaft * der(twist);
  j_motor * der(omega_m) = k_motor * current - friction_torque - shaft_torque / gear_ratio;
  inductance * der(current) = u - resistance * current - k_motor * omega_m;
  der(z) = omega_m - sigma0 * abs(omega_m) * z / g_stribeck;
  friction_torque = sigma0 * z + sigma1 * der(z) + sigma2 * omega_m;
  annotation (experiment(StartTime = 0, StopTime = 10, Interval = 0.05));
end Pendulum;
