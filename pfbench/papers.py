"""The values the papers report, keyed by paper and table: the comparison columns of our tables.

Each reported quantity says which of our summary statistics it corresponds to (``ours``: metric and
statistic over trials). The notes record what we had to decide to read the table; PAPERS.md in the
project's shared material has the full digest.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field


@dataclass(frozen=True)
class Quantity:
    key: str
    title: str
    metric: str        # our per-trial metric column, or 'time_ratio', 'gain_mean', 'gain_var'
    stat: str          # 'mean' or 'var' over trials
    not_comparable: str | None = None   # why our value cannot be held against the paper's
    scale: float = 1.0                  # our metric times this is in the paper's unit


@dataclass(frozen=True)
class PerTrial:
    """A table of one metric per run, as a paper prints it (runs as columns): each paper row beside
    the first ``runs`` trials of one of our filter runs and our mean over all trials."""
    metric: str                          # our per-trial metric column
    title: str
    rows: tuple[tuple[str, str, tuple[float, ...]], ...]   # (paper's row name, our label, values)
    also: tuple[str, ...] = ()           # further metrics of ours shown per trial, no paper values

    @property
    def runs(self) -> int:
        return max(len(v) for _, _, v in self.rows)


@dataclass(frozen=True)
class Table:
    caption: str
    quantities: tuple[Quantity, ...]
    # (label, particles or None) -> {quantity key: value}
    values: dict
    notes: tuple[str, ...] = ()
    not_comparable: str | None = None   # the reason, when no value of ours can be compared
    # quantity key (or keys) whose order across rows the paper claims or its values show
    ranking: str | tuple[str, ...] | None = None
    # (label, particles or None, quantity key) -> why that one paper value cannot be compared
    cell_notes: dict = field(default_factory=dict)
    per_trial: PerTrial | None = None
    # (quantity key, from label, to label): the paper's factor between two rows beside ours
    factors: tuple[tuple[str, str, str], ...] = ()


@dataclass(frozen=True)
class Paper:
    key: str
    citation: str
    tables: dict = field(default_factory=dict)


def _rows(labels, counts, table):
    return {(lab, n): {"rmse_mean": v} for lab, row in zip(labels, table) for n, v in zip(counts, row)}


def _with_time_ratios(rows, pf_seconds, seconds):
    """Add the run-time ratio to the PF (the paper's times for 30 runs at N = 100)."""
    for label, t in seconds.items():
        rows[(label, 100)]["time_ratio"] = round(t / pf_seconds, 2)
    return rows


_RMSE = Quantity("rmse_mean", "RMSE", "rmse", "mean")
_COURSE = "course and bearing noise unpublished"

PAPERS = {
    "ifa2021": Paper(
        "ifa2021",
        "Cui et al., accuracy of SLAM with a bionic-algorithm-improved particle filter, "
        "Control and Decision 36(1), 2021",
        {
            "table1": Table(
                "UNGM (Q = R = 1, T = 100): RMSE over time of PF, BA-PF, FA-PF and IFA-PF at "
                "N = 50, 100, 150",
                (_RMSE, Quantity("time_ratio", "time / PF", "time_ratio", "mean")),
                _with_time_ratios(
                    _rows(("PF", "BA-PF", "FA-PF", "IFA-PF"), (50, 100, 150),
                          ((4.2216, 3.0043, 2.4415), (3.6631, 2.5799, 1.8336),
                           (3.2270, 2.4075, 1.6815), (2.9783, 1.8843, 1.2885))),
                    0.3076, {"FA-PF": 0.7500, "BA-PF": 0.7002, "IFA-PF": 0.6412}),
                ranking="rmse_mean",
                notes=(
                    "The paper prints the denominator as 1 - x^2; every filter diverges with it, so "
                    "1 + x^2 is the default (scenario.denominator: minus gives the printed form).",
                    "The number of Monte Carlo runs is not stated; the PF row falls like 1/sqrt(N), "
                    "the signature of a few runs rather than a many-run average.",
                    "The particle prior is not stated; the config states ours.",
                    "Reproduced here means: PF at N = 50 within 10%, and the ranking of the four "
                    "filters; values below what a PF with many particles reaches are marked as "
                    "below the model's floor.",
                    "'time / PF': the paper's MATLAB times for 30 runs at N = 100 (PF 0.3076 s, "
                    "FA-PF 0.7500 s, BA-PF 0.7002 s, IFA-PF 0.6412 s) as ratios; ours is the mean "
                    "over trials of each filter's wall time over the PF's on the same trial. "
                    "Interpreted MATLAB loops and compiled kernels weigh the same work differently.",
                    "The swarm filters weigh the moved particles by the likelihood without "
                    "correcting for the move, as the paper does; their parameters not in the paper "
                    "(FA's step, the bat and fish settings) are the configs' documented defaults.",
                ),
            ),
            "table3": Table(
                "FastSLAM variants on a 15-waypoint, 31-landmark course in 100 m x 80 m, 8000 "
                "control steps, 20 runs: position RMSE mean and 'variance' (as printed) over runs, "
                "and the gains over FastSLAM in %",
                (Quantity("rmse_mean", "RMSE mean", "rmse", "mean", _COURSE),
                 Quantity("rmse_var", "RMSE variance", "rmse", "var", _COURSE),
                 Quantity("accuracy_gain", "accuracy gain %", "gain_mean", "mean"),
                 Quantity("stability_gain", "stability gain %", "gain_var", "mean")),
                {("FastSLAM", None): {"rmse_mean": 2.2418, "rmse_var": 1.0612},
                 ("BA-FastSLAM", None): {"rmse_mean": 1.2234, "rmse_var": 0.8269,
                                         "accuracy_gain": 45.4, "stability_gain": 22.2},
                 ("FA-FastSLAM", None): {"rmse_mean": 1.1313, "rmse_var": 0.5596,
                                         "accuracy_gain": 49.5, "stability_gain": 47.2},
                 ("IFA-FastSLAM", None): {"rmse_mean": 0.4160, "rmse_var": 0.2089,
                                          "accuracy_gain": 81.4, "stability_gain": 80.3}},
                notes=(
                    "The course is only drawn in the paper; configs/worlds/ifa_course.yaml is ours. "
                    "The bearing noise, sensor range, observation interval, waypoint radius and "
                    "particle count are not given: the config states ours (the classic "
                    "simulator's 1 deg, 30 m, every 8th step, 1 m; 100 particles). With 1 deg a "
                    "FastSLAM on such a course stays well under 1 m; the paper's range needs about "
                    "3 deg. So the verdict is about the gains over FastSLAM and the ranking, never "
                    "the metres.",
                    "Gains: accuracy 100 (1 - mean_f / mean_FastSLAM) with an interval from the "
                    "paired per-trial differences (the baseline's mean taken as known); stability "
                    "100 (1 - var_f / var_FastSLAM) with a conservative interval from the two "
                    "variances' intervals.",
                    "The swarm moves act on poses (x, y, heading): random steps in units of the "
                    "predicted cloud's spread per coordinate, headings unwrapped around the cloud's "
                    "mean; IFA's brightness combines the innovations' Mahalanobis distance with the "
                    "pose's distance from the predicted cloud. The paper specifies neither.",
                ),
                ranking="rmse_mean",
            ),
        },
    ),
    "afsa2014": Paper(
        "afsa2014",
        "FastSLAM improved by the artificial fish swarm algorithm with directional resampling "
        "(PAPERS.md section 2)",
        {
            "table1": Table(
                "PSO-FastSLAM and AFSA-FastSLAM (fish-swarm pose refinement, directional "
                "resampling) in a 50 m x 60 m landmark world, 10 particles, nearest-neighbour "
                "association: mean position, heading and landmark errors (the paper's text), "
                "Neff averaged over time and 10 runs, and particle diversity (its Table 1)",
                (Quantity("pos_mean", "position error (m)", "position_error", "mean"),
                 Quantity("heading_mean", "heading error (rad)", "heading_error", "mean"),
                 Quantity("landmark_mean", "landmark error (m)", "landmark_error", "mean"),
                 Quantity("neff_mean", "Neff", "mean_ess", "mean"),
                 Quantity("diversity_mean", "diversity", "diversity_l1", "mean",
                          "the paper's 'mean Hamming distance' is undefined (values above 1); "
                          "compare the directional / traditional ratio below")),
                {("PSO-FastSLAM", 10): {"pos_mean": 0.41, "heading_mean": 0.0034,
                                        "landmark_mean": 0.037},
                 ("AFSA-FastSLAM", 10): {"pos_mean": 0.034, "heading_mean": 0.003,
                                         "landmark_mean": 0.0035, "neff_mean": 4.616,
                                         "diversity_mean": 0.978},
                 ("AFSA-FastSLAM (standard resampling)", 10): {"neff_mean": 0.336,
                                                               "diversity_mean": 0.336}},
                cell_notes={("AFSA-FastSLAM (standard resampling)", 10, "neff_mean"):
                            "0.336 as printed is impossible for Neff >= 1 (it equals the "
                            "diversity mean)"},
                per_trial=PerTrial(
                    "diversity_l1", "Particle diversity per run after resampling (the paper's "
                    "Table 1, 'mean Hamming distance'; ours: mean pairwise L1 pose distance)",
                    (("traditional", "AFSA-FastSLAM (standard resampling)",
                      (0.42, 0.29, 0.32, 0.39, 0.19, 0.27, 0.34, 0.49, 0.35, 0.30)),
                     ("directional", "AFSA-FastSLAM",
                      (1.05, 0.96, 1.00, 0.91, 0.96, 1.02, 0.93, 1.05, 0.94, 0.96))),
                    also=("distinct_frac",)),
                factors=(("pos_mean", "PSO-FastSLAM", "AFSA-FastSLAM"),
                         ("heading_mean", "PSO-FastSLAM", "AFSA-FastSLAM"),
                         ("landmark_mean", "PSO-FastSLAM", "AFSA-FastSLAM"),
                         ("diversity_mean", "AFSA-FastSLAM (standard resampling)",
                          "AFSA-FastSLAM")),
                notes=(
                    "The world is only drawn in the paper; configs/worlds/afsa_world.yaml is ours "
                    "(24 landmarks around a closed path of about 110 m), and so are the number of "
                    "steps, the time step and the observation interval, so the metres are ours "
                    "too: the verdict is about the order of the filters and the size of the "
                    "improvement.",
                    "The paper compares AFSA-FastSLAM with a PSO-improved FastSLAM; which filter its "
                    "Neff and diversity values ('traditional' against 'directional resampling') "
                    "come from is not said: we put them beside AFSA-FastSLAM with standard and "
                    "with directional resampling, and show FastSLAM with either too.",
                    "Neff is 1 / sum W^2 of the normalised weights before resampling, averaged over "
                    "the observations of a trial, then over trials.",
                    "Diversity: the paper's 'mean Hamming distance' of the particles cannot be a "
                    "fraction of differing bits (values above 1); ours is the mean pairwise L1 "
                    "distance |dx| + |dy| + |dtheta| (m and rad) of the poses right after "
                    "resampling, averaged over the resampling steps, beside the fraction of "
                    "distinct particles. Its size depends on directional resampling's copy noise, "
                    "which the paper does not give (ours: directional_noise_m / _deg).",
                    "Association: nearest neighbour with each particle's pose uncertainty in the "
                    "gate (see the README); the position, heading and landmark errors are means "
                    "over time (the paper: 'mean error').",
                ),
            ),
        },
    ),
    "sspf2008": Paper(
        "sspf2008",
        "Luo & Tan, global localization with the SSPF algorithm, J. Transducer Technology 27(5), "
        "2008",
        {
            "table1": Table(
                "UKF, PF, PFMH and SSPF: mean and variance over 100 runs of the per-run 'MSE' (the "
                "paper states UNGM with Q = 10, R = 1, T = 60, x_0 = 1, N = 200)",
                (Quantity("mse_mean", "MSE mean", "rmse", "mean"),
                 Quantity("mse_var", "MSE variance", "rmse", "var")),
                {("UKF", None): {"mse_mean": 0.2646, "mse_var": 0.0094},
                 ("PF", 200): {"mse_mean": 0.4540, "mse_var": 0.0535},
                 ("PFMH", 200): {"mse_mean": 0.4209, "mse_var": 0.0545},
                 ("SSPF", 200): {"mse_mean": 0.0679, "mse_var": 0.0061}},
                notes=(
                    "The paper's 'MSE' is the per-run RMS error (the convention of the benchmark "
                    "the values match), summarised as mean and variance over 100 runs.",
                    "The values match the Gamma-noise benchmark of van der Merwe et al., 'The "
                    "Unscented Particle Filter' (2000), not UNGM (the SSPF row equals that paper's "
                    "PF with UKF proposal): a bootstrap PF on UNGM with these settings has an RMSE "
                    "near 4.7, and a UKF is worse than the PF on UNGM, not better. Scenario "
                    "upf_gamma (configs/sspf_upf_gamma.yaml) reproduces the table; on UNGM "
                    "(configs/sspf_ungm.yaml) the rows differ.",
                    "On upf_gamma the values are those of the benchmark's reference implementation: "
                    "it adds 1e-99 to the likelihood, which ties all particles whenever none lies "
                    "near the measurement (R = 1e-5), and its EKF, UKF and UKF proposals take the "
                    "Gamma noise (mean 1.5) as zero-mean. Rows marked '(exact)' run the same "
                    "filters without these: the PF's error then falls about tenfold.",
                    "The reference's RMSE also averages t = 1 (error 0), which makes its values "
                    "0.8% smaller than ours over t = 2..60.",
                ),
            ),
            "field": Table(
                "Global localization on the 40 m x 40 m beacon field (one beacon's range a step, "
                "1000 particles, 80 steps), MCL against SSPF: the paper shows one run in figures "
                "and prints one point",
                (Quantity("converged", "converged (success rate)", "converged", "mean"),
                 Quantity("converge_step", "convergence step", "converge_step", "mean"),
                 Quantity("final_error", "final error (m)", "final_error", "mean"),
                 Quantity("step39", "error at step 39 (m)", "error_at_step", "mean")),
                {("SSPF", 1000): {"step39": round(math.hypot(0.99 - 0.98, 4.26 - 4.22), 3)}},
                cell_notes={("SSPF", 1000, "step39"): "one run: true (0.98, 4.22), estimate "
                            "(0.99, 4.26); ours is the mean over trials, the figure the spread"},
                notes=(
                    "The paper's only number: at step 39 of one run the true position is (0.98, "
                    "4.22) and the estimate (0.99, 4.26), an error of 0.041 m; its figures show "
                    "the particles converging after a few steps and the error per step.",
                    "Convergence: the first step after which the position error stays below "
                    "0.5 m; success: the filter converged by the last step.",
                    "The field, the path, the beacons' detection radius and every noise level are "
                    "ours (the paper gives none); SSPF's initial covariance and its jitter are "
                    "the keys of the config, stated in the README.",
                ),
            ),
        },
    ),
}


_ASRL_ROWS = (
    (100, (71.25, 52.17, 3.85), (42.49, 44.44, 2.49)),
    (200, (84.01, 54.70, 5.17), (49.09, 49.86, 4.44)),
    (400, (73.25, 42.83, 4.90), (26.97, 28.18, 1.95)),
    (500, (50.78, 63.48, 4.46), (44.55, 44.74, 2.49)),
    (1000, (53.40, 40.82, 3.28), (48.72, 40.52, 2.54)),
    (1500, (42.98, 45.13, 2.51), (40.88, 49.14, 4.27)),
    (2000, (56.84, 44.57, 3.50), (49.74, 44.65, 2.84)),
    (5000, (50.25, 43.90, 2.33), (46.94, 27.51, 2.52)),
    (10000, (55.75, 40.12, 3.49), (46.42, 45.44, 4.14)),
)


def _asrl_values():
    keys = ("x_mm", "y_mm", "th_deg")
    out = {}
    for n, srl, asrl in _ASRL_ROWS:
        out[("SRL", n)] = dict(zip(keys, srl))
        out[("ASRL", n)] = dict(zip(keys, asrl))
    return out


PAPERS["asrl2008"] = Paper(
    "asrl2008",
    "Adaptive sensor resetting localization (ASRL) for mobile robots, 2008 (PAPERS.md section 4)",
    {
        "table1": Table(
            "SRL and ASRL: mean localization error in x, y (mm) and heading (deg) at 100 to 10000 "
            "particles",
            (Quantity("x_mm", "x error (mm)", "x_error", "mean", scale=1000.0),
             Quantity("y_mm", "y error (mm)", "y_error", "mean", scale=1000.0),
             Quantity("th_deg", "heading error (deg)", "heading_error", "mean",
                      scale=180.0 / math.pi)),
            _asrl_values(),
            not_comparable="a real robot indoors with a camera; ours simulates the beacon field",
            ranking=("x_mm", "y_mm", "th_deg"),
            notes=(
                "The paper ran a real robot with a camera seeing six landmarks; we rerun it in "
                "simulation on the beacon field with range-bearing observations and asrl2008's "
                "odometry model (alpha1..alpha4 decoded from damaged text). So the comparison is "
                "about the ranking of SRL and ASRL and the trend with the particle count, never "
                "the millimetres.",
                "The paper does not say over which steps its mean error runs; ours averages the "
                "steps from the scenario's score_from on (after the global localization), over "
                "trials.",
                "The paper's own values show no steady trend with the particle count (SRL's x "
                "error is 71 mm at 100 particles, 84 at 200, 43 at 1500, 56 at 10000): a few runs "
                "of a real robot per cell.",
                "ASRL's mu and p_t and SRL's fraction and threshold are not given; the config "
                "states ours.",
            ),
        ),
        "kidnap": Table(
            "Kidnapping twice: steps to recover (position error below the bound again) and "
            "kidnappings never recovered from, for MCL, SRL, ASRL, augmented MCL and KLD-MCL",
            (Quantity("recovery", "recovery steps", "recovery_steps", "mean"),
             Quantity("failures", "failures per trial", "recovery_failures", "mean"),
             Quantity("converged", "localized before the first kidnapping (rate)", "converged",
                      "mean")),
            {("ASRL", None): {"recovery": (10.0, 20.0)}},
            notes=(
                "asrl2008 reports that ASRL recovers from each of two kidnappings in 10-20 steps "
                "(a real robot, a camera; the bound of 'recovered' not stated); the other rows "
                "are the baselines of review2007 and have no paper values.",
                "Recovery steps average over the kidnappings a trial recovers from; failures "
                "count those it never recovers from before the next kidnapping or the end.",
            ),
        ),
    },
)


PAPERS["review2007"] = Paper(
    "review2007",
    "Yu & Wang, a review of particle-filter localization and mapping, Robot 29(3), 2007 (a "
    "survey: no tables of its own; its MCL family runs as the baselines of the beacon-field "
    "configs)",
)


def reported(paper: str | None, table: str | None) -> Table | None:
    """The reported table, or None for an experiment that names none."""
    if paper is None or table is None:
        return None
    return PAPERS[paper].tables[table]


# What each paper leaves open or ambiguous, and the config keys that hold the values we use; the
# report reads the values from the configs (PAPERS.md: "says in the generated report which choice
# produced the numbers"). Each key applies to the configs of that paper that have it.
CHOICES: dict[str, tuple[tuple[str, tuple[str, ...]], ...]] = {
    "ifa2021": (
        ("UNGM denominator printed as 1 - x^2 (every filter diverges with it)",
         ("scenario.denominator",)),
        ("UNGM cosine argument, printed 8 cos(1.2 (t - 1))", ("scenario.cosine_time",)),
        ("particle prior: not stated", ("scenario.prior_mean", "scenario.prior_var")),
        ("Monte Carlo runs: Table 1 not stated, Table 3 20", ("trials",)),
        ("how IFA turns a distance into a brightness: not stated",
         ("filters.ifa.brightness",)),
        ("EWA bias correction, printed inside the recursion", ("filters.ifa.ewa_correction",)),
        ("the course: only drawn", ("scenario.world",)),
        ("bearing noise: not given", ("scenario.bearing_noise_deg",)),
        ("sensor range: not given", ("scenario.max_range_m",)),
        ("observation interval (control steps): not given", ("scenario.obs_every",)),
        ("waypoint acceptance radius: not given", ("scenario.waypoint_radius_m",)),
        ("FastSLAM particle count: not given", ("filters.fastslam.particles",)),
        ("Fig. 7's robot speeds: not listed", ("scenario.speed_mps",)),
    ),
    "afsa2014": (
        ("the world and the robot's path: only drawn", ("scenario.world",)),
        ("steps per run: not given", ("scenario.steps",)),
        ("noise values called 'variance' (read as standard deviations or variances)",
         ("scenario.noise_values",)),
        ("Neff threshold for resampling: not given", ("filters.fastslam.neff_ratio",)),
        ("nearest-neighbour gates: not given",
         ("filters.fastslam.gate_reject", "filters.fastslam.gate_augment")),
        ("AFSA visual range, step, crowding factor, iterations: not given",
         ("filters.afsa.visual", "filters.afsa.step", "filters.afsa.crowding",
          "filters.afsa.iterations")),
        ("directional resampling noise nu: not given",
         ("filters.afsa.directional_noise_m", "filters.afsa.directional_noise_deg")),
        ("Monte Carlo runs: 10", ("trials",)),
    ),
    "sspf2008": (
        ("the model behind Table 1 (stated UNGM; the values match van der Merwe's Gamma "
         "benchmark)", ("scenario.name",)),
        ("particle prior on UNGM: not stated", ("scenario.prior_mean", "scenario.prior_var")),
        ("the weight-change threshold sigma: not given", ("filters.sspf.sigma",)),
        ("the reference implementation's likelihood floor (Gamma benchmark)",
         ("filters.pf.likelihood_floor",)),
        ("the Gamma noise's mean in the Gaussian filters and proposals (Gamma benchmark)",
         ("filters.ukf.process_noise_mean", "filters.sspf.process_noise_mean")),
        ("the UKF proposal's noise (Gamma benchmark)",
         ("filters.sspf.process_noise_var", "filters.sspf.measurement_noise_var")),
        ("Monte Carlo runs: 100 (Table 1); the field: one run", ("trials",)),
        ("the field's path, step length and turns: not given",
         ("scenario.step_m", "scenario.max_turn_deg")),
        ("beacon detection radius and every noise level: not given",
         ("scenario.max_range_m", "scenario.range_noise_m", "scenario.trans_noise_m",
          "scenario.turn_noise_deg")),
        ("SSPF's initial covariance and jitter on the field: not given",
         ("filters.sspf.init_std_m", "filters.sspf.init_std_deg", "filters.sspf.jitter_m",
          "filters.sspf.jitter_deg")),
        ("what 'converged' means: not given", ("scenario.converge_bound_m",)),
    ),
    "asrl2008": (
        ("odometry noise alpha1..alpha4 (decoded from damaged text)", ("scenario.alphas",)),
        ("the camera's field of view and range: not given",
         ("scenario.field_of_view_deg", "scenario.max_range_m")),
        ("range and bearing noise: not given",
         ("scenario.range_noise_m", "scenario.bearing_noise_deg")),
        ("the steps the mean error averages: not given", ("scenario.score_from",)),
        ("SRL's reset fraction and threshold: not given",
         ("filters.srl.srl_fraction", "filters.srl.srl_threshold")),
        ("ASRL's mu and p_t: not given", ("filters.asrl.asrl_mu", "filters.asrl.asrl_pt")),
        ("the kidnappings: when, and where to (no poses: drawn uniformly over the field)",
         ("scenario.kidnap_steps", "scenario.kidnap_poses")),
        ("when a filter has recovered: not given", ("scenario.converge_bound_m",)),
        ("Monte Carlo runs: a real robot, runs not stated", ("trials",)),
    ),
    "review2007": (
        ("augmented MCL's averaging rates (after Thrun, Burgard and Fox)",
         ("filters.augmented.alpha_slow", "filters.augmented.alpha_fast")),
        ("what augmented MCL injects", ("filters.augmented.inject",)),
        ("KLD-sampling's epsilon, delta, bins and least count (after Fox)",
         ("filters.kld.kld_epsilon", "filters.kld.kld_delta", "filters.kld.kld_bin_m",
          "filters.kld.kld_bin_deg", "filters.kld.kld_min")),
        ("KLD-sampling's largest count", ("filters.kld.particles",)),
    ),
}

# The report's short summary per paper: what reproduced and what did not, and why (PAPERS.md's
# reasons). {config:run:column} is filled in from that config's recomputed table (:ci adds the
# 95% interval), so the numbers are always those of the committed results.
FINDINGS: dict[str, tuple[str, ...]] = {
    "ifa2021": (
        "Table 1, PF at N = 50: {ifa_pf_ungm:pf@50:rmse_mean:ci} against the paper's 4.2216: "
        "{ifa_pf_ungm:pf@50:verdict_rmse_mean} (the project's bar: within 10%).",
        "The paper's PF at N = 100 and 150 and most swarm-filter values lie below the floor of "
        "this model: a PF with 5000 particles averages "
        "{ifa_pf_ungm:pf_floor@5000:rmse_mean:ci}, so no filter can average 3.0 or 1.3; the "
        "paper's PF row falls like 1/sqrt(N), the signature of a few runs (PAPERS.md).",
        "With the paper's firefly parameters the swarm filters do not improve on the PF at the "
        "same N: at N = 100 PF {ifa_pf_ungm:pf@100:rmse_mean}, BA-PF "
        "{ifa_pf_ungm:ba@100:rmse_mean}, FA-PF {ifa_pf_ungm:fa@100:rmse_mean}, IFA-PF "
        "{ifa_pf_ungm:ifa@100:rmse_mean} (paper 3.00, 2.58, 2.41, 1.88); a PF with IFA's "
        "likelihood evaluations reaches {ifa_pf_ungm:pf_equal@200:rmse_mean}.",
        "Run time over the PF at N = 100: FA {ifa_pf_ungm:fa@100:ours_time_ratio}, IFA "
        "{ifa_pf_ungm:ifa@100:ours_time_ratio}, BA {ifa_pf_ungm:ba@100:ours_time_ratio} "
        "(paper 2.44, 2.08, 2.28 in MATLAB); compiled kernels make the PF itself cheap, so the "
        "swarm's O(N^2) firefly moves weigh more.",
        "Table 3 (FastSLAM): the course and the bearing noise are unpublished, so the metres are "
        "not comparable (ours: FastSLAM {ifa_fastslam:fastslam@100:rmse_mean:ci} m against the "
        "paper's 2.24). The gains over FastSLAM do not reproduce: IFA-FastSLAM "
        "{ifa_fastslam:ifa@100:ours_accuracy_gain:ci} % (paper 81.4), FA-FastSLAM "
        "{ifa_fastslam:fa@100:ours_accuracy_gain:ci} % (49.5), BA-FastSLAM "
        "{ifa_fastslam:ba@100:ours_accuracy_gain:ci} % (45.4); FastSLAM with IFA's evaluations "
        "{ifa_fastslam:fastslam_equal@300:ours_accuracy_gain:ci} %.",
    ),
    "afsa2014": (
        "Position error, AFSA-FastSLAM {afsa_fastslam:afsa@10:ours_pos_mean:ci} m against "
        "PSO-FastSLAM {afsa_fastslam:pso@10:ours_pos_mean:ci} m (paper 0.034 against 0.41): the "
        "paper's twelvefold improvement is not seen in our world (the paper's world, path and "
        "run length are only drawn; the factors below compare like with like).",
        "Directional resampling raises the particle diversity as the paper says, by more than "
        "it says (mean pairwise L1 {afsa_fastslam:afsa_std@10:ours_diversity_mean} -> "
        "{afsa_fastslam:afsa@10:ours_diversity_mean}; paper 0.336 -> 0.978 in an undefined "
        "unit), but its Neff {afsa_fastslam:afsa@10:ours_neff_mean} is far from the paper's "
        "4.616 of 10; the paper's 0.336 for the traditional Neff is impossible (Neff >= 1).",
    ),
    "sspf2008": (
        "Table 1 reproduces, all four rows, mean and variance, on the benchmark its values come "
        "from (van der Merwe et al.'s Gamma-noise model, not the UNGM the paper names): SSPF "
        "{sspf_upf_gamma:sspf@200:rmse_mean:ci} (paper 0.0679), PF "
        "{sspf_upf_gamma:pf@200:rmse_mean:ci} (0.4540) - but only with that benchmark's "
        "reference-implementation choices (a 1e-99 likelihood floor, zero-mean Gaussian "
        "stand-ins for the Gamma noise); the same filters without them are far more accurate "
        "(PF {sspf_upf_gamma:pf_exact@200:rmse_mean}, SSPF "
        "{sspf_upf_gamma:sspf_exact@200:rmse_mean}).",
        "On UNGM as the paper states it the rows do not reproduce: PF "
        "{sspf_ungm:pf@200:rmse_mean:ci}, UKF {sspf_ungm:ukf:rmse_mean:ci}, SSPF "
        "{sspf_ungm:sspf@200:rmse_mean:ci}: the UKF is worse than the PF there, not better, and "
        "no error definition gives the paper's values (PAPERS.md).",
        "Global localization on the beacon field (our field, path and noise; the paper gives "
        "none): SSPF converges in {sspf_global:sspf@1000:ours_converged} of the trials, MCL with "
        "the same 1000 particles in {sspf_global:mcl@1000:ours_converged}; SSPF's error at step "
        "39 is {sspf_global:sspf@1000:ours_step39:ci} m on average, against the paper's single "
        "run's 0.041 m (not comparable: one run).",
    ),
    "asrl2008": (
        "Table 1 ran a real robot, so the millimetres are not comparable (ours, SRL at 1000 "
        "particles: x {asrl_vs_srl:srl@1000:ours_x_mm:ci} mm against the paper's 53.4); the "
        "ranking of SRL and ASRL is compared per particle count and error component (see the "
        "summary table), and the paper's own values show no trend with the particle count.",
        "Kidnapping: ASRL recovers in {kidnap:asrl@1000:ours_recovery:ci} steps against the "
        "paper's 10-20: {kidnap:asrl@1000:verdict_recovery}. SRL recovers in "
        "{kidnap:srl@1000:ours_recovery:ci}; augmented MCL in "
        "{kidnap:augmented@1000:ours_recovery:ci} with {kidnap:augmented@1000:ours_failures} "
        "failures per trial; plain MCL and KLD-MCL never recover "
        "({kidnap:mcl@1000:ours_failures} and {kidnap:kld@5000:ours_failures} of 2 "
        "kidnappings per trial).",
    ),
    "review2007": (
        "The survey reports no numbers; its MCL family runs here as the baselines of the "
        "beacon-field configs, and the kidnapped robot separates them as it says. Of 2 "
        "kidnappings per trial plain MCL never recovers from "
        "{kidnap:mcl@1000:ours_failures:ci}, KLD-sampling MCL (at most 5000 particles, "
        "{kidnap:kld@5000:lik_evals_per_step} a step on average) from "
        "{kidnap:kld@5000:ours_failures:ci}; augmented MCL (random particles while the "
        "short-term likelihood is below the long-term one) recovers in "
        "{kidnap:augmented@1000:ours_recovery:ci} steps and never from "
        "{kidnap:augmented@1000:ours_failures:ci}; asrl2008's sensor resetting in "
        "{kidnap:srl@1000:ours_recovery} (SRL) and {kidnap:asrl@1000:ours_recovery} (ASRL) "
        "steps.",
        "Global localization from a uniform start with one beacon range a step: plain MCL with "
        "1000 particles converges in {sspf_global:mcl@1000:ours_converged} of the trials (see "
        "sspf2008).",
    ),
}
