"""The numeric codes of pfbench's categorical choices, each defined once: the kernels compare with
these names (``o.reset == RESET_AUGMENTED``, never ``o.reset == 3``), and the mappings from a
config's names to codes (``RESET``, ``SCHEME_CODES``, ...) are built from them. The numbers are
what the jitted kernels branch on; numba reads these module globals as compile-time constants.
"""
from __future__ import annotations

# Resampling schemes (pfbench.resampling.SCHEMES), then the stepwise EWA (ifa2021; the swarm PFs
# and FastSLAM) and FastSLAM's directional resampling (afsa2014), which extend the numbering.
SCHEME_MULTINOMIAL = 0
SCHEME_SYSTEMATIC = 1
SCHEME_STRATIFIED = 2
SCHEME_RESIDUAL = 3
STEPWISE_EWA = 4
DIRECTIONAL = 5
SCHEME_CODES = {"multinomial": SCHEME_MULTINOMIAL, "systematic": SCHEME_SYSTEMATIC,
                "stratified": SCHEME_STRATIFIED, "residual": SCHEME_RESIDUAL}

# MCL's particle injection (key ``reset``).
RESET_NONE = 0
RESET_SRL = 1
RESET_ASRL = 2
RESET_AUGMENTED = 3
RESET = {"none": RESET_NONE, "srl": RESET_SRL, "asrl": RESET_ASRL, "augmented": RESET_AUGMENTED}

# The field SSPF's resampling trigger (key ``resample``).
TRIGGER_ALWAYS = 0
TRIGGER_NEFF = 1
TRIGGER_WEIGHT_CHANGE = 2
TRIGGERS = {"always": TRIGGER_ALWAYS, "neff": TRIGGER_NEFF, "weight_change": TRIGGER_WEIGHT_CHANGE}

# The swarm algorithms, one numbering for every kernel that moves particles with them.
FA = 0
IFA = 1
BA = 2
PSO = 3
AFSA = 4
NO_SWARM = -1
ALGORITHMS = {"fa": FA, "ifa": IFA, "ba": BA, "pso": PSO, "afsa": AFSA}

# The beacon field's motion model (scenario key ``motion``) and sensor (``sensor``).
MOTION_ODOMETRY = 0         # sspf2008's (T, dtheta) with additive Gaussian noise
MOTION_ROT_TRANS_ROT = 1    # asrl2008's rot-trans-rot, noise growing with the motion
FIELD_MOTIONS = {"odometry": MOTION_ODOMETRY, "rot_trans_rot": MOTION_ROT_TRANS_ROT}
SENSOR_RANGE = 0
SENSOR_RANGE_BEARING = 1
SENSORS = {"range": SENSOR_RANGE, "range_bearing": SENSOR_RANGE_BEARING}

# A SLAM model's vehicle: the steered vehicle of the waypoint course, or odometry.
SLAM_STEERED = 0
SLAM_ODOMETRY = 1

# A scalar model's process noise (ScalarModel.noise[0]).
NOISE_GAUSSIAN = 0
NOISE_GAMMA = 1

# IFA's brightness of a particle from its distance d (swarm PFs' key ``brightness``).
BRIGHTNESS_GAUSSIAN = 0     # exp(-d^2 / 2)
BRIGHTNESS_INVERSE = 1      # 1 / (1 + d)
BRIGHTNESS_LIKELIHOOD = 2   # exp(ll - max ll): the likelihood of the measurement alone
BRIGHTNESS_DISTANCE = 3     # -d: the distance itself, smaller brighter (see swarm.ifa_move)
BRIGHTNESS = {"gaussian": BRIGHTNESS_GAUSSIAN, "inverse": BRIGHTNESS_INVERSE,
              "likelihood": BRIGHTNESS_LIKELIHOOD, "distance": BRIGHTNESS_DISTANCE}

# The firefly moves' random term (FA's and IFA's key ``random_term``), per coordinate.
RANDOM_UNIFORM_HALF = 0     # u - 0.5, u ~ U(0, 1): pfbench's
RANDOM_UNIFORM_SQRT3 = 1    # U(-sqrt 3, sqrt 3): mean 0, variance 1, a uniform (ifa2021's words)
RANDOM_GAUSSIAN = 2         # N(0, 1)
RANDOM_NONE = 3             # no random term (no draw)
RANDOM_TERMS = {"uniform_half": RANDOM_UNIFORM_HALF, "uniform_sqrt3": RANDOM_UNIFORM_SQRT3,
                "gaussian": RANDOM_GAUSSIAN, "none": RANDOM_NONE}

# Which fireflies a firefly moves toward (FA's and IFA's key ``move_toward``).
TOWARD_BRIGHTER_IN_PLACE = 0    # every brighter one, in place (later ones see moved ones)
TOWARD_BRIGHTER_ALL_AT_ONCE = 1  # every brighter one, from the positions at the iteration's start
TOWARD_BRIGHTEST = 2            # the brightest one only
MOVE_TOWARD = {"brighter_in_place": TOWARD_BRIGHTER_IN_PLACE,
               "brighter_all_at_once": TOWARD_BRIGHTER_ALL_AT_ONCE,
               "brightest": TOWARD_BRIGHTEST}

# The scalar swarm PFs' weights after the move (key ``move_correction``) and the order of the
# move and the resampling (key ``move_order``).
CORRECTION_NONE = 0
CORRECTION_PRIOR_RATIO = 1
MOVE_CORRECTIONS = {"none": CORRECTION_NONE, "prior_ratio": CORRECTION_PRIOR_RATIO}
ORDER_MOVE_THEN_RESAMPLE = 0
ORDER_RESAMPLE_THEN_MOVE = 1
MOVE_ORDERS = {"move_then_resample": ORDER_MOVE_THEN_RESAMPLE,
               "resample_then_move": ORDER_RESAMPLE_THEN_MOVE}


# The stepwise EWA's copies of a kept particle of weight W (key ``ewa_copies``; n = W / delta).
EWA_COPIES_CEIL = 0             # ceil(n) in all, the kept particle one of them (pfbench's)
EWA_COPIES_FLOOR_PLUS_ONE = 1   # floor(n) + 1
EWA_COPIES_CEIL_PLUS_ONE = 2    # the kept particle and ceil(n) copies of it
EWA_COPIES = {"ceil": EWA_COPIES_CEIL, "floor_plus_one": EWA_COPIES_FLOOR_PLUS_ONE,
              "ceil_plus_one": EWA_COPIES_CEIL_PLUS_ONE}

# The bat algorithm's acceptance of a candidate (key ``ba_accept``) and local walk (``ba_walk``).
BA_ACCEPT_FITTER_AND_LOUD = 0   # fitter than its bat, and u < A_i (pfbench's)
BA_ACCEPT_BETTER_THAN_BEST = 1  # fitter than the best bat, and u < A_i (Yang 2010's text)
BA_ACCEPT = {"fitter_and_loud": BA_ACCEPT_FITTER_AND_LOUD,
             "better_than_best": BA_ACCEPT_BETTER_THAN_BEST}
BA_WALK_GAUSSIAN = 0            # x_best + N(0, 1) mean(A) (pfbench's)
BA_WALK_UNIFORM = 1             # x_best + U(-1, 1) mean(A) (Yang 2010's epsilon in [-1, 1])
BA_WALK = {"gaussian_loudness": BA_WALK_GAUSSIAN, "uniform": BA_WALK_UNIFORM}

# AFSA's prey target (key ``prey_target``).
PREY_FISH = 0                   # another fish within the visual range (pfbench's)
PREY_RANDOM_POINT = 1           # a random point within the visual range (afsa2014's text)
PREY_TARGET = {"fish": PREY_FISH, "random_point": PREY_RANDOM_POINT}

# FastSLAM's swarm refinement: the unit of the random steps (key ``step_unit``) and IFA's
# brightness of a pose (key ``pose_brightness``).
STEP_UNIT_CLOUD = 0         # the predicted cloud's spread per coordinate
STEP_UNIT_FIXED = 1         # fixed metres and radians (step_unit_m, step_unit_rad)
STEP_UNITS = {"cloud_spread": STEP_UNIT_CLOUD, "fixed": STEP_UNIT_FIXED}
POSE_BRIGHTNESS_COMBINED = 0    # exp(ll - max ll - d^2 / 2), d the pose's distance from the cloud
POSE_BRIGHTNESS_LIKELIHOOD = 1  # exp(ll - max ll): the innovations alone
POSE_BRIGHTNESS_INVERSE = 2     # 1 / (1 + d), d^2 = -2 (ll - max ll) + the pose's distance^2
POSE_BRIGHTNESS = {"combined": POSE_BRIGHTNESS_COMBINED, "likelihood": POSE_BRIGHTNESS_LIKELIHOOD,
                   "inverse": POSE_BRIGHTNESS_INVERSE}

# Directional resampling's copies (afsa2014, key ``directional_map``): the map they carry.
DIRECTIONAL_MAP_BOARD = 0   # the board particle's, as of the previous observation
DIRECTIONAL_MAP_BEST = 1    # this observation's highest-weight particle's, updated by it
DIRECTIONAL_MAPS = {"board": DIRECTIONAL_MAP_BOARD, "best": DIRECTIONAL_MAP_BEST}

# MCL's sensor resetting (key ``srl_rule``): how many particles SRL replaces.
SRL_FIXED_FRACTION = 0      # srl_fraction of N when p_mean < srl_threshold
SRL_LENSER_VELOSO = 1       # N (1 - p_mean / srl_threshold) when p_mean < srl_threshold
SRL_RULES = {"fixed_fraction": SRL_FIXED_FRACTION, "lenser_veloso": SRL_LENSER_VELOSO}

# Mixture MCL's density estimate of the predicted belief (key ``density``), how its dual samples
# are weighed (``dual_weight``) and how the two sets' weights are combined (``combine``).
DENSITY_KDE = 0                 # Gaussian kernel over the pose (pfbench's)
DENSITY_HISTOGRAM = 1           # piecewise constant over cells (a kd-tree's leaves, made regular)
DENSITIES = {"kde": DENSITY_KDE, "histogram": DENSITY_HISTOGRAM}
DUAL_BELIEF = 0                 # the predicted belief at the pose (the paper's)
DUAL_IMPORTANCE = 1             # belief x likelihood / the sensor draw's density
DUAL_WEIGHTS = {"belief": DUAL_BELIEF, "importance": DUAL_IMPORTANCE}
COMBINE_SEPARATE = 0            # each set normalised to its share of the particles (pfbench's)
COMBINE_JOINT = 1               # the weights as they are (both importance weights of one target)
COMBINES = {"separate": COMBINE_SEPARATE, "joint": COMBINE_JOINT}
