"""The experiment methods: a task, methods fitted on its training beams, scores on held-out."""

import numpy as np
import pytest

import potmap

ex = potmap.experiment


@pytest.fixture(scope="module")
def task(town_scans):
    return ex.make_task(town_scans[:3], seed=1)


def test_bhm_method_equals_the_joint_bhm_over_the_task(task, ctx):
    t, test = task
    assert len(t.train_scans) == 3 and len(test) > 0 and len(t.train) > len(test)
    fitted = ex.bhm_method().fit(ctx, t)
    # The same learner by hand: the joint BHM on a grid over the task's area, scan by scan.
    bhm = potmap.JointBhm(2, lo=t.lo, hi=t.hi)
    bhm.update_by_scan(t.train)
    mine = bhm.map()
    k = fitted.kernels
    np.testing.assert_array_equal(k.positions, mine.positions)
    np.testing.assert_allclose(k.w_mean, mine.w_mean, rtol=1e-12, atol=1e-12)
    s = ex.score_map(fitted, test)
    prob, var = fitted.query(test.positions)
    direct = potmap.score(prob, test.labels)
    assert abs(s.auc - direct.auc) < 1e-12 and s.auc > 0.9
    assert fitted.fit_seconds > 0


def test_ogm_and_pot_methods(task, town_scans, ctx, tmp_path):
    t, test = task
    ogm = ex.ogm_method(0.25).fit(ctx, t)
    prob, var = ogm.query(test.positions)
    assert np.all(np.isnan(var)) and ogm.kernels is None
    assert ex.score_map(ogm, test).auc > 0.7
    t2, test2 = ex.make_task(town_scans[3:5], seed=1, source=[town_scans[:3]])
    t2.source_key = "town1-0-3"
    repot = ex.pot_method(refine=True)
    assert repot.name == "RePOT" and repot.uses_source
    fitted = repot.fit(ctx, t2)
    assert ex.score_map(fitted, test2).auc > 0.8
    files = ex.write_figures(fitted, t2.lo, t2.hi, str(tmp_path / "repot"), max_pixels=100)
    assert any(f.endswith("_prob.png") for f in files)
