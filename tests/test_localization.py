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
