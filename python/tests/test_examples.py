"""The examples in examples/python run (sized down) and say what they measured."""

import os
import subprocess
import sys

HERE = os.path.dirname(__file__)
EXAMPLES = os.path.join(HERE, "..", "..", "examples", "python")


def run(name, *args):
    done = subprocess.run([sys.executable, os.path.join(EXAMPLES, name), *args],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    return done.stdout


def test_repot_radish_example(data_dir, tmp_path):
    out = run("repot_radish.py", "--log", f"{data_dir}/radish/intel-corrected.log.gz",
              "--scans", "5", "--res", "0.25", "--out", str(tmp_path))
    auc = float(out.split("AUC ")[1].split()[0])
    assert auc > 0.9, out
    assert os.path.getsize(tmp_path / "repot_radish.png") > 10000


def test_sinkhorn_example():
    out = run("sinkhorn_vs_pot.py", "--sizes", "40", "--problems", "4")
    row = [l for l in out.splitlines() if l.startswith("| 40 |")]
    assert row and "4/4" in row[0], out
