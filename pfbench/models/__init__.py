"""The models layer: every kind's model type, and the robot code that worlds (scenarios) and
filters share. A scenario builds a model and simulates with it; a filter weighs and predicts
with it; neither imports the other (docs/internals/layers.md).

- ``scalar``: the scalar kind's ``ScalarModel`` (the model-function signature, the process
  noise) and its simulator;
- ``slam``: the SLAM kind's ``SlamModel`` (a waypoint course among point landmarks), a trial's
  ``CourseData``, the landmark sensor and the two vehicles' simulators;
- ``field``: the localization kind's ``FieldModel`` (a beacon field), a trial's ``FieldData``
  and its simulator, kidnappings included;
- ``odometry``: the odometry motion model of a wheeled robot, with its noise;
- ``beacons``: the range (and bearing) sensor of known beacons: simulation, likelihood, and poses
  drawn from it;
- ``waypoints``: driving a closed path of waypoints;
- ``pose``: beliefs over a robot's pose on a field: the initial particles and the weighted mean
  pose.
"""
