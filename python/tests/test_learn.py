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


def street(car, seed):
    """Beams up the y axis over x in [0, 1]: ending on a car at y = 2, or on a wall at y = 5."""
    end = 2.0 if car else 5.0
    pos, lab = [], []
    for b in range(11):
        x = 0.1 * b
        pos.append((x, end))
        lab.append(1)
        y = 0.2 + 0.05 * (seed % 7)
        while y < end - 0.3:
            pos.append((x, y))
            lab.append(0)
            y += 0.5
    n = len(lab)
    return potmap.LabelledPoints(np.array(pos), np.array(lab, dtype=np.uint8),
                                 np.full(n, seed, dtype=np.int64))


def test_joint_bhm_forgets_with_a_half_life():
    # Ten scans with the car, then three without it, 0.1 s apart: with a 0.1 s half-life the
    # map reads the car gone; without, the ten scans still outvote the three.
    keep, forget = potmap.JointBhm(2), potmap.JointBhm(2, half_life=0.1)
    assert forget.options.half_life == 0.1 and keep.options.half_life == 0
    for t in range(13):
        for m in (keep, forget):
            m.set_time(0.1 * t)
            m.update(street(t < 10, t))
    assert forget.time == pytest.approx(1.2)
    car = np.array([[0.5, 2.0]])

    def prob(m):
        return float(m.map().evaluate_exact(car).prob[0])

    assert prob(keep) > 0.5
    assert prob(forget) < 0.25
    # catch_up() applies the fading map() would apply on a copy: the same map either way.
    before = forget.map()
    forget.catch_up()
    same_map(before, forget.map(), rtol=1e-9, atol=1e-12)
    with pytest.raises(potmap.ArgumentError):
        potmap.JointBhm(2, half_life=-1.0)
