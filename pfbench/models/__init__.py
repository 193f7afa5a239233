"""Models that worlds (scenarios) and filters share: a world simulates with them, a filter
weighs and predicts with them, and neither imports the other.

- ``scalar``: the scalar state-space model (``ScalarModel``, the model-function signature, the
  process noise);
- ``odometry``: the odometry motion model of a wheeled robot, with its noise;
- ``beacons``: the range (and bearing) sensor of known beacons: simulation, likelihood, and poses
  drawn from it;
- ``pose``: beliefs over a robot's pose on a field: the initial particles and the weighted mean
  pose.
"""
