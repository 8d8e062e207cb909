#!/usr/bin/env python3
"""Tests of scripts/module_cycles.py on tiny synthetic crates written to a temporary folder.

    python3 scripts/test_module_cycles.py
"""
import io
import os
import sys
import tempfile
import unittest
from contextlib import redirect_stdout

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import module_cycles  # noqa: E402


def crate(files):
    """A crate folder with `src/<path>` = text for each entry; returns the crate's folder."""
    top = tempfile.mkdtemp(prefix="module_cycles_")
    for path, text in files.items():
        full = os.path.join(top, "src", path)
        os.makedirs(os.path.dirname(full), exist_ok=True)
        with open(full, "w") as fh:
            fh.write(text)
    return top


def circles(files):
    """The circles of a crate, each as sorted `a::b` names."""
    src = os.path.join(crate(files), "src")
    return [["::".join(m) for m in comp] for comp in module_cycles.circles(module_cycles.Crate(src).graph())]


class ModuleCycles(unittest.TestCase):
    def test_one_way_imports_make_no_circle(self):
        self.assertEqual(circles({
            "lib.rs": "pub mod a;\npub mod b;\n",
            "a.rs": "use crate::b::f;\npub fn g() { f() }\n",
            "b.rs": "pub fn f() {}\n",
        }), [])

    def test_two_modules_importing_each_other(self):
        self.assertEqual(circles({
            "lib.rs": "pub mod a;\npub mod b;\n",
            "a.rs": "use crate::b::f;\npub fn g() { f() }\n",
            "b.rs": "pub fn f() { crate::a::g() }\n",
        }), [["a", "b"]])

    def test_own_item_through_a_reexport_is_a_circle(self):
        # model's constant, re-exported by collision, which imports model: model reaching its
        # own constant through collision imports collision.
        files = {
            "lib.rs": "pub mod collision;\npub mod model;\n",
            "model.rs": "pub const MAX: usize = 16;\npub struct Frame;\n"
                        "fn n() -> usize { crate::collision::MAX }\n",
            "collision.rs": "use crate::model::Frame;\npub use crate::model::MAX;\n",
        }
        self.assertEqual(circles(files), [["collision", "model"]])
        files["model.rs"] = files["model.rs"].replace("crate::collision::MAX", "MAX")
        self.assertEqual(circles(files), [])

    def test_own_item_through_a_reexport_alone_is_no_circle(self):
        # The re-exporting module does not import model: a self-import and one edge, no loop.
        self.assertEqual(circles({
            "lib.rs": "pub mod collision;\npub mod model;\n",
            "model.rs": "pub const MAX: usize = 16;\nfn n() -> usize { crate::collision::MAX }\n",
            "collision.rs": "pub use crate::model::MAX;\n",
        }), [])

    def test_a_reexport_leads_to_the_defining_module(self):
        # `crate::collision::MAX` from reach imports model (and collision): a circle reach <-> model.
        self.assertEqual(circles({
            "lib.rs": "pub mod collision;\npub mod model;\npub mod reach;\n",
            "model.rs": "pub const MAX: usize = 16;\nfn r() { crate::reach::r() }\n",
            "collision.rs": "pub use crate::model::MAX;\n",
            "reach.rs": "use crate::collision::MAX;\npub fn r() {}\n",
        }), [["model", "reach"]])

    def test_glob_reexport(self):
        self.assertEqual(circles({
            "lib.rs": "pub mod a;\npub mod b;\n",
            "a.rs": "pub const X: u8 = 1;\nfn y() -> u8 { crate::b::X }\n",
            "b.rs": "pub use crate::a::*;\nfn z() { crate::a::y(); }\n",
        }), [["a", "b"]])

    def test_facade_that_only_reexports_makes_no_circle(self):
        self.assertEqual(circles({
            "lib.rs": "pub mod geo;\n",
            "geo/mod.rs": "mod capsule;\npub use capsule::Capsule;\npub struct Contact;\n",
            "geo/capsule.rs": "use super::Contact;\npub struct Capsule(Contact);\n",
        }), [])

    def test_parent_and_child_importing_each_other(self):
        self.assertEqual(circles({
            "lib.rs": "pub mod geo;\n",
            "geo/mod.rs": "mod capsule;\nuse capsule::helper;\npub struct Contact;\n",
            "geo/capsule.rs": "use super::Contact;\npub fn helper() {}\n",
        }), [["geo", "geo::capsule"]])

    def test_new_style_module_files(self):
        self.assertEqual(circles({
            "lib.rs": "pub mod geo;\n",
            "geo.rs": "mod capsule;\nuse capsule::helper;\npub struct Contact;\n",
            "geo/capsule.rs": "use super::Contact;\npub fn helper() {}\n",
        }), [["geo", "geo::capsule"]])

    def test_comments_strings_and_inline_tests_are_not_imports(self):
        self.assertEqual(circles({
            "lib.rs": "pub mod a;\npub mod b;\n",
            "a.rs": "// crate::b::f\n/* crate::b::f */\nconst S: &str = \"crate::b::f\";\n"
                    "pub fn g() {}\n#[cfg(test)]\nmod tests {\n    use super::*;\n}\n",
            "b.rs": "pub fn f() { crate::a::g() }\n",
        }), [])

    def test_main_reports_the_path_behind_each_import(self):
        top = crate({
            "lib.rs": "pub mod collision;\npub mod model;\n",
            "model.rs": "pub const MAX: usize = 16;\npub struct Frame;\n"
                        "fn n() -> usize { crate::collision::MAX }\n",
            "collision.rs": "use crate::model::Frame;\npub use crate::model::MAX;\n",
        })
        out = io.StringIO()
        sys.argv = ["module_cycles.py", top]
        with redirect_stdout(out):
            code = module_cycles.main()
        self.assertEqual(code, 1)
        self.assertIn("model -> collision: crate::collision::MAX", out.getvalue())
        self.assertIn("collision -> model: crate::model::Frame", out.getvalue())


if __name__ == "__main__":
    unittest.main()
