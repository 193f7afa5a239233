"""What the figures draw is kept while the trials run (traces.npz), and figures never run a
trial again."""
import numpy as np
import pytest

from pfbench import plots, runner
from pfbench.config import load
from pfbench.diag import Diag
from pfbench.errors import UserError
from pfbench.runner import run_experiment, run_filter, trial_data
from pfbench.store import TRACES, TRACES_PARTIAL, read_traces, stage_trace
from pfbench.traces import (FIGURE_TRIALS, PATH_POINTS, PATH_TRIALS, SNAPSHOT_PARTICLES,
                            SlamTracer, curve_stride, error_runs, path_runs, path_steps,
                            slam_error_curves, snapshot_runs)

from .conftest import ROOT, TINY

FIELD = f"""\
seed: 3
trials: {{trials}}
scenario:
  name: beacon_field
  world: {ROOT / 'configs/worlds/beacon_field.yaml'}
  steps: 25
  initial: known
  kidnap_steps: [12]
filters:
  mcl:
    label: MCL
    particles: 300
  kld:
    type: mcl
    label: KLD-MCL
    particles: {{kld}}
    sampling: kld
  sspf:
    label: SSPF
    particles: 60
"""

COURSE = f"""\
seed: 2
trials: 3
scenario: {{name: waypoint_course, world: {ROOT / 'configs/worlds/ifa_course.yaml'}, steps: 300}}
filters:
  fastslam: {{particles: 10}}
  ifa: {{type: fastslam, refine: ifa, particles: 10}}
"""


def _field(write_config, trials=4, kld=3000, name="field.yaml"):
    return load(write_config(FIELD.format(trials=trials, kld=kld), name))


def _no_runs(monkeypatch):
    """From here on, running a filter or simulating a trial is an error."""
    def refuse(*a, **k):
        raise AssertionError("a figure ran a trial")
    monkeypatch.setattr(runner, "run_filter", refuse)
    monkeypatch.setattr(runner, "trial_data", refuse)


def test_localization_traces_hold_what_the_trials_gave(tmp_path, write_config):
    exp = _field(write_config)
    run_experiment(exp, tmp_path / "r")
    traces = read_traces(tmp_path / "r")
    assert sorted(traces.trials) == list(range(exp.trials))       # fewer than FIGURE_TRIALS
    assert not (tmp_path / "r" / TRACES_PARTIAL).exists()
    model, truth, data = trial_data(exp, 1)
    for r in error_runs(exp):
        out, _ = run_filter(exp, 1, r, model, data)
        want = np.hypot(*(out["pose"][:, :2] - truth.pose[:, :2]).T).astype(np.float32)
        np.testing.assert_array_equal(traces.trials[1][f"{r.key}/error"], want)
    first = traces.trials[0]
    steps = first["steps"]
    assert 0 in steps and 12 in steps and 25 in steps
    model, _, data = trial_data(exp, 0)
    for r in snapshot_runs(exp):
        out, _ = run_filter(exp, 0, r, model, data, snapshots=list(steps))
        np.testing.assert_array_equal(first[f"{r.key}/pose_at"],
                                      out["pose"][steps].astype(np.float32))
        _, parts, counts = out["snapshots"]
        np.testing.assert_array_equal(first[f"{r.key}/snap_count"], counts)
        drawn = first[f"{r.key}/snap_drawn"]
        assert np.all(drawn <= np.minimum(counts, SNAPSHOT_PARTICLES))
        assert np.all(drawn >= np.minimum(counts, SNAPSHOT_PARTICLES) // 2)
        assert first[f"{r.key}/snap_xy"].shape == (drawn.sum(), 2)
    np.testing.assert_array_equal(traces.world["kidnaps"], [12])
    assert float(traces.world["bound"]) == model.bound
    # the paths of the first PATH_TRIALS trials: every step of a short trial, as float32
    assert PATH_TRIALS == 1 and "truth_path" not in traces.trials[1]
    np.testing.assert_array_equal(first["path_step"], np.arange(26))
    model, truth, data = trial_data(exp, 0)
    np.testing.assert_array_equal(first["truth_path"], truth.pose[:, :2].astype(np.float32))
    assert [r.label for r in path_runs(exp)] == ["MCL", "KLD-MCL", "SSPF"]
    for r in path_runs(exp):
        out, _ = run_filter(exp, 0, r, model, data)
        assert first[f"{r.key}/path"].shape == (26, 2)
        assert first[f"{r.key}/path"].dtype == np.float32
        np.testing.assert_array_equal(first[f"{r.key}/path"],
                                      out["pose"][:, :2].astype(np.float32))
    np.testing.assert_array_equal(traces.world["beacon_ids"], np.arange(len(model.beacons)))
    assert not bool(traces.world["global_start"]) and "times" not in traces.world


def test_a_long_path_is_thinned_to_path_points_keeping_the_end_and_each_kidnapping():
    T = 9665                                      # Plaza 1's 1933 s in steps of 0.2 s
    at = path_steps(T, kidnaps=[1001, 5003])
    assert at[0] == 0 and at[-1] == T and len(at) <= PATH_POINTS + 5
    assert np.all(np.diff(at) > 0) and at.dtype == np.int32
    stride = -(-(T + 1) // PATH_POINTS)
    assert set(range(0, T + 1, stride)) <= set(at.tolist())
    assert {1000, 1001, 5002, 5003} <= set(at.tolist())
    np.testing.assert_array_equal(path_steps(30), np.arange(31))      # short: every step


def test_snapshots_of_a_large_set_are_thinned_evenly(tmp_path, write_config):
    exp = _field(write_config, trials=1, kld=9000)
    kld = next(r for r in exp.filters if r.label == "KLD-MCL")
    run_experiment(exp, tmp_path / "r")
    first = read_traces(tmp_path / "r").trials[0]
    counts, drawn = first[f"{kld.key}/snap_count"], first[f"{kld.key}/snap_drawn"]
    stride = -(-9000 // SNAPSHOT_PARTICLES)                # every stride-th of 9000
    assert counts[0] == 9000 and drawn[0] == len(range(0, 9000, stride)) <= SNAPSHOT_PARTICLES
    model, _, data = trial_data(exp, 0)
    out, _ = run_filter(exp, 0, kld, model, data, snapshots=[0])
    np.testing.assert_array_equal(first[f"{kld.key}/snap_xy"][:drawn[0]],
                                  out["snapshots"][1][0, ::stride, :2].astype(np.float32))


def test_only_the_first_figure_trials_keep_a_trace(tmp_path, write_config):
    exp = load(write_config(FIELD.format(trials=FIGURE_TRIALS + 3, kld=500)
                            .replace("steps: 25", "steps: 4")
                            .replace("kidnap_steps: [12]", "kidnap_steps: [2]")))
    run_experiment(exp, tmp_path / "r")
    assert sorted(read_traces(tmp_path / "r").trials) == list(range(FIGURE_TRIALS))


def test_figures_draw_from_the_traces_without_running_a_trial(tmp_path, write_config,
                                                              monkeypatch):
    field, course = _field(write_config), load(write_config(COURSE, "course.yaml"))
    got = {}
    for exp, name in ((field, "f"), (course, "c")):
        got[name] = run_experiment(exp, tmp_path / name)
    _no_runs(monkeypatch)
    for exp, name in ((field, "f"), (course, "c")):
        paths = plots.write_figures(exp, got[name].rows, tmp_path / name)
        assert all(p.stat().st_size > 5000 for p in paths)
    assert {p.name for p in (tmp_path / "f/figures").iterdir()} == {
        "rmse.png", "errors.png", "particles.png", "rates.png",   # it has a kidnapping
        "paths.png"}                 # from the known start: no convergence figure
    assert {p.name for p in (tmp_path / "c/figures").iterdir()} == {
        "rmse.png", "course.png", "errors.png", "ess.png"}


def test_slam_traces_keep_every_traced_trials_errors_and_trial_0s_paths(tmp_path,
                                                                         write_config):
    """Each of the first FIGURE_TRIALS trials keeps every run's error curves (position and
    heading error every k-th step, map error every k'-th observation), as computed from what the
    run gave; trial 0 also its paths, map, Neff and full map-error trace."""
    exp = load(write_config(COURSE.replace("steps: 300", "steps: 700")))     # k = 3
    run_experiment(exp, tmp_path / "c")
    traces = read_traces(tmp_path / "c")
    assert sorted(traces.trials) == list(range(exp.trials))         # fewer than FIGURE_TRIALS
    tracer = SlamTracer()
    assert tracer.keeps(exp, FIGURE_TRIALS - 1) and not tracer.keeps(exp, FIGURE_TRIALS)
    for k in range(exp.trials):
        model, truth, data = trial_data(exp, k)
        T, K = truth.pose.shape[0] - 1, data.obs_n.shape[0]
        tr = traces.trials[k]
        step, obs = curve_stride(T + 1), curve_stride(K)
        assert step > 1 and len(tr["error_time"]) == len(range(0, T + 1, step)) <= 301
        assert tr["map_time"].shape == (len(range(0, K, obs)),)
        assert ("truth_pose" in tr) == (k == 0)
        for r in exp.filters:
            out, _ = run_filter(exp, k, r, model, data, diag=Diag.MAP_TRACE)
            err = np.hypot(*(out["pose"][::step, :2] - truth.pose[::step, :2]).T)
            np.testing.assert_array_equal(tr[f"{r.key}/error"], err.astype(np.float32))
            np.testing.assert_array_equal(tr[f"{r.key}/map_error"],
                                          out["lm_trace"][::obs].astype(np.float32))
            assert tr[f"{r.key}/heading_error"].shape == tr["error_time"].shape
            assert tr[f"{r.key}/heading_error"].dtype == np.float32
            if k == 0:
                np.testing.assert_array_equal(tr[f"{r.key}/pose"],
                                              out["pose"].astype(np.float32))
                np.testing.assert_array_equal(tr[f"{r.key}/lm_seen"],
                                              out["lm_seen"].astype(bool))
                assert tr[f"{r.key}/lm_trace"].shape == (K,)
            else:
                assert f"{r.key}/pose" not in tr and f"{r.key}/lm_trace" not in tr
    first = traces.trials[0]
    model, truth, data = trial_data(exp, 0)
    np.testing.assert_array_equal(first["truth_pose"], truth.pose.astype(np.float32))
    assert first["time"].shape == (truth.pose.shape[0],)
    assert first["obs_time"].shape == (data.obs_n.shape[0],)
    np.testing.assert_array_equal(traces.world["landmarks"], model.landmarks.astype(np.float32))


def test_slam_error_curves_thin_the_steps_and_average_the_heading_over_a_window():
    n = 1001                                   # T = 1000 steps: every 4th kept, 251 points
    k = curve_stride(n)
    assert k == 4 and curve_stride(301) == 1 and curve_stride(302) == 2
    truth = np.zeros((n, 3))
    pose = np.zeros((n, 3))
    pose[:, 0] = 3.0 * np.arange(n)            # x error 3 t, y error 4 t: position error 5 t
    pose[:, 1] = 4.0 * np.arange(n)
    pose[1::2, 2] = 0.3                        # heading error 0.3 on odd steps, 0 on even
    pose[:, 2] += 2 * np.pi                    # a whole turn more: wrapped away
    time = 0.5 * np.arange(n)
    lm = np.arange(500, dtype=float)
    got = slam_error_curves(pose, truth, time, lm, 2.0 * np.arange(1, 501))
    at = np.arange(0, n, k)
    np.testing.assert_allclose(got["error"], 5.0 * at, rtol=1e-6)
    np.testing.assert_array_equal(got["error_time"], (0.5 * at).astype(np.float32))
    w = max(k, n // 100)                       # 10 steps: half of them 0.3
    assert float(got["heading_window_s"]) == w * 0.5
    np.testing.assert_allclose(got["heading_error"][at >= w], 0.3 / np.sqrt(2), rtol=1e-5)
    assert abs(got["heading_error"][0]) < 1e-6           # the start: no error
    assert curve_stride(500) == 2
    np.testing.assert_array_equal(got["map_error"], lm[::2].astype(np.float32))
    np.testing.assert_array_equal(got["map_time"], (2.0 * np.arange(1, 501))[::2]
                                  .astype(np.float32))
    assert "map_error" not in slam_error_curves(pose, truth, time, None, None)


def test_traces_are_the_same_bytes_whatever_the_workers_and_after_a_resume(tmp_path,
                                                                           write_config):
    exp = _field(write_config, trials=6)
    run_experiment(exp, tmp_path / "one")
    run_experiment(exp, tmp_path / "two", workers=2)
    ref = (tmp_path / "one" / TRACES).read_bytes()
    assert (tmp_path / "two" / TRACES).read_bytes() == ref
    # an interrupted run: 3 finished trials, the trace of trial 1 damaged, trial 2's missing
    part = tmp_path / "part"
    part.mkdir()
    lines = (tmp_path / "one" / "trials.csv").read_text().splitlines(keepends=True)
    (part / "trials.partial.csv").write_text("".join(lines[: 1 + 3 * len(exp.filters)]))
    (part / "run.json").write_text('{"experiment_hash": "%s"}' % exp.hash)
    old = read_traces(tmp_path / "one").trials
    stage_trace(part, 0, old[0])
    stage_trace(part, 1, old[1])
    staged = part / TRACES_PARTIAL / "trial-1.npz"
    staged.write_bytes(staged.read_bytes()[:100])
    res = run_experiment(exp, part, resume=True)
    assert res.ran == 5                  # trials 1 and 2 again for their traces, 3 to 5
    assert (part / TRACES).read_bytes() == ref
    assert not (part / TRACES_PARTIAL).exists()
    # a finished run that lost its traces: --resume runs the traced trials again
    (part / TRACES).unlink()
    assert run_experiment(exp, part, resume=True).ran == 6
    assert (part / TRACES).read_bytes() == ref


def test_runs_without_figures_keep_no_traces(tmp_path, write_config):
    exp = load(write_config(TINY))                       # a scalar scenario draws no trace
    run_experiment(exp, tmp_path / "s")
    assert not (tmp_path / "s" / TRACES).exists()
    field = _field(write_config)
    run_experiment(field, tmp_path / "f", traces=False)
    assert not (tmp_path / "f" / TRACES).exists()
    with pytest.raises(UserError, match="no traces.npz"):
        plots.write_figures(field, [], tmp_path / "f")
