"""Categorical choices are named constants defined once (pfbench.codes), and the kernels compare
with those names, never with a bare number; the localization and SLAM kernels take their
parameter groups as named records, built in one place from a filter run's keys."""
from __future__ import annotations

import ast
import math
from pathlib import Path
from statistics import NormalDist

import pytest

from pfbench import codes

from .conftest import ROOT, parsed

# Names a kernel gives a categorical code it branches on (a function's argument or a local).
CATEGORICAL = {"motion", "sensor", "scheme", "reset", "refine", "trigger", "kind", "algo", "assoc"}
ARRAY_FIELDS = {"shape", "ndim", "size"}     # an array's, not a code
SCANNED = ("pfbench/filters", "pfbench/models", "pfbench/resampling.py")


def _files(where: str) -> list[Path]:
    path = ROOT / where
    return sorted(path.rglob("*.py")) if path.is_dir() else [path]


def _is_number(node) -> bool:
    return (isinstance(node, ast.Constant) and isinstance(node.value, (int, float))
            and not isinstance(node.value, bool))


def _is_code(node) -> bool:
    """An options field (``o.reset``, ``model.motion``: an attribute of a name) or a name that
    holds a categorical code."""
    if isinstance(node, ast.Subscript) and _is_number(node.slice):     # noise[0], a slot
        return isinstance(node.value, ast.Name)
    return ((isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
             and node.attr not in ARRAY_FIELDS)
            or (isinstance(node, ast.Name) and node.id in CATEGORICAL))


def bare_code_comparisons(text: str, name: str = "<source>") -> list[str]:
    """'file:line: comparison' for each ==, != or ``in`` of an options field (or a categorical
    code's name) with a bare number, or a subscript of one (``noise[0] == 0``)."""
    found = []
    for node in ast.walk(parsed(text)):
        if not isinstance(node, ast.Compare):
            continue
        sides = [node.left, *node.comparators]
        for op, left, right in zip(node.ops, sides, sides[1:]):
            if not isinstance(op, (ast.Eq, ast.NotEq, ast.In, ast.NotIn)):
                continue
            for a, b in ((left, right), (right, left)):
                numbers = b.elts if isinstance(b, (ast.Tuple, ast.List, ast.Set)) else [b]
                if _is_code(a) and any(_is_number(x) for x in numbers):
                    found.append(f"{name}:{node.lineno}: {ast.unparse(node)}")
    return found


def test_no_kernel_compares_a_code_with_a_bare_number():
    found = []
    for where in SCANNED:
        for path in _files(where):
            found += bare_code_comparisons(path.read_text(encoding="utf-8"),
                                           path.relative_to(ROOT).as_posix())
    assert not found, "compare with a constant of pfbench.codes:\n" + "\n".join(found)


@pytest.mark.parametrize("source, flagged", [
    ("if o.reset == 3:\n    pass", 1),
    ("x = 1 if o.scheme != 1 else 0", 1),
    ("ok = 0 == o.trigger or (o.trigger == 1 and e < t)", 2),
    ("if motion == 0:\n    pass", 1),
    ("if sensor in (0, 1):\n    pass", 1),
    ("if o.reset == RESET_AUGMENTED and m > 0:\n    pass", 0),
    ("if o.iters > 0 and n == 0:\n    pass", 0),       # a count, not a code
    ("if motion == MOTION_ODOMETRY:\n    pass", 0),
    ("if noise[0] == 0:\n    pass", 1),
    ("if w.size == 0 or first[t] == 0:\n    pass", 0),
])
def test_the_scan_finds_bare_codes(source, flagged):
    assert len(bare_code_comparisons(source)) == flagged


def _groups():
    return [v for k, v in vars(codes).items() if k.isupper() and isinstance(v, dict)]


def test_each_mapping_is_made_of_the_named_constants_and_codes_differ():
    named = {v for k, v in vars(codes).items() if k.isupper() and isinstance(v, int)}
    for mapping in _groups():
        assert set(mapping.values()) <= named
        assert len(set(mapping.values())) == len(mapping)
    schemes = [codes.SCHEME_MULTINOMIAL, codes.SCHEME_SYSTEMATIC, codes.SCHEME_STRATIFIED,
               codes.SCHEME_RESIDUAL, codes.STEPWISE_EWA, codes.DIRECTIONAL]
    assert len(set(schemes)) == len(schemes)
    assert codes.NO_SWARM not in codes.ALGORITHMS.values()


def test_the_modules_use_the_one_definition_and_the_config_names_it():
    from pfbench import resampling
    from pfbench.filters import mcl, sspf_field, swarm
    from pfbench.models import scalar
    from pfbench.scenarios import beacon_field

    assert resampling.SCHEME_CODES is codes.SCHEME_CODES
    assert tuple(codes.SCHEME_CODES) == tuple(resampling.SCHEMES)
    assert resampling.STEPWISE_EWA is codes.STEPWISE_EWA
    assert mcl.RESET is codes.RESET
    assert sspf_field.TRIGGERS is codes.TRIGGERS
    assert swarm.ALGORITHMS is codes.ALGORITHMS
    assert scalar.NOISE_GAUSSIAN == codes.NOISE_GAUSSIAN
    # every choice a config can make has its code, and no code lacks a choice
    assert set(mcl.mcl_keys()["reset"].choices) == set(codes.RESET)
    assert set(sspf_field.sspf_field_keys()["resample"].choices) == set(codes.TRIGGERS)
    keys = beacon_field.SCHEMA
    assert set(keys["motion"].choices) == set(codes.FIELD_MOTIONS)
    assert set(keys["sensor"].choices) == set(codes.SENSORS)


MCL_KEYS = {"srl_fraction": 0.1, "srl_threshold": 0.02, "asrl_mu": 0.8, "asrl_pt": 0.3,
            "alpha_slow": 0.01, "alpha_fast": 0.2, "kld_epsilon": 0.05, "kld_delta": 0.01,
            "kld_bin_m": 0.5, "kld_bin_deg": 10.0, "kld_min": 40, "srl_rule": "lenser_veloso"}


def test_mcl_parameters_are_named_records_built_from_the_keys():
    from pfbench.filters.mcl import KldParams, ResetParams, kld_params, reset_params
    from pfbench.codes import SRL_LENSER_VELOSO, SRL_RULES

    rp = reset_params(MCL_KEYS)
    assert isinstance(rp, ResetParams)
    # every field its key's value, SRL's rule as its code (a float, as the record holds floats)
    assert rp._asdict() == {k: (float(SRL_RULES[MCL_KEYS[k]]) if k == "srl_rule" else MCL_KEYS[k])
                            for k in ResetParams._fields}
    assert rp.srl_rule == SRL_LENSER_VELOSO
    assert all(type(v) is float for v in rp)
    kp = kld_params(MCL_KEYS, 30)
    assert isinstance(kp, KldParams) and all(type(v) is float for v in kp)
    assert kp.epsilon == 0.05 and kp.z == NormalDist().inv_cdf(0.99)
    assert kp.bin_m == 0.5 and kp.bin_rad == math.radians(10.0)
    assert kp.n_min == 30.0         # kld_min, at most the particles
    assert kld_params(MCL_KEYS, 100).n_min == 40.0


def test_sspf_and_fastslam_parameters_are_named_records():
    from pfbench.filters.fastslam import DirectionalNoise, directional_noise
    from pfbench.filters.sspf_field import PoseStd, SigmaParams, sspf_params

    up, init, jit = sspf_params({"alpha": 0.5, "beta": 2.0, "kappa": 1.0, "init_std_m": 1.5,
                                 "init_std_deg": 30.0, "jitter_m": 0.05, "jitter_deg": 1.0})
    assert up == SigmaParams(alpha=0.5, beta=2.0, kappa=1.0)
    assert init == PoseStd(m=1.5, rad=math.radians(30.0))
    assert jit == PoseStd(m=0.05, rad=math.radians(1.0))
    dn = directional_noise({"directional_noise_m": 0.2, "directional_noise_deg": 3.0})
    assert dn == DirectionalNoise(m=0.2, rad=3.0 * (math.pi / 180.0))


def test_the_kernels_refuse_a_positional_array_for_a_record():
    """The records' types are in the kernels' signatures: a positional float array in their
    place is a typing error, not a silent misreading of its slots."""
    import numpy as np

    from pfbench.filters.mcl import kld_bins

    area = np.array([10.0, 10.0])
    with pytest.raises(TypeError):
        kld_bins(area, np.array([0.05, 2.3, 0.5, 0.17, 40.0]))


def test_the_kernels_signatures_name_their_records():
    """The trial kernels take their parameter groups, observations and snapshots as records:
    fewer positional arguments, none of them a float array read by slot."""
    from pfbench.filters import fastslam, mcl, sspf_field
    from pfbench.models.observations import OBSERVATIONS
    from pfbench.models.odometry import MOTION_NOISE
    from pfbench.models.pose import INITIAL_BELIEF, SNAPSHOTS

    wanted = {
        mcl.MCL_SIG: {OBSERVATIONS, MOTION_NOISE, mcl.RESET_PARAMS, mcl.KLD_PARAMS, INITIAL_BELIEF,
                      SNAPSHOTS},
        sspf_field.SSPF_SIG: {OBSERVATIONS, MOTION_NOISE, sspf_field.SIGMA_PARAMS,
                              sspf_field.POSE_STD, INITIAL_BELIEF, SNAPSHOTS},
        fastslam.FASTSLAM_SIG: {OBSERVATIONS, fastslam.DIRECTIONAL_NOISE},
    }
    for sig, records in wanted.items():
        assert records <= set(sig.args)
        assert len(sig.args) <= 17


def test_observations_and_snapshots_are_records_of_the_trials_arrays():
    import numpy as np

    from pfbench.models.observations import Observations, observations
    from pfbench.models.pose import Snapshots, snapshot_arrays

    class Data:
        obs_n = np.zeros(3, dtype=np.int64)
        obs_id = np.zeros((3, 2), dtype=np.int64)
        obs_z = np.zeros((3, 2, 2))

    obs = observations(Data)
    assert isinstance(obs, Observations)
    assert obs.n is Data.obs_n and obs.ids is Data.obs_id and obs.z is Data.obs_z
    snap = snapshot_arrays([5, 0, 5], 4)
    assert isinstance(snap, Snapshots)
    steps, poses, counts = snap         # what a filter's traces hold: (steps, particles, counts)
    assert steps.tolist() == [0, 5] and poses.shape == (2, 4, 3) and counts.shape == (2,)


@pytest.mark.parametrize("motion, sensor, answer, initial", [
    ("odometry", "range", "random", "unknown"),
    ("rot_trans_rot", "range_bearing", "nearest", "known"),
])
def test_the_beacon_field_builds_its_model_records(motion, sensor, answer, initial):
    from pfbench.models.beacons import BeaconSensor
    from pfbench.models.odometry import MotionNoise
    from pfbench.models.pose import InitialBelief
    from pfbench.scenarios import beacon_field as bf

    p = {k: v.default for k, v in bf.SCHEMA.items()}
    p.update(world="worlds/beacon_field.yaml", motion=motion, sensor=sensor, answer=answer,
             initial=initial)
    m = bf.build(bf.resolve(p, ROOT / "configs"))
    assert m.motion == codes.FIELD_MOTIONS[motion] and m.sensor == codes.SENSORS[sensor]
    assert isinstance(m.mnoise, MotionNoise) and isinstance(m.sense, BeaconSensor)
    assert isinstance(m.init, InitialBelief)
    assert m.sense.nearest == (answer == "nearest") and m.init.known == (initial == "known")
    if motion == "odometry":
        assert m.mnoise == MotionNoise.additive(p["trans_noise_m"],
                                                p["turn_noise_deg"] * bf.DEG)
    else:
        assert m.mnoise[2:] == tuple(p["alphas"]) and m.mnoise[:2] == (0.0, 0.0)
    assert m.sense.sr == p["range_noise_m"]


SWARM_KEYS = {"beta0": 1.5, "gamma": 0.25, "alpha": 0.2, "brightness": "inverse",
              "freq_min": 0.1, "freq_max": 2.0, "loudness": 0.8, "pulse_rate": 0.4,
              "loudness_decay": 0.95, "pulse_growth": 0.7, "inertia": 0.6, "c1": 1.25,
              "c2": 1.75, "visual": 2.5, "step": 0.3, "crowding": 0.618, "tries": 4,
              "greedy": False, "ba_accept": "better_than_best", "ba_walk": "uniform",
              "prey_target": "random_point", "converge": True, "random_term": "gaussian",
              "move_toward": "brightest"}
# the choice keys among them, read as their codes
CHOICE_CODES = {"brightness": codes.BRIGHTNESS, "random_term": codes.RANDOM_TERMS,
                "move_toward": codes.MOVE_TOWARD, "ba_accept": codes.BA_ACCEPT,
                "ba_walk": codes.BA_WALK, "prey_target": codes.PREY_TARGET}


@pytest.mark.parametrize("algo, read", [
    ("fa", {"beta0", "gamma", "alpha", "random_term", "move_toward"}),
    ("ifa", {"beta0", "gamma", "brightness", "random_term", "move_toward"}),
    ("ba", {"freq_min", "freq_max", "loudness", "pulse_rate", "loudness_decay", "pulse_growth",
            "ba_accept", "ba_walk"}),
    ("pso", {"inertia", "c1", "c2"}),
    ("afsa", {"visual", "step", "crowding", "tries", "greedy", "prey_target", "converge"}),
    ("none", set()),
])
def test_swarm_parameters_are_one_named_record_built_from_the_keys(algo, read):
    """Each algorithm's keys land in the field of the same name, as floats; the fields it does
    not read are 0.0."""
    from pfbench.filters.swarm import SWARM_PARAMS, SwarmParams, swarm_params

    sp = swarm_params(algo, SWARM_KEYS)
    assert isinstance(sp, SwarmParams) and all(type(v) is float for v in sp)
    want = {k: 0.0 for k in SwarmParams._fields}
    want.update({k: float(SWARM_KEYS[k]) for k in read - set(CHOICE_CODES)})
    want.update({k: float(CHOICE_CODES[k][SWARM_KEYS[k]]) for k in read & set(CHOICE_CODES)})
    if "brightness" in read:
        assert want["brightness"] == float(codes.BRIGHTNESS_INVERSE)
    assert sp._asdict() == want
    assert SWARM_PARAMS.count == len(SwarmParams._fields)
    # a filter without IFA's brightness key (FastSLAM's IFA) keeps the field's 0.0
    no_brightness = {k: v for k, v in SWARM_KEYS.items() if k != "brightness"}
    assert swarm_params("ifa", no_brightness).brightness == 0.0


def _named(node, names: set[str]) -> bool:
    return ((isinstance(node, ast.Name) and node.id in names)
            or (isinstance(node, ast.Attribute) and node.attr in names))


def index_reads(text: str, names: set[str], name: str = "<source>") -> list[str]:
    """'file:line: read' for each subscript with a number of a name in ``names`` (``p[2]``) or
    of an attribute so named (``model.noise[0]``)."""
    return [f"{name}:{node.lineno}: {ast.unparse(node)}" for node in ast.walk(parsed(text))
            if isinstance(node, ast.Subscript) and _named(node.value, names)
            and _is_number(node.slice)]


SWARM_ARGS = {"p", "sp"}        # the swarm parameters' argument in the swarm kernels


def test_no_kernel_reads_a_swarm_parameter_by_slot():
    """The swarm's parameters (``p`` in the swarm moves and the scalar swarm PFs, ``sp`` in
    FastSLAM) are read by name: ``p.visual``, never ``p[0]``."""
    found = []
    for name in ("swarm.py", "swarm_pf.py", "fastslam.py"):
        path = ROOT / "pfbench/filters" / name
        found += index_reads(path.read_text(encoding="utf-8"), SWARM_ARGS,
                             path.relative_to(ROOT).as_posix())
    assert not found, "read the SwarmParams field by name:\n" + "\n".join(found)


@pytest.mark.parametrize("source, flagged", [
    ("x = p[2] + sp[0] * q[1]", 2),
    ("afsa_select(X, wk.ll, wk.C, wk.llC, D, int(p[4]))", 1),
    ("wk.A[:] = p.loudness", 0),
    ("y = p[i]", 0),            # an index that is a variable: not a slot of a record
    ("dt = float(model.sp[1])", 1),
])
def test_the_scan_finds_slot_reads(source, flagged):
    assert len(index_reads(source, SWARM_ARGS)) == flagged


def _declared(fn) -> list:
    sigs = fn._sigs
    return list(sigs) if isinstance(sigs, (list, tuple)) else [sigs]


def test_the_swarm_kernels_take_the_record_and_refuse_an_array():
    """The swarm record's type is in the declared signatures of the dispatcher, the moves'
    callers and both swarm trial kernels, at the argument that carries it; a positional float
    array in its place matches no declared signature (numba's typing, as a call resolves it:
    the dispatcher, inlined into its callers, is not compiled alone for this)."""
    import inspect

    import numba
    import numpy as np
    from numba.core.registry import cpu_target

    from pfbench.filters import fastslam, swarm, swarm_pf
    from pfbench.rng import state_from_seed

    assert swarm.SWARM_PARAMS in swarm_pf.SWARM_SIG.args
    assert swarm.SWARM_PARAMS in fastslam.FASTSLAM_SIG.args
    for fn in (swarm.swarm_move, swarm.afsa_joint_shift, swarm.afsa_fish_shift,
               swarm_pf.swarm_refine, swarm_pf.swarm_fitness, swarm_pf.swarm_pf_kernel,
               fastslam.refine_poses, fastslam.fastslam_kernel):
        names = list(inspect.signature(fn).parameters)
        slots = [i for i, n in enumerate(names) if n in SWARM_ARGS]
        assert len(slots) == 1, fn.__name__
        for sig in _declared(fn):
            assert sig.args[slots[0]] == swarm.SWARM_PARAMS, fn.__name__
    N, D = 4, 1
    wk = swarm.new_swarm_work(N, D)
    s = state_from_seed(np.random.SeedSequence(1))

    def resolves(p) -> bool:
        args = (swarm.FA, 0, 0, np.zeros(N * D), D, p, 1.0, 0, wk, s)
        return cpu_target.typing_context.resolve_overload(
            "swarm_move", _declared(swarm.swarm_move), tuple(map(numba.typeof, args)),
            {}) is not None
    assert resolves(swarm.swarm_params("none", {}))
    assert not resolves(np.array([1.0, 1.0, 0.2]))


# The SLAM model's records and the names their arguments take in the simulators and FastSLAM.
SLAM_ARGS = {"noise", "veh", "vehicle", "sensor"}
SLAM_READERS = ("pfbench/models/slam.py", "pfbench/filters/fastslam.py",
                "pfbench/benchmarks/fastslam_course.py")


def test_no_one_reads_the_slam_model_by_slot():
    """A SLAM model's vehicle, noise and sensor are read by name (``model.noise.range``,
    ``veh.wheelbase``), never by slot (``model.noise[2]``)."""
    found = []
    for where in SLAM_READERS:
        path = ROOT / where
        found += index_reads(path.read_text(encoding="utf-8"), SLAM_ARGS, where)
    assert not found, "read the SLAM model's record by name:\n" + "\n".join(found)


@pytest.mark.parametrize("scenario", ["waypoint_course", "landmark_world"])
def test_the_slam_model_holds_named_records(scenario):
    """Each SLAM scenario's model holds a Vehicle, a SlamNoise and a SlamSensor of floats, and a
    model given sequences (a plug-in's, or ``dataclasses.replace``) gets the records too."""
    import importlib
    from dataclasses import replace

    import numpy as np

    from pfbench.models.slam import SlamNoise, SlamSensor, Vehicle

    mod = importlib.import_module(f"pfbench.scenarios.{scenario}")
    p = {k: v.default for k, v in mod.SCHEMA.items()}
    p["world"] = {"waypoint_course": "worlds/ifa_course.yaml",
                  "landmark_world": "worlds/afsa_world.yaml"}[scenario]
    p = mod.resolve(p, ROOT / "configs")
    m = mod.build(p)
    for field, kind in (("vehicle", Vehicle), ("noise", SlamNoise), ("sensor", SlamSensor)):
        rec = getattr(m, field)
        assert type(rec) is kind and all(type(v) is float for v in rec), field
    deg = math.pi / 180.0
    assert m.sensor == SlamSensor(p["max_range_m"], 0.5 * p["field_of_view_deg"] * deg,
                                  float(p["obs_every"]))
    assert m.vehicle.speed == p["speed_mps"] and m.vehicle.dt == p["dt_s"]
    assert m.noise.range == (p["range_noise_m"] if p.get("noise_values") != "variance"
                             else math.sqrt(p["range_noise_m"]))
    m2 = replace(m, sensor=np.array([1e-3, math.pi, 8.0]), noise=[0.1, 0.2, 0.3, 0.4])
    assert m2.sensor == SlamSensor(1e-3, math.pi, 8.0) and m2.noise.bearing == 0.4
    with pytest.raises(TypeError):
        replace(m, vehicle=[1.0, 2.0])          # a record's fields are all given


def test_the_slam_simulators_take_the_records():
    from pfbench.models import slam

    for fn in (slam.simulate_course, slam.simulate_odometry):
        (sig,) = _declared(fn)
        assert sig.args[3:6] == (slam.VEHICLE, slam.SLAM_NOISE, slam.SLAM_SENSOR)
    (sig,) = _declared(slam.sense_landmarks)
    assert slam.SLAM_NOISE in sig.args
