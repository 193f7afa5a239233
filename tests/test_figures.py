"""Figures: one style, labels from names and units, the paper's values marked, a sweep's lines,
a snapshot of each outcome, and the formats, byte for byte (issue 18, parts 2, 3 and 5)."""
import pandas as pd
import pytest
from typer.testing import CliRunner

from pfbench import figstyle as fs
from pfbench import plots
from pfbench.cli import app
from pfbench.config import load
from pfbench.runner import run_experiment

from .conftest import ROOT, TINY, one_line_exit_2

runner = CliRunner()


def test_axis_labels_come_from_names_and_units_never_raw_keys():
    assert fs.label("scenario.speed_mps") == "robot speed (m/s)"
    assert fs.label("filters.*.particles") == "particles N"
    assert fs.label("rmse", "m") == "RMSE (m)" and fs.label("rmse") == "RMSE"
    assert fs.label("scenario.wheel_gap_deg") == "wheel gap (deg)"       # not in the table
    assert fs.label("scenario.some_thing") == "some thing"
    for key in ("scenario.steps", "filters.pf.neff_ratio", "scenario.bearing_noise_deg"):
        assert "." not in fs.label(key) and "_" not in fs.label(key)


@pytest.mark.parametrize("fmt", fs.FORMATS)
def test_every_format_gives_the_same_bytes_twice_and_replaces_the_other(tmp_path, write_config,
                                                                        fmt):
    exp = load(write_config(TINY))
    res = run_experiment(exp, tmp_path / "r", traces=False)
    a = plots.write_figures(exp, res.rows, tmp_path / "r", fmt)
    first = {p.name: p.read_bytes() for p in a}
    b = plots.write_figures(exp, res.rows, tmp_path / "r", fmt)
    assert {p.name: p.read_bytes() for p in b} == first and all(p.suffix == f".{fmt}" for p in a)
    other = "svg" if fmt != "svg" else "pdf"
    plots.write_figures(exp, res.rows, tmp_path / "r", other)
    assert {p.suffix for p in (tmp_path / "r/figures").iterdir()} == {f".{other}"}


def test_a_bad_figure_format_is_one_line(write_config):
    line = one_line_exit_2(runner.invoke(app, ["run", str(write_config(TINY)),
                                               "--figure-format", "jpg"]))
    assert "--figure-format jpg" in line and "png, svg, pdf" in line


def test_the_distributions_are_the_tables_quantities_in_the_papers_unit(monkeypatch):
    monkeypatch.chdir(ROOT)
    exp = load(ROOT / "configs/asrl_vs_srl.yaml")
    got = {m: (scale, label, q) for m, scale, label, q in plots._distribution_quantities(exp)}
    assert set(got) >= {"rmse", "x_error", "y_error"}
    assert got["x_error"][0] == 1000.0 and got["x_error"][1] == "x error (mm)"
    assert got["x_error"][2].metric == "x_error"


def _figures_saved(monkeypatch) -> list:
    saved = []
    monkeypatch.setattr(plots, "save_figure", lambda fig, path: saved.append((fig, path)))
    return saved


def test_the_distribution_marks_the_paper_and_our_mean_with_its_interval(tmp_path, monkeypatch):
    monkeypatch.chdir(ROOT)
    exp = load(ROOT / "configs/ifa_pf_ungm.yaml", {"trials": 3})
    res = run_experiment(exp, tmp_path / "u", traces=False)
    from pfbench.compare import compare
    table = compare(exp, res.rows).table
    saved = _figures_saved(monkeypatch)
    plots.write_figures(exp, res.rows, tmp_path / "u", "png", table)
    fig, path = next((f, p) for f, p in saved if p.stem == "rmse")
    ax = fig.axes[0]                                # the PF's panel: N = 50, 100, 150
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert "the paper's value" in labels and "our mean and its 95% interval" in labels
    paper = next(line for line in ax.get_lines() if line.get_label() == "the paper's value")
    assert paper.get_ydata()[0] == pytest.approx(4.2216)      # PF at N = 50, the first given
    box = ax.get_xticks()[0] - 0.1                  # on its box: the same x
    assert paper.get_xdata()[0] == pytest.approx(box)


def test_a_sweep_over_particles_draws_a_line_per_filter(tmp_path, write_config, monkeypatch):
    saved = _figures_saved(monkeypatch)
    cfg = write_config(TINY)
    res = runner.invoke(app, ["sweep", str(cfg), "--set", "filters.pf.particles=10,30,90",
                              "--out", str(tmp_path / "s")])
    assert res.exit_code == 0, res.output
    fig = next(f for f, p in saved if p.stem == "rmse")
    ax = fig.axes[0]
    assert ax.get_xlabel() == "particles N"
    pf = [line for line in ax.get_lines() if line.get_label().startswith("PF")]
    assert len(pf) == 1 and list(pf[0].get_xdata()) == [10, 30, 90]
    assert ax.collections, "the 95% bands"


def test_a_snapshot_shows_a_converged_and_a_failed_trial():
    class Run:
        key = "mcl@100"

    class T:
        trials = {k: {"mcl@100/snap_xy": 1} for k in range(4)}
    rows = pd.DataFrame({"trial": range(4), "filter": ["mcl@100"] * 4,
                         "converged": [0.0, 0.0, 1.0, 0.0]})
    assert plots._snapshot_trials(None, T, rows, Run) == [(2, 1.0), (0, 0.0)]
    rows["converged"] = 0.0
    assert plots._snapshot_trials(None, T, rows, Run) == [(0, 0.0)]


def test_with_kidnappings_the_outcome_is_recovering_from_every_one():
    class Run:
        key = "srl@100"

    class T:
        trials = {k: {"srl@100/snap_xy": 1} for k in range(3)}
    rows = pd.DataFrame({"trial": range(3), "filter": ["srl@100"] * 3,
                         "converged": [1.0, 1.0, 1.0], "recovery_failures": [1.0, 0.0, 2.0]})
    assert plots._snapshot_trials(None, T, rows, Run, kidnapped=True) == [(1, 1.0), (0, 0.0)]
    assert plots._snapshot_trials(None, T, rows, Run) == [(0, 1.0)]


# --- issue 36: figures for the claims -------------------------------------------------------

def test_a_sweep_axis_is_logarithmic_from_a_factor_of_8():
    assert plots.log_axis([25, 50, 100, 200]) and plots.log_axis([1, 8])
    assert not plots.log_axis([1, 2, 3, 4, 5]) and not plots.log_axis([10, 79])
    assert not plots.log_axis(["a", "b"])


@pytest.mark.parametrize("k,n", [(0, 100), (16, 100), (92, 100), (50, 50), (3, 7)])
def test_rates_carry_scipys_wilson_interval(k, n):
    from scipy.stats import binomtest
    ci = binomtest(k, n).proportion_ci(confidence_level=0.95, method="wilson")
    assert plots.wilson(k, n) == pytest.approx((ci.low, ci.high), rel=0, abs=1e-15)
    rows = pd.DataFrame({"trial": range(n), "filter": ["a@1"] * n,
                         "converged": [1.0] * k + [0.0] * (n - k)})

    class Run:
        key = "a@1"

    class Exp:
        filters = [Run]
    t = plots.rate_table(Exp, rows, rows["converged"])
    assert (t["k"][0], t["n"][0]) == (k, n) and t["rate"][0] == pytest.approx(k / n)
    assert (t["lo"][0], t["hi"][0]) == pytest.approx((ci.low, ci.high))


def test_a_positive_quantitys_band_stays_positive_where_the_normal_one_dips():
    rng = __import__("numpy").random.default_rng(7)
    x = rng.lognormal(-3.0, 1.5, size=20)           # run times: skewed, near 0
    m, se = x.mean(), x.std(ddof=1) / len(x) ** 0.5
    assert m - 1.96 * se * 3 < 0                      # a normal band of 3 se would dip below 0
    for k in (1, 3, 10):
        lo, hi = fs.lognormal_band(m, k * se)
        assert 0 < lo < m < hi
    summ = pd.DataFrame({"wall_s_mean": [m], "wall_s_se": [10 * se],
                         "wall_s_ci_lo": [m - 19.6 * se], "wall_s_ci_hi": [m + 19.6 * se]})
    lo, hi = plots.sweep_band(summ, "wall_s")
    assert lo[0] > 0 and hi[0] > m


def _committed(name):
    from pfbench.store import read_results
    exp = load(ROOT / f"configs/{name}.yaml")
    meta, tf = read_results(ROOT / "results" / name)
    return exp, pd.DataFrame(tf.rows)


def _titles(fig) -> str:
    return " ".join([fig._suptitle.get_text() if fig._suptitle else ""]
                    + [ax.get_title() for ax in fig.axes]
                    + [t.get_text() for ax in fig.axes for t in ax.get_xticklabels()])


def test_titles_count_the_trials_each_figure_shows(tmp_path, monkeypatch):
    monkeypatch.chdir(ROOT)
    exp, rows = _committed("sspf_global")
    saved = _figures_saved(monkeypatch)
    with fs.style():
        plots.distribution_figure(exp, rows, tmp_path / "c.png", "converge_step", 1.0,
                                  "steps to converge")
    text = _titles(saved[-1][0])
    for r in exp.filters:
        n = int(rows.loc[rows["filter"] == r.key, "converge_step"].notna().sum())
        assert f"{n} of {rows['trial'].nunique()}" in text
    assert "over 100 trials" not in text
    with fs.style():
        plots.rate_figure(exp, rows, tmp_path / "r.png")
    text = _titles(saved[-1][0])
    for r in exp.filters:
        k = int((rows.loc[rows["filter"] == r.key, "converged"] == 1).sum())
        assert f"{k} of {len(rows[rows['filter'] == r.key])}" in text


@pytest.mark.slow     # every committed figure drawn again: 14 s
def test_every_committed_figure_is_legible_at_1400_px(tmp_path, monkeypatch):
    """Drawn again from the committed trials and traces (no trial runs): no figure wider than
    1400 px, no text under 8 pt; many runs make small multiples with a shared axis."""
    monkeypatch.chdir(ROOT)
    from pfbench.store import read_results
    saved, ungm = [], []

    def check(fig, path):           # each figure checked as it is saved, then closed as saving does
        saved.append((path, fs.legibility(fig)))
        if path.parent.parent.name == "ifa_pf_ungm" and path.stem == "rmse":
            ungm.extend((len(ax.get_xticks()), ax.get_ylim()) for ax in fig.axes
                        if ax.get_visible())
        fs.pyplot().close(fig)
    monkeypatch.setattr(plots, "save_figure", check)
    for name in ("ifa_pf_ungm", "kidnap", "ifa_fastslam", "asrl_vs_srl", "plaza_global"):
        exp = load(ROOT / f"configs/{name}.yaml")
        meta, tf = read_results(ROOT / "results" / name)
        monkeypatch.setattr(plots, "read_traces", lambda _: __import__(
            "pfbench.store", fromlist=["read_traces"]).read_traces(ROOT / "results" / name))
        plots.write_figures(exp, tf.rows, tmp_path / name, "png")
    assert len(saved) > 15
    for path, problems in saved:
        assert problems == [], (path.parent.name, path.name)
    assert len(ungm) == 8 and all(ticks <= 3 for ticks, _ in ungm)     # its 8 panels
    assert len({ylim for _, ylim in ungm}) == 1                        # one shared axis
    drawn = {(p.parent.parent.name, p.stem) for p, _ in saved}
    assert {("kidnap", "paths"), ("plaza_global", "paths"), ("plaza_global", "rates"),
            ("asrl_vs_srl", "convergence")} <= drawn


def test_every_committed_sweep_cell_has_its_table():
    cells = sorted((ROOT / "results").glob("*/cells/*/trials.csv"))
    assert cells
    for t in cells:
        assert (t.parent / "table.md").is_file(), t.parent


# --- issue 35: paths over the map, convergence from a uniform start -------------------------

PATHS = f"""\
seed: 1
trials: 3
scenario: {{name: beacon_field, world: {ROOT / 'configs/worlds/beacon_field.yaml'}, steps: 40,
            initial: unknown}}
filters:
  dr: {{type: dead_reckoning, label: Dead reckoning}}
  mcl: {{label: MCL, particles: [100, 300]}}
  srl: {{type: mcl, label: SRL, particles: 300, reset: srl}}
  sspf: {{label: SSPF, particles: 60}}
"""


def _generated(exp, T=40, kidnaps=()):
    """A trace as the tracer keeps it, generated (no trial run): trial 0's paths on a circle,
    each filter's estimate off by a constant; rows with the converged trials."""
    from pfbench.store import Traces
    from pfbench.traces import path_runs, path_steps
    np = __import__("numpy")
    at = path_steps(T, kidnaps)
    a = np.linspace(0, 2 * np.pi, len(at))
    truth = np.c_[20 + 10 * np.cos(a), 20 + 10 * np.sin(a)].astype(np.float32)
    trial = {"path_step": at, "truth_path": truth}
    for i, r in enumerate(path_runs(exp)):
        trial[f"{r.key}/path"] = truth + np.float32(0.5 * i)
    world = {"beacons": np.array([[4, 20], [30, 6], [26, 37]], np.float32),
             "beacon_ids": np.array([0, 5, 6]), "area": np.array([40.0, 40.0]),
             "kidnaps": np.asarray(kidnaps, dtype=np.int64), "bound": np.asarray(2.0),
             "global_start": np.asarray(True)}
    rows = pd.DataFrame([{"trial": k, "filter": r.key, "rmse": 1.0 + k, "converged": float(k < 2),
                          "converge_step": 10.0 + k if k < 2 else float("nan")}
                         for r in exp.filters for k in range(3)])
    return Traces(world, {0: trial}), rows


def test_the_paths_figure_has_a_panel_per_filter_with_the_beacons_and_shared_axes(
        tmp_path, write_config, monkeypatch):
    exp = load(write_config(PATHS))
    traces, rows = _generated(exp)
    saved = _figures_saved(monkeypatch)
    with fs.style():
        plots.path_figure(exp, traces, tmp_path / "paths.png", rows)
    fig, _ = saved[-1]
    panels = [ax for ax in fig.axes if ax.get_visible()]
    assert [ax.get_title().split("\n")[0] for ax in panels] == [
        "MCL (N=300)", "SRL (N=300)", "SSPF (N=60)"]     # dead reckoning: in each, no panel
    assert "RMSE 1 m, converged at step 10" in panels[0].get_title()
    for ax in panels:
        labels = {t.get_text() for t in ax.texts}
        assert {"B0", "B5", "B6"} <= labels
        assert ax.get_xlim() == (0.0, 40.0) and ax.get_ylim() == (0.0, 40.0)
        assert ax.get_aspect() == 1.0
        dashed = [ln for ln in ax.get_lines() if ln.get_linestyle() == "--"]
        assert len(dashed) == 1                           # the dead-reckoning path
    assert panels[0].get_shared_x_axes().joined(panels[0], panels[2])
    assert {ax.get_xlabel() for ax in panels} == {"x (m)"}
    title = fig._suptitle.get_text().replace("\n", " ")
    assert "trial 0 (the first of 3)" in title and "steps 0 to 40" in title
    assert fs.legibility(fig) == []


def test_the_paths_break_at_a_kidnapping_and_say_a_thinned_span():
    np = __import__("numpy")
    steps = np.array([0, 5, 9, 10, 15], dtype=np.int32)
    xy = np.arange(10, dtype=float).reshape(5, 2)
    got = plots._broken(xy, steps, [10])
    assert got.shape == (6, 2) and np.isnan(got[3]).all()
    np.testing.assert_array_equal(got[4], xy[3])
    words = plots._span_words({"times": np.arange(16) * 0.2}, steps)
    assert words.startswith("0 to 3 s of the span (15 steps)") and "one step in 5" in words


def test_the_convergence_figure_draws_each_runs_wilson_rate_and_its_times(
        tmp_path, write_config, monkeypatch):
    exp = load(write_config(PATHS))
    traces, rows = _generated(exp)
    assert plots.draws_convergence(exp, rows, traces)
    saved = _figures_saved(monkeypatch)
    with fs.style():
        plots.convergence_figure(exp, rows, traces, tmp_path / "c.png")
    fig, _ = saved[-1]
    rate, when = fig.axes
    assert [t.get_text() for t in rate.get_yticklabels()] == [
        plots._run_name(r) for r in exp.filters]
    assert sum(t.get_text() == "2 of 3" for t in rate.texts) == len(exp.filters)
    lo, hi = plots.wilson(2, 3)                   # each run's bar: its Wilson interval in %
    ends = [tuple(seg[:, 0]) for c in rate.collections for seg in c.get_segments()]
    assert len(ends) == len(exp.filters)
    assert all(e == pytest.approx((100 * lo, 100 * hi)) for e in ends)
    dots = [ln for ln in when.get_lines() if ln.get_marker() == "o"]
    assert len(dots) == len(exp.filters)
    assert sorted(dots[0].get_xdata()) == [10.0, 11.0]        # steps: no times in the world
    assert when.get_xlabel() == "converged at (step)"
    assert fs.legibility(fig) == []
    # from the known start, or where the paper's table draws the rate: none
    traces.world["global_start"] = __import__("numpy").asarray(False)
    assert not plots.draws_convergence(exp, rows, traces)


def test_convergence_times_are_seconds_on_recorded_data():
    class Run:
        key = "mcl@100"
    rows = pd.DataFrame({"trial": [0, 1, 2], "filter": ["mcl@100"] * 3,
                         "converged": [1.0, 0.0, 1.0], "converge_step": [5.0, float("nan"), 20.0]})
    times = __import__("numpy").arange(30) * 0.25
    assert list(plots.converge_times(rows, Run, times)) == [1.25, 5.0]
    assert list(plots.converge_times(rows, Run, None)) == [5.0, 20.0]


def _slam_traces(exp, trials: int, seed: int = 5):
    """A SLAM trace of ``trials`` trials as SlamTracer keeps it, made up: each run's errors
    drawn around a level of its own."""
    import numpy as np
    from pfbench.store import Traces
    rng = np.random.default_rng(seed)
    t, t_obs = np.arange(0, 101, 4) * 0.1, np.arange(1, 51) * 0.2
    out = {}
    for k in range(trials):
        tr = {"error_time": t.astype(np.float32), "map_time": t_obs.astype(np.float32),
              "heading_window_s": np.asarray(1.0)}
        for i, r in enumerate(exp.filters):
            tr[f"{r.key}/error"] = (i + 1 + rng.random(t.size)).astype(np.float32)
            tr[f"{r.key}/heading_error"] = (0.01 * (i + 1) * rng.random(t.size)).astype(
                np.float32)
            m = 0.1 * (i + 1) + rng.random(t_obs.size) * 0.05
            m[:3] = np.nan                     # before any landmark is mapped
            tr[f"{r.key}/map_error"] = m.astype(np.float32)
        out[k] = tr
    return Traces({"landmarks": np.zeros((3, 2), np.float32)}, out)


def test_slam_errors_are_medians_and_bands_over_the_traced_trials(tmp_path, monkeypatch,
                                                                  write_config):
    """errors.png of a SLAM experiment: a row per run, a column per error, each the median
    over the kept trials with its interquartile band, the trial count in the title."""
    import warnings

    import numpy as np
    exp = load(write_config(f"""\
seed: 2
trials: 9
scenario: {{name: waypoint_course, world: {ROOT / 'configs/worlds/ifa_course.yaml'}, steps: 100}}
filters:
  fastslam: {{label: FastSLAM, particles: 10}}
  ifa: {{type: fastslam, label: IFA-FastSLAM, refine: ifa, particles: 10}}
  ba: {{type: fastslam, label: BA-FastSLAM, refine: ba, particles: 10}}
"""))
    traces = _slam_traces(exp, 6)
    saved = _figures_saved(monkeypatch)
    with fs.style():
        medians = plots.slam_error_figure(exp, traces, tmp_path / "errors.png")
    fig = saved[-1][0]
    assert fs.legibility(fig) == []
    axes = [ax for ax in fig.axes if ax.get_visible()]
    assert len(axes) == 3 * 3                                  # 3 runs x 3 errors
    title = fig._suptitle.get_text().replace("\n", " ")
    assert "median and interquartile band over the first 6 of 9 trials" in title
    assert [ax.get_title(loc="left") for ax in axes[::3]] == [
        "FastSLAM (N=10)", "IFA-FastSLAM (N=10)", "BA-FastSLAM (N=10)"]
    assert [ax.get_ylabel().split(" (")[0] for ax in axes[:3]] == [
        "position error", "heading error", "landmark error"]
    for r in exp.filters:
        for name in ("error", "heading_error", "map_error"):
            a = np.array([traces.trials[k][f"{r.key}/{name}"] for k in range(6)], dtype=float)
            with warnings.catch_warnings():                   # a column of NaN: NaN
                warnings.simplefilter("ignore", RuntimeWarning)
                want = np.nanmedian(a, axis=0) if name == "map_error" else np.median(a, axis=0)
            np.testing.assert_array_equal(medians[r.key][name], want)
    # each panel: the other runs' medians (grey), the band (a fill) and the run's median
    ax = axes[3]
    assert len(ax.collections) == 1 and len(ax.lines) == 3
    np.testing.assert_array_equal(ax.lines[-1].get_ydata(), medians["ifa@10"]["error"])
    for j in range(3):                                         # a column shares its axis from 0
        assert {axes[3 * i + j].get_ylim() for i in range(3)} == {axes[j].get_ylim()}
        assert axes[j].get_ylim()[0] == 0
    # a trace written before the error curves were kept (trial 0's paths only) still draws
    one = {"truth_pose": np.zeros((11, 3), np.float32), "time": np.arange(11, dtype=np.float32),
           "obs_time": np.arange(1, 6, dtype=np.float32)}
    for r in exp.filters:
        one[f"{r.key}/pose"] = np.ones((11, 3), np.float32)
        one[f"{r.key}/lm_trace"] = np.full(5, 0.5, np.float32)
    from pfbench.store import Traces
    with fs.style():
        old = plots.slam_error_figure(exp, Traces(traces.world, {0: one}), tmp_path / "o.png")
    np.testing.assert_allclose(old["fastslam@10"]["error"][1:], np.sqrt(2), rtol=1e-6)
    assert "over the first 1 of 9 trials" in saved[-1][0]._suptitle.get_text().replace("\n", " ")


def test_a_run_time_ratio_is_drawn_from_what_judges_it_and_its_times_only_with_timings(
        tmp_path, monkeypatch):
    """ifa_pf_ungm's time over the PF is judged on the likelihood evaluations over the PF's:
    ratios.png draws those from the committed trials (no run times there), beside the paper's
    time ratio; time_ratios.png the run times' ratio, only where the rows have them."""
    import numpy as np
    monkeypatch.chdir(ROOT)
    exp, rows = _committed("ifa_pf_ungm")
    fams = plots._families(exp)
    assert [(q.key, m) for q, m in fams["ratios"]] == [("time_ratio", "judged")]
    assert [(q.key, m) for q, m in fams["time_ratios"]] == [("time_ratio", "ours")]
    assert "wall_s" not in rows
    saved = _figures_saved(monkeypatch)
    plots.write_figures(exp, rows, tmp_path / "u", "png")
    names = [p.name for _, p in saved]          # drawn (save_figure is replaced: not written)
    assert "ratios.png" in names and "time_ratios.png" not in names
    fig = next(f for f, p in saved if p.name == "ratios.png")
    assert fs.legibility(fig) == []
    ax = fig.axes[0]
    assert ax.get_title().startswith("likelihood evaluations / PF")
    dots = next(ln for ln in ax.lines if ln.get_marker() == "o")      # ours: 2 or 5, PF's own 1
    assert set(np.round(dots.get_ydata(), 9)) == {1.0, 2.0, 5.0}
    assert [t.get_rotation() for t in ax.get_xticklabels()][0] == 35   # 16 names: slanted
    timed = rows.assign(wall_s=np.where(rows["label"] == "PF", 1.0, 3.0))
    saved.clear()
    plots.write_figures(exp, timed, tmp_path / "t", "png")
    assert {"ratios.png", "time_ratios.png"} <= {p.name for _, p in saved}
    fig = next(f for f, p in saved if p.name == "time_ratios.png")
    dots = next(ln for ln in fig.axes[0].lines if ln.get_marker() == "o")
    np.testing.assert_allclose(dots.get_ydata(), 3.0)


def test_a_recorded_spans_errors_are_over_time_and_its_dense_curves_pixels(
        tmp_path, write_config, monkeypatch):
    """On recorded data (step times in the world) the error figure's axis is time in seconds;
    a curve of more than DENSE_POINTS points is rasterized in a vector figure, a short one not."""
    import numpy as np
    from pfbench.store import Traces
    exp = load(write_config(PATHS))
    saved = _figures_saved(monkeypatch)

    def draw(T, times):
        rng = np.random.default_rng(3)
        trials = {k: {f"{r.key}/error": rng.random(T + 1).astype(np.float32)
                      for r in exp.filters} for k in range(3)}
        world = {"kidnaps": np.zeros(0, np.int64), "bound": np.asarray(2.0)}
        if times:
            world["times"] = np.arange(T + 1) * 0.2
        with fs.style():
            plots.localization_error_figure(exp, Traces(world, trials), tmp_path / "e.png")
        fig, _ = saved[-1]
        ax = fig.axes[0]
        return ax, [a for a in ax.get_children() if getattr(a, "get_rasterized", None)
                    and a.get_rasterized()]

    ax, dense = draw(plots.DENSE_POINTS + 10, times=True)
    assert fig_xlabel(ax) == "time (s)"
    median = next(ln for ln in ax.get_lines() if ln.get_label() == "median")
    assert median.get_xdata()[-1] == pytest.approx(0.2 * (plots.DENSE_POINTS + 10))
    assert len(dense) >= 2                          # the band and the median at least
    ax, dense = draw(100, times=False)
    assert fig_xlabel(ax) == "step" and dense == []


def fig_xlabel(ax) -> str:
    """The x label of the bottom panel of ``ax``'s column (the panels share x)."""
    fig = ax.figure
    bottom = [a for a in fig.axes if a.get_visible() and a.get_xlabel()]
    return bottom[0].get_xlabel() if bottom else ""
