"""Localization on the beacon field: metrics, scenario, MCL and its resetting variants."""
import math

import numpy as np
import pytest

from pfbench.metrics import localization_metrics, settle_step


def _poses(errs):
    """True poses at the origin and estimates displaced by errs along x: (truth, out)."""
    T = len(errs)
    truth = np.zeros((T + 1, 3))
    est = np.zeros((T + 1, 3))
    est[1:, 0] = errs
    return truth, {"pose": est, "ess": np.ones(T), "resampled": np.ones(T),
                   "lik_evals_per_step": 10.0}


def test_settle_step():
    assert settle_step(np.array([3.0, 0.1, 0.2]), 0.5) == 1
    assert settle_step(np.array([0.1, 0.9, 0.2, 0.1]), 0.5) == 2
    assert settle_step(np.array([0.1, 0.9]), 0.5) == 2          # not settled at the end
    assert settle_step(np.array([0.1, 0.2]), 0.5) == 0


def test_convergence_and_recovery_steps():
    # steps 1..10; kidnapped at step 5 (error jumps) and at step 9 (never recovers)
    errs = [5.0, 2.0, 0.3, 0.2, 8.0, 6.0, 0.4, 0.1, 7.0, 9.0]
    truth, out = _poses(errs)
    m = localization_metrics(truth, out, 0.5, np.array([5, 9]))
    assert m["converge_step"] == 3
    assert m["recovery_steps"] == 2          # kidnapped at 5, below the bound from step 7 on
    assert m["recovery_failures"] == 1
    assert m["final_error"] == 9.0
    assert m["x_error"] == pytest.approx(np.mean(errs)) and m["y_error"] == 0.0
    assert m["rmse"] == pytest.approx(math.sqrt(np.mean(np.square(errs))))
    none = localization_metrics(truth, out, 0.5, np.array([], dtype=np.int64))
    assert math.isnan(none["converge_step"]) and math.isnan(none["recovery_failures"])


from pfbench.config import Params  # noqa: E402
from pfbench.filters import FILTERS  # noqa: E402
from pfbench.filters.mcl import sensor_pose  # noqa: E402
from pfbench.rng import state_from_seed  # noqa: E402
from pfbench.scenarios import beacon_field as bf  # noqa: E402

from .conftest import ROOT  # noqa: E402


def _field(**over):
    p = {k: v.default for k, v in bf.SCHEMA.items()}
    p.update(over)
    return bf.build(bf.resolve(p, ROOT / "configs"))


def _mcl(model, data, N, seed=0, **over):
    ft = FILTERS["mcl"]
    p = {k: v.default for k, v in ft.schema.items()}
    p.update(over)
    return ft.run(model, data, Params(p), N, state_from_seed(np.random.SeedSequence(seed)))


@pytest.mark.parametrize("sensor", [0, 1])
def test_sensor_model_draws_reproduce_the_observation(sensor):
    area = np.array([40.0, 40.0])
    bc = np.array([[10.0, 12.0], [30.0, 25.0]])
    ids = np.array([1, 0])
    zs = np.array([[7.5, 0.4], [12.0, -1.1]])
    s = state_from_seed(np.random.SeedSequence(3))
    out = np.empty(3)
    for _ in range(200):
        sensor_pose(area, sensor, bc, 2, ids, zs, 1e-9, 1e-9, out, s)
        # the pose sees one of the two observed beacons as observed
        hits = []
        for b, (r, brg) in zip(ids, zs):
            d = bc[b] - out[:2]
            ok = abs(np.hypot(*d) - r) < 1e-6
            if sensor == 1:
                ok &= abs((math.atan2(d[1], d[0]) - out[2] - brg + math.pi) % (2 * math.pi)
                          - math.pi) < 1e-6
            hits.append(ok)
        assert any(hits)


def test_kidnapping_is_invisible_in_the_odometry():
    plain = _field(steps=60)
    kid = _field(steps=60, kidnap_steps=[30], kidnap_poses=[35.0, 35.0, 90.0])
    a, _ = bf.simulate(plain, state_from_seed(np.random.SeedSequence(4)))
    b, _ = bf.simulate(kid, state_from_seed(np.random.SeedSequence(4)))
    assert np.array_equal(a.pose[:30], b.pose[:30]) and np.array_equal(a.ctrl[:30], b.ctrl[:30])
    assert np.array_equal(a.obs_z[:29], b.obs_z[:29])
    assert b.pose[30] == pytest.approx([35.0, 35.0, math.pi / 2])
    # the odometry of the kidnapping step is the commanded move, as if nothing happened
    assert np.array_equal(a.ctrl[29], b.ctrl[29])


def test_mcl_with_precise_sensors_converges_to_the_true_pose():
    model = _field(sensor="range_bearing", range_noise_m=0.05, bearing_noise_deg=1.0, steps=60)
    for seed in range(3):
        truth, data = bf.simulate(model, state_from_seed(np.random.SeedSequence(10 + seed)))
        out = _mcl(model, data, 2000, seed=seed)
        err = np.hypot(*(out["pose"][1:, :2] - truth.pose[1:, :2]).T)
        assert err[-10:].max() < 0.5, seed


def test_augmented_mcl_injects_nothing_while_the_likelihood_is_steady_and_after_a_kidnap_does():
    model = _field(sensor="range_bearing", range_noise_m=0.05, bearing_noise_deg=1.0, steps=80,
                   kidnap_steps=[50], kidnap_poses=[34.0, 30.0, 180.0])
    truth, data = bf.simulate(model, state_from_seed(np.random.SeedSequence(20)))
    blind = bf.FieldData(data.pose, data.ctrl, np.zeros_like(data.obs_n), data.obs_id, data.obs_z)
    out = _mcl(model, blind, 500, reset="augmented")
    assert out["injected"].sum() == 0                  # no observations: p_mean stays 1
    out = _mcl(model, data, 2000, seed=1, reset="augmented", inject="sensor")
    assert out["injected"][49:60].sum() > 0
    err = np.hypot(*(out["pose"][1:, :2] - truth.pose[1:, :2]).T)
    assert err[-5:].max() < 0.5                        # and it recovers


def test_asrl_replaces_more_particles_the_lower_the_likelihood():
    model = _field(sensor="range_bearing", range_noise_m=0.05, bearing_noise_deg=1.0, steps=80,
                   kidnap_steps=[50], kidnap_poses=[34.0, 30.0, 180.0])
    truth, data = bf.simulate(model, state_from_seed(np.random.SeedSequence(21)))
    out = _mcl(model, data, 1000, reset="asrl", asrl_pt=0.5, asrl_mu=1.0)
    n = data.obs_n * 2
    want = np.round(1000 * np.maximum(0.0, 1.0 - out["pmean"] / (1.0 * 0.5 ** n)))
    assert np.array_equal(out["injected"], want.astype(np.int64))
    # the kidnapping (step 50, index 49) leaves no particle near the robot: all are replaced,
    # by poses consistent with that step's observations, and the filter is back at once
    assert out["injected"][49] == 1000 and out["injected"][44] == 0
    err = np.hypot(*(out["pose"][1:, :2] - truth.pose[1:, :2]).T)
    assert err[49] > 5.0 and err[51:].max() < 0.5


def test_beacon_world_errors_name_the_problem(tmp_path):
    from pfbench.schema import ConfigError
    world = tmp_path / "w.yaml"
    world.write_text("area: [40, 40]\nstart: [5, 5, 0]\nwaypoints: [[10, 10], [20, 20]]\n"
                     "beacons: [[5, 20], [45, 10]]\n")
    p = {k: v.default for k, v in bf.SCHEMA.items()}
    p["world"] = str(world)
    with pytest.raises(ConfigError, match=r"beacons\[1\] = \[45.0, 10.0\] lies outside"):
        bf.resolve(p, tmp_path)
    p.update(world=str(ROOT / "configs/worlds/beacon_field.yaml"), kidnap_steps=(10,),
             kidnap_poses=(1.0, 2.0))
    with pytest.raises(ConfigError, match="kidnap_poses"):
        bf.resolve(p, tmp_path)
