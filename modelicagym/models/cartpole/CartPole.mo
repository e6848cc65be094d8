within ;
package ModelicaGym
  "Models of the ModelicaGym toolbox (Lukianykhin and Bogodorova, 2019), Modelica Standard Library 4"

  model CartPole "Classic cart pole: a cart on a frictionless track carrying an inverted pendulum"
    import Modelica.Units.SI;
    constant Real pi = Modelica.Constants.pi;

    parameter SI.Mass m_cart = 10 "Mass of the cart";
    parameter SI.Mass m_pole = 1 "Point mass at the far end of the pole";
    parameter SI.Length length = 2 "Twice the length of the pole cylinder";
    parameter SI.Diameter diameter = 0.05 "Diameter of the pole cylinder";
    parameter SI.Density density = 900 "Density of the pole cylinder (0: point-mass pendulum)";
    parameter SI.Angle theta_0(displayUnit = "deg") = 85/180*pi "Initial pole angle from the +x axis";
    parameter SI.AngularVelocity theta_dot_0 = 0 "Initial pole angular velocity";
    parameter SI.Position x_0 = 0 "Initial cart position";
    parameter SI.Velocity x_dot_0 = 0 "Initial cart velocity";

    Modelica.Blocks.Interfaces.RealInput f(unit = "N") "Force pushing the cart along x"
      annotation (Placement(transformation(extent = {{-140, -20}, {-100, 20}})));
    Modelica.Blocks.Interfaces.RealOutput x(unit = "m") = prismatic.s "Cart position"
      annotation (Placement(transformation(extent = {{100, 70}, {120, 90}})));
    Modelica.Blocks.Interfaces.RealOutput x_dot(unit = "m/s") = prismatic.v "Cart velocity"
      annotation (Placement(transformation(extent = {{100, 30}, {120, 50}})));
    Modelica.Blocks.Interfaces.RealOutput theta(unit = "rad") = rev.phi "Pole angle (upright = pi/2)"
      annotation (Placement(transformation(extent = {{100, -50}, {120, -30}})));
    Modelica.Blocks.Interfaces.RealOutput theta_dot(unit = "rad/s") = rev.w "Pole angular velocity"
      annotation (Placement(transformation(extent = {{100, -90}, {120, -70}})));

    inner Modelica.Mechanics.MultiBody.World world(
      gravityType = Modelica.Mechanics.MultiBody.Types.GravityTypes.UniformGravity,
      g = 9.81,
      n = {0, -1, 0},
      animateWorld = false)
      annotation (Placement(transformation(extent = {{-100, -80}, {-80, -60}})));
    Modelica.Mechanics.MultiBody.Joints.Prismatic prismatic(
      n = {1, 0, 0},
      useAxisFlange = true,
      s(fixed = true, start = x_0),
      v(fixed = true, start = x_dot_0)) "Frictionless track"
      annotation (Placement(transformation(extent = {{-70, -10}, {-50, 10}})));
    Modelica.Mechanics.Translational.Sources.Force force
      annotation (Placement(transformation(extent = {{-90, 20}, {-70, 40}})));
    Modelica.Mechanics.MultiBody.Parts.Body cart(m = m_cart, r_CM = {0, 0, 0}) "The cart"
      annotation (Placement(transformation(extent = {{-40, 20}, {-20, 40}})));
    Modelica.Mechanics.MultiBody.Joints.Revolute rev(
      n = {0, 0, 1},
      phi(fixed = true, start = theta_0),
      w(fixed = true, start = theta_dot_0)) "Pole hinge at the cart's centre"
      annotation (Placement(transformation(extent = {{-30, -10}, {-10, 10}})));
    Modelica.Mechanics.MultiBody.Parts.BodyCylinder poleCylinder(
      r = {length/2, 0, 0},
      diameter = diameter,
      density = density) "Uniform pole, half of length"
      annotation (Placement(transformation(extent = {{10, -10}, {30, 10}})));
    Modelica.Mechanics.MultiBody.Parts.Body poleMass(
      m = m_pole,
      r_CM = {0, 0, 0},
      I_11 = 0.001, I_22 = 0.001, I_33 = 0.001) "Point mass at the pole's end"
      annotation (Placement(transformation(extent = {{50, -10}, {70, 10}})));

  equation
    connect(f, force.f) annotation (Line(points = {{-120, 0}, {-96, 0}, {-96, 30}, {-92, 30}}, color = {0, 0, 127}));
    connect(force.flange, prismatic.axis) annotation (Line(points = {{-70, 30}, {-52, 30}, {-52, 6}}, color = {0, 127, 0}));
    connect(force.support, prismatic.support) annotation (Line(points = {{-80, 20}, {-64, 20}, {-64, 6}}, color = {0, 127, 0}));
    connect(world.frame_b, prismatic.frame_a) annotation (Line(points = {{-80, -70}, {-76, -70}, {-76, 0}, {-70, 0}}, color = {95, 95, 95}, thickness = 0.5));
    connect(prismatic.frame_b, cart.frame_a) annotation (Line(points = {{-50, 0}, {-44, 0}, {-44, 30}, {-40, 30}}, color = {95, 95, 95}, thickness = 0.5));
    connect(prismatic.frame_b, rev.frame_a) annotation (Line(points = {{-50, 0}, {-30, 0}}, color = {95, 95, 95}, thickness = 0.5));
    connect(rev.frame_b, poleCylinder.frame_a) annotation (Line(points = {{-10, 0}, {10, 0}}, color = {95, 95, 95}, thickness = 0.5));
    connect(poleCylinder.frame_b, poleMass.frame_a) annotation (Line(points = {{30, 0}, {50, 0}}, color = {95, 95, 95}, thickness = 0.5));
    annotation (
      experiment(StartTime = 0, StopTime = 10, Interval = 0.05),
      Documentation(info = "<html>
<p>The cart-pole of the ModelicaGym toolbox (ucuapps/modelicagym, resources/ModelicaGym.mo),
restated for MSL 4 with its outputs read from the joint coordinates instead of sensors, and with
the cylinder's diameter/density and the cart's initial state as parameters.
The hand-written C implementation of the same equations is model.c next to this file; its
model descriptions add <code>cs_step_size</code>, the internal RK4 step of co-simulation.</p>
</html>"));
  end CartPole;
end ModelicaGym;
