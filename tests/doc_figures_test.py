#!/usr/bin/env python3
"""scripts/make_doc_figures.py --check against pages it must refuse: a copy of the pages and their
sources in a temporary folder, each changed in one way that makes two pages disagree or a figure
go stale; the check must pass the copy as it is and fail every change (ctest doc_figures_selftest)."""
import glob
import json
import os
import re
import shutil
import sys
import tempfile
import unittest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "scripts"))
import make_doc_figures as mdf  # noqa: E402


class DocFigures(unittest.TestCase):
    def setUp(self):
        self.root = tempfile.mkdtemp(prefix="doc-figures-")
        shutil.copy(os.path.join(ROOT, "README.md"), self.root)
        for path in glob.glob(os.path.join(ROOT, "docs", "**", "*"), recursive=True):
            if path.endswith((".md", ".json")):
                dest = os.path.join(self.root, os.path.relpath(path, ROOT))
                os.makedirs(os.path.dirname(dest), exist_ok=True)
                shutil.copy(path, dest)

    def tearDown(self):
        shutil.rmtree(self.root)

    def problems(self):
        return mdf.check(self.root, mdf.derive(self.root), mdf.read_figures(self.root))

    def edit(self, rel, old, new, count=1):
        path = os.path.join(self.root, rel)
        with open(path) as f:
            text = f.read()
        self.assertIn(old, text)
        with open(path, "w") as f:
            f.write(text.replace(old, new, count))

    def marked(self):
        """(page, name, text) of the first marked figure found on a docs/ page."""
        for page in sorted(glob.glob(os.path.join(self.root, "docs", "*.md"))):
            with open(page) as f:
                m = mdf.SPAN.search(f.read())
            if m:
                return os.path.relpath(page, self.root), m.group(1), m.group(2)
        self.fail("no page marks a figure")

    def test_the_pages_as_committed_pass(self):
        self.assertEqual(self.problems(), [])

    def test_a_page_that_disagrees_fails(self):
        page, name, text = self.marked()
        self.edit(page, "<!-- fig %s -->%s<!-- /fig -->" % (name, text),
                  "<!-- fig %s -->%s9<!-- /fig -->" % (name, text))
        self.assertTrue(any(name in p and page in p for p in self.problems()))

    def test_an_unknown_marker_fails(self):
        page, name, text = self.marked()
        self.edit(page, "<!-- fig %s -->" % name, "<!-- fig no.such.figure -->")
        self.assertTrue(any("no.such.figure" in p for p in self.problems()))

    def test_a_changed_source_fails_until_regenerated(self):
        name, (source, _) = next(iter(mdf.DERIVED.items()))
        path = os.path.join(self.root, source)
        with open(path) as f:
            data = json.load(f)
        before = mdf.derive(self.root)
        # Scale every number in the rows: whatever the rule reads, its text changes.
        for row in data.get("rows", []):
            for k, v in row.items():
                if isinstance(v, float):
                    row[k] = v * 1.37 + 0.011
        with open(path, "w") as f:
            json.dump(data, f)
        after = mdf.derive(self.root)
        changed = [n for n in after if after[n] != before[n]]
        self.assertTrue(changed)
        self.assertTrue(any(changed[0] in p and mdf.FIGURES in p for p in self.problems()))
        # Regenerating (the script without --check) brings figures.json and every page along.
        self.assertEqual(mdf.main(["--root", self.root]), 0)
        self.assertEqual(self.problems(), [])

    def test_an_unmarked_copy_fails(self):
        figures = mdf.read_figures(self.root)["figures"]
        name, entry = next((n, e) for n, e in figures.items() if e.get("context"))
        word = re.sub(r"[\\^$()|?*+\[\]{}]", "", entry["context"].split("|")[0])
        self.edit("docs/methods.md", "\n\n", "\n\nAs %s shows, %s here.\n\n" % (word, entry["text"]))
        self.assertTrue(any(name in p and "unmarked" in p for p in self.problems()))

    def test_a_paraphrase_fails(self):
        figures = mdf.read_figures(self.root)["figures"]
        watched = [(n, e) for n, e in figures.items() if e.get("watch")]
        self.assertTrue(watched)
        page = os.path.join(self.root, "docs", "methods.md")
        with open(page) as f:
            pristine = f.read()
        for name, entry in watched:
            samples = entry["watch_sample"]
            for sample in samples if isinstance(samples, list) else [samples]:
                with self.subTest(name=name, sample=sample):
                    self.assertTrue(any(re.search(w, sample) for w in entry["watch"]))
                    with open(page, "w") as f:
                        f.write(pristine)
                    self.edit("docs/methods.md", "\n\n", "\n\n%s\n\n" % sample)
                    self.assertTrue(any(name in p and "unmarked" in p for p in self.problems()))

    def test_a_figure_marked_nowhere_fails(self):
        data = mdf.read_figures(self.root)
        data["figures"]["unused.figure"] = {"text": "1 s", "command": "x", "machine": "y"}
        mdf.write_figures(self.root, data)
        self.assertTrue(any("unused.figure" in p for p in self.problems()))


if __name__ == "__main__":
    unittest.main()
