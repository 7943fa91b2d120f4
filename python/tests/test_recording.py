"""The library's defaults (those `potmap mapping` runs) and the paper's preset, the built-in
dictionary, and a recording mapped in one call, compared with the command on the same log."""

import json
import os
import time

import pytest

import potmap

# Scans of Intel mapped here: enough for a map worth scoring, few enough for a CPU device.
SCANS = 30


def test_defaults_are_what_maps_real_logs_and_paper_is_a_preset():
    o = potmap.MapperOptions()
    assert o.pot.ranking == "indexed" and o.pot.placement == "target_samples"
    assert o.pot.wall_clearance == 0.5 and o.average_overall
    assert o.seed_placement == "barycentric" and o.seed_displacement_variance == 0.25
    p = potmap.MapperOptions.paper()
    assert p.pot.ranking == "exhaustive" and p.pot.placement == "barycentric"
    assert p.pot.wall_clearance == 0 and not p.average_overall
    assert p.seed_placement == "barycentric" and p.seed_displacement_variance == 0
    assert potmap.PotOptions.paper().ranking == "exhaustive"
    # Every other field is the defaults'.
    assert p.pot.rotations == o.pot.rotations and p.holdout == o.holdout
    assert p.persistent_refine == o.persistent_refine


@pytest.fixture(scope="module")
def default_dictionary():
    t0 = time.monotonic()
    d = potmap.default_dictionary()  # built once when the cache lacks it
    return d, time.monotonic() - t0


def test_default_dictionary_is_the_commands(default_dictionary, cli, tmp_path):
    d, _ = default_dictionary
    assert d.dim == 2 and len(d) > 100 and d.max_range == 20
    path = potmap.default_dictionary_path()
    assert path and os.path.exists(path)
    # The command reads the same cached file.
    out = tmp_path / "default.potdict"
    cli("dict", "default", "--out", out)
    assert open(out, "rb").read() == open(path, "rb").read()
    # A second call reads the cache.
    t0 = time.monotonic()
    again = potmap.default_dictionary()
    assert len(again) == len(d) and time.monotonic() - t0 < 10
    with pytest.raises(potmap.ArgumentError):
        potmap.default_dictionary(dim=4)


def test_map_recording_scores_as_potmap_mapping(default_dictionary, data_dir, ctx, cli, tmp_path):
    log = f"{data_dir}/radish/intel-corrected.log.gz"
    r = potmap.map_recording(log, out_dir=tmp_path / "py", ctx=ctx, max_scans=SCANS)
    assert r.scans == SCANS and r.overall_kernels > 0 and len(r.map) > 0
    # Measured on PoCL (CPU): overall AUC 0.981, NLL 0.131 on 6170 held-out samples;
    # instantaneous AUC 0.922.
    assert r.overall.auc > 0.97 and r.overall.nll < 0.16
    assert r.instantaneous.auc > 0.9
    assert r.instantaneous.n == r.overall.n > 6000
    theirs = cli("mapping", log, "-o", tmp_path / "cli", "--max-scans", SCANS, "-q", "--json", "-",
                 json_out=True)
    assert theirs["scans"] == SCANS
    assert theirs["overall"]["points"] == r.overall.n
    assert theirs["overall"]["auc"] == pytest.approx(r.overall.auc, abs=1e-6)
    assert theirs["overall"]["nll"] == pytest.approx(r.overall.nll, abs=1e-6)
    assert theirs["instantaneous"]["auc"] == pytest.approx(r.instantaneous.auc, abs=1e-6)
    mine = potmap.read_map(str(tmp_path / "py" / "map.potmap"))
    cmd = potmap.read_map(str(tmp_path / "cli" / "map.potmap"))
    assert len(mine) == len(cmd)
    with open(tmp_path / "py" / "scores.json") as f:
        assert json.load(f)["overall"]["auc"] == pytest.approx(r.overall.auc)


def test_map_recording_paper_preset_is_the_commands(default_dictionary, data_dir, ctx, cli,
                                                     tmp_path):
    log = f"{data_dir}/radish/intel-corrected.log.gz"
    n = 10  # the exhaustive ranking is slow
    r = potmap.map_recording(log, ctx=ctx, method="pot", options=potmap.MapperOptions.paper(),
                             max_scans=n)
    theirs = cli("mapping", log, "-o", tmp_path / "cli", "--max-scans", n, "--method", "pot",
                 "--preset", "paper", "-q", "--json", "-", json_out=True)
    assert theirs["ranking"] == "exhaustive" and theirs["overall_kind"] == "merged kernels"
    assert theirs["overall"]["auc"] == pytest.approx(r.overall.auc, abs=1e-6)
    # Measured: overall AUC 0.903, NLL 1.65 (the summed barycentric kernels erase walls; the
    # defaults score 0.98 on these scans).
    assert 0.85 < r.overall.auc < 0.95


def test_map_recording_refuses_what_it_cannot_map(data_dir, ctx):
    with pytest.raises(potmap.ArgumentError, match="3D drive"):
        potmap.map_recording(f"{data_dir}/drives3d/" + sorted(os.listdir(f"{data_dir}/drives3d"))[0],
                             ctx=ctx)
    with pytest.raises(potmap.ArgumentError, match="method"):
        potmap.map_recording(f"{data_dir}/radish/intel-corrected.log.gz", method="bhm", ctx=ctx)
