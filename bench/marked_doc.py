"""The benchmark scripts' tables in the docs: text between two marker lines replaced whole."""
import os
import sys


def replace_marked(doc, script, name, body):
    """Replaces what stands between "<!-- SCRIPT NAME -->" and "<!-- end of SCRIPT NAME -->" in
    `doc` by `body` (a temporary file renamed into place); exits naming the lines if absent."""
    start = "<!-- %s %s -->" % (script, name)
    end = "<!-- end of %s %s -->" % (script, name)
    with open(doc) as f:
        text = f.read()
    if start not in text or end not in text:
        sys.exit("%s: %s has no lines %r and %r" % (script, doc, start, end))
    head, rest = text.split(start, 1)
    tail = rest.split(end, 1)[1]
    with open(doc + ".tmp", "w") as f:
        f.write(head + start + body + end + tail)
    os.replace(doc + ".tmp", doc)


def write_json(path, data):
    """Writes `data` as indented JSON to `path` through a temporary file renamed into place."""
    import json
    with open(path + ".tmp", "w") as f:
        json.dump(data, f, indent=1)
    os.replace(path + ".tmp", path)


def refresh_figures():
    """Carries the figures derived from the docs' JSON into docs/figures.json and every page's
    marked spans (scripts/make_doc_figures.py); for a script that has just written docs/ JSON."""
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    sys.path.insert(0, os.path.join(root, "scripts"))
    import make_doc_figures
    if make_doc_figures.main(["--root", root]) != 0:
        sys.exit("scripts/make_doc_figures.py found disagreements (above)")
