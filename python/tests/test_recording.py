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
    assert o.pot.anchor_clearance == 0.25
    assert o.pot.anchor_sweeps == 10 and o.pot.logit_gain == 1.5
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


def same_files(mine, theirs):
    """The two runs wrote files of the same names (each in its own folder)."""
    assert [os.path.basename(f) for f in mine] == [os.path.basename(f) for f in theirs]


def test_map_recording_scores_as_potmap_mapping(default_dictionary, data_dir, ctx, cli, tmp_path):
    log = f"{data_dir}/radish/intel-corrected.log.gz"
    seen = []
    r = potmap.map_recording(log, out_dir=tmp_path / "py", ctx=ctx, max_scans=SCANS,
                             progress=seen.append)
    assert not r.drive and r.summary["scans"] == SCANS and len(r.map) > 0
    assert [p.done for p in seen if p.stage == "mapping"] == list(range(1, SCANS + 1))
    # Measured on PoCL (CPU): overall AUC 0.981, NLL 0.131 on 6170 held-out samples;
    # instantaneous AUC 0.922.
    assert r.overall.auc > 0.97 and r.overall.nll < 0.16
    assert r.summary["instantaneous"]["auc"] > 0.9
    theirs = cli("mapping", log, "-o", tmp_path / "cli", "--max-scans", SCANS, "-q", "--json", "-",
                 json_out=True)
    assert theirs["scans"] == SCANS
    assert theirs["overall"] == r.summary["overall"]
    assert theirs["instantaneous"] == r.summary["instantaneous"]
    same_files(r.files, theirs["files"])
    assert all(os.path.exists(f) for f in r.files)
    cmd = potmap.read_map(str(tmp_path / "cli" / "map.potmap"))
    assert len(r.map) == len(cmd)
    with open(tmp_path / "py" / "scores.json") as f:
        assert json.load(f)["overall"]["auc"] == r.overall.auc


def test_map_recording_looks_ahead_as_potmap_mapping(default_dictionary, data_dir, ctx, cli,
                                                    tmp_path):
    # A 2D log's look-ahead: each scan's held-out samples on RePOT's map before the scan.
    log = f"{data_dir}/radish/intel-corrected.log.gz"
    r = potmap.map_recording(log, out_dir=tmp_path / "py", ctx=ctx, max_scans=6, lookahead=True)
    theirs = cli("mapping", log, "-o", tmp_path / "cli", "--max-scans", 6, "--lookahead", "-q",
                 "--json", "-", json_out=True)
    assert r.summary["lookahead"] == theirs["lookahead"]
    assert 0 < r.summary["lookahead"]["all"]["n"] < r.summary["overall"]["points"]


def test_map_recording_paper_preset_is_the_commands(default_dictionary, data_dir, ctx, cli,
                                                     tmp_path):
    log = f"{data_dir}/radish/intel-corrected.log.gz"
    n = 10  # the exhaustive ranking is slow
    r = potmap.map_recording(log, out_dir=tmp_path / "py", ctx=ctx, method="pot",
                             preset="paper", max_scans=n)
    theirs = cli("mapping", log, "-o", tmp_path / "cli", "--max-scans", n, "--method", "pot",
                 "--preset", "paper", "-q", "--json", "-", json_out=True)
    assert theirs["ranking"] == "exhaustive" and theirs["overall_kind"] == "merged kernels"
    assert theirs["overall"] == r.summary["overall"]
    # Measured: overall AUC 0.903, NLL 1.65 (the summed barycentric kernels erase walls; the
    # defaults score 0.98 on these scans).
    assert 0.85 < r.overall.auc < 0.95


def first_drive(data_dir):
    return f"{data_dir}/drives3d/" + sorted(os.listdir(f"{data_dir}/drives3d"))[0]


def test_map_recording_maps_a_drive_as_potmap_mapping(data_dir, ctx, cli, tmp_path):
    drive, n = first_drive(data_dir), 3
    seen = []
    r = potmap.map_recording(drive, out_dir=tmp_path / "py", ctx=ctx, max_scans=n,
                             progress=seen.append)
    assert r.drive and r.summary["keyframes"] == n
    assert [p.done for p in seen if p.stage == "mapping"] == list(range(1, n + 1))
    assert seen[-1].stage == "outputs" and seen[-1].fraction == 1
    theirs = cli("mapping", drive, "-o", tmp_path / "cli", "--max-scans", n, "-q", "--json", "-",
                 json_out=True)
    assert theirs["scores"] == r.summary["scores"] and theirs["kernels"] == r.summary["kernels"]
    assert r.overall.auc == theirs["scores"]["auc"] and r.overall.n == theirs["scores"]["n"]
    same_files(r.files, theirs["files"])
    assert {"map.bt", "map_occupied.ply", "map_band_prob.png"} <= {
        os.path.basename(f) for f in r.files}


def test_map_recording_stopped_by_progress_leaves_files_whole(data_dir, ctx, tmp_path):
    class Stop(Exception):
        pass

    def stop_at_second(p):
        if p.stage == "mapping" and p.done == 2:
            raise Stop()

    out = tmp_path / "stopped"
    with pytest.raises(Stop):
        potmap.map_recording(first_drive(data_dir), out_dir=out, ctx=ctx, max_scans=4,
                             progress=stop_at_second)
    assert not [f for f in os.listdir(out) if ".tmp" in f or ".body" in f]
    assert not os.path.exists(out / "scores.json")


def test_map_recording_refuses_what_it_cannot_map(data_dir, ctx, tmp_path):
    log = f"{data_dir}/radish/intel-corrected.log.gz"
    with pytest.raises(potmap.ArgumentError, match="method"):
        potmap.map_recording(log, out_dir=tmp_path / "a", method="bhm", ctx=ctx)
    with pytest.raises(potmap.ArgumentError, match="pot"):
        potmap.map_recording(first_drive(data_dir), out_dir=tmp_path / "b", method="pot", ctx=ctx)
    with pytest.raises(TypeError, match="no_such_option"):
        potmap.map_recording(log, out_dir=tmp_path / "c", no_such_option=1, ctx=ctx)
