"""Checks an installed potmap package from outside the source tree. Run by the CTest tests
python_pip_install and install_consumer (not a pytest file):

    python check_installed.py PREFIX [--script | --no-command] [--log LOG --drive DRIVE --out DIR]

The package, and the libpotmap it loads, must come from under PREFIX; `python -m potmap` runs
the potmap command (its help, its exit status; --no-command: built without it); --script: so
does the `potmap` script beside the interpreter (pip's). With --log and --drive it maps the
first scans of the 2D log with potmap.map_recording(), and the first keyframes of the 3D drive
folder with potmap.map_recording(), each scored on its held-out beams, and both again with
`python -m potmap mapping` (the same maps and scores). Prints what it measured as JSON.
"""

import argparse
import json
import os
import subprocess
import sys

SCANS = 10  # of the log: a map worth scoring, in a second or two on a CPU device
KEYFRAMES = 3  # of the drive


def run(args, ok=True):
    done = subprocess.run(args, capture_output=True, text=True, timeout=600)
    if ok and done.returncode != 0:
        sys.exit("check_installed: %s failed (exit status %d):\n%s%s"
                 % (" ".join(args), done.returncode, done.stdout, done.stderr))
    return done


def imported_from(prefix):
    import potmap

    assert os.path.realpath(potmap.__file__).startswith(prefix), "imported %s" % potmap.__file__
    libs = sorted({line.split()[-1] for line in open("/proc/self/maps") if "libpotmap" in line})
    assert libs and all(lib.startswith(prefix) for lib in libs), "libpotmap loaded from %s" % libs
    return potmap, libs


def check_command(script):
    commands = [[sys.executable, "-m", "potmap"]]
    if script:
        commands.append([os.path.join(os.path.dirname(sys.executable), "potmap")])
    for cmd in commands:
        done = run(cmd + ["--help"])
        assert "mapping" in done.stdout and "Usage" in done.stdout, done.stdout
        # The command's own exit status comes back: an unknown subcommand is an error.
        bad = run(cmd + ["no-such-command"], ok=False)
        assert bad.returncode != 0 and bad.stderr, (bad.returncode, bad.stderr)


def check_recording(potmap, ctx, log, out):
    r = potmap.map_recording(log, out_dir=os.path.join(out, "py"), ctx=ctx, max_scans=SCANS)
    scans = r.summary["scans"]
    assert scans == SCANS and len(r.map) > 0 and r.overall.n > 0, (scans, r.overall.n)
    assert r.overall.auc > 0.5, r.overall.auc  # better than chance; the command's own: below
    with open(os.path.join(out, "py", "scores.json")) as f:
        assert json.load(f)["overall"]["auc"] == r.overall.auc
    done = run([sys.executable, "-m", "potmap", "mapping", log, "--max-scans", str(SCANS), "-q",
                "--json", "-", "-o", os.path.join(out, "cmd")])
    theirs = json.loads(done.stdout)
    assert theirs["overall"]["points"] == r.overall.n, (theirs["overall"], r.overall.n)
    assert abs(theirs["overall"]["auc"] - r.overall.auc) < 1e-6, (theirs["overall"], r.overall.auc)
    assert os.path.exists(os.path.join(out, "cmd", "map.potmap"))
    return {"scans": scans, "auc": r.overall.auc, "nll": r.overall.nll, "points": r.overall.n}


def check_drive(potmap, ctx, drive, out):
    r = potmap.map_recording(drive, out_dir=os.path.join(out, "py-drive"), ctx=ctx,
                             max_scans=KEYFRAMES)
    keyframes, kernels, s = r.summary["keyframes"], r.summary["kernels"], r.scores
    assert r.drive and keyframes == KEYFRAMES and kernels > 0, (keyframes, kernels)
    assert s.n > 0 and s.auc > 0.5, (s.n, s.auc)  # better than chance; the command's own: below
    assert len(r.map) == kernels and r.map.dim == 3, (len(r.map), kernels)
    # The command runs the same job: the same map and scores.
    done = run([sys.executable, "-m", "potmap", "mapping", drive, "--max-scans", str(KEYFRAMES),
                "-q", "--json", "-", "-o", os.path.join(out, "drive")])
    theirs = json.loads(done.stdout)
    assert (theirs["keyframes"], theirs["kernels"], theirs["scores"]) == \
        (keyframes, kernels, r.summary["scores"]), (theirs["scores"], r.summary["scores"])
    return {"keyframes": keyframes, "kernels": kernels, "auc": s.auc, "nll": s.nll,
            "points": s.n}


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("prefix")
    p.add_argument("--script", action="store_true")
    p.add_argument("--no-command", action="store_true")
    p.add_argument("--log")
    p.add_argument("--drive")
    p.add_argument("--out")
    a = p.parse_args()
    potmap, libs = imported_from(os.path.realpath(a.prefix))
    result = {"version": potmap.__version__, "module": potmap.__file__, "libpotmap": libs}
    if not a.no_command:
        check_command(a.script)
    if a.log or a.drive:
        ctx = potmap.Context()
        result["device"] = ctx.device.summary()
        if a.log:
            result["recording"] = check_recording(potmap, ctx, a.log, a.out)
        if a.drive:
            result["drive"] = check_drive(potmap, ctx, a.drive, a.out)
    else:  # a map of a synthetic scene scored, at least
        s = potmap.synthetic_scene(test_points=200)
        v = s.map.evaluate_exact(s.test.positions)
        result["synthetic_auc"] = potmap.score(v.prob, s.test.labels).auc
    print(json.dumps(result))


if __name__ == "__main__":
    main()
