"""BHM (joint, online; diagonal) and ABHM against the maps `potmap learn` writes."""

import numpy as np
import pytest

import potmap


@pytest.fixture(scope="module")
def samples(town_scans, tmp_path_factory):
    train = potmap.label(town_scans[:3], seed=2).train
    path = str(tmp_path_factory.mktemp("learn") / "train.csv")
    potmap.write_labelled_csv(train, path)
    return potmap.read_labelled_csv(path), path  # as the command reads them


def bounds(points):
    return list(points.positions.min(axis=0)), list(points.positions.max(axis=0))


def same_map(a, b, rtol=0.0, atol=0.0):
    assert len(a) == len(b) and a.dim == b.dim
    np.testing.assert_allclose(a.positions, b.positions, rtol=rtol, atol=atol)
    np.testing.assert_allclose(a.gamma, b.gamma, rtol=rtol, atol=atol)
    np.testing.assert_allclose(a.w_mean, b.w_mean, rtol=rtol, atol=atol)
    np.testing.assert_allclose(a.w_var, b.w_var, rtol=rtol, atol=atol)


def test_joint_bhm_scan_by_scan_equals_the_command(samples, cli, tmp_path):
    pts, path = samples
    cli("learn", "bhm", path, "-o", tmp_path / "c.potmap", "--sequential")
    lo, hi = bounds(pts)
    bhm = potmap.JointBhm(2, lo=lo, hi=hi)  # the command's defaults: 0.5 m, prior 10, bias
    for t in np.unique(pts.scan):  # online: one scan at a time
        m = pts.scan == t
        bhm.update(potmap.LabelledPoints(pts.positions[m], pts.labels[m], pts.scan[m]))
        assert bhm.last_stats.samples == m.sum()
    mine = bhm.map()
    same_map(mine, potmap.read_map(str(tmp_path / "c.potmap")))
    assert mine.bias is not None
    # The exact predictive mean agrees with the exported map's logit mean where data was seen.
    mean, var = bhm.predict_exact(pts.positions[:200])
    exact = mine.evaluate_exact(pts.positions[:200])
    assert np.corrcoef(mean, exact.mean)[0, 1] > 0.99 and np.all(var > 0)


def test_joint_bhm_with_the_host_helper_is_the_same_bit_for_bit(samples, ctx):
    # The host's sums on the host team; the device's sums agree to rounding.
    pts, _ = samples
    alone, team = potmap.JointBhm(2), potmap.JointBhm(2, sums="host")
    device = potmap.JointBhm(2, sums="device")
    for t in np.unique(pts.scan):
        m = pts.scan == t
        s = potmap.LabelledPoints(pts.positions[m], pts.labels[m], pts.scan[m])
        alone.update(s)
        team.update(s, ctx)
        device.update(s, ctx)
        assert device.last_stats.sums_on_device and not team.last_stats.sums_on_device
    same_map(alone.map(), team.map())  # rtol = atol = 0
    same_map(alone.map(), device.map(), rtol=1e-6, atol=1e-9)


def test_diagonal_bhm_on_the_device_equals_the_command(samples, cli, ctx, tmp_path):
    pts, path = samples
    cli("learn", "bhm", path, "-o", tmp_path / "d.potmap", "--model", "diagonal", "--sequential")
    lo, hi = bounds(pts)
    prior = potmap.bhm_grid_prior(lo, hi, spacing=1.0, gamma=8.0)
    mine = potmap.bhm_update(prior, pts, ctx, sequential=True)
    same_map(mine, potmap.read_map(str(tmp_path / "d.potmap")))
    ref = potmap.bhm_update(prior, pts, None, sequential=True)  # the CPU reference
    same_map(mine, ref, rtol=1e-3, atol=1e-3)
    one = potmap.bhm_update(prior, pts, ctx, em_iterations=1)
    assert not np.allclose(one.w_mean, mine.w_mean)  # the keyword reaches the learner


def test_abhm_equals_the_command(samples, cli, tmp_path):
    pts, path = samples
    cli("learn", "abhm", path, "-o", tmp_path / "a.potmap", "--halton", "--count", 60,
        "--steps", 40, "--cpu", "--params", tmp_path / "a.params")
    lo, hi = bounds(pts)
    start = potmap.abhm_init_halton(lo, hi, 60, gamma0=1.0)
    seen = []
    params, steps = potmap.abhm_train(start, pts, steps=40, report_every=10,
                                      progress=lambda s, elbo: seen.append((s, elbo)))
    assert steps == 40 and [s for s, _ in seen] == [10, 20, 30, 40]
    same_map(params.to_map(), potmap.read_map(str(tmp_path / "a.potmap")))
    np.testing.assert_array_equal(params.flat(), potmap.read_abhm_params(str(tmp_path / "a.params")).flat())
    assert not np.array_equal(start.flat(), params.flat())


def test_abhm_progress_exception_stops_training(samples):
    pts, _ = samples
    lo, hi = bounds(pts)

    def stop(step, elbo):
        raise KeyError("stop here")

    with pytest.raises(KeyError, match="stop here"):
        potmap.abhm_train(potmap.abhm_init_halton(lo, hi, 10), pts, steps=50, report_every=5,
                          progress=stop)
