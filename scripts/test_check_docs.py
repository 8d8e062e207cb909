#!/usr/bin/env python3
"""Tests of scripts/check_docs.py's check of docs/ARCHITECTURE.md's tree, on a small synthetic
repository written to a temporary folder.

    python3 scripts/test_check_docs.py
"""
import os
import sys
import tempfile
import unittest
from pathlib import Path

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import check_docs  # noqa: E402

MAIN = """
#[derive(Parser)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    Plan(cli::plan::Args),
    GenBench(cli::gen_bench::Args),
    /// A variant with its own name.
    #[command(name = "import-problems")]
    Import(cli::import::Args),
    Watch { verbose: bool },
}
"""

TREE = """# Architecture

```
Cargo.toml            workspace
core/                 the core
  src/model.rs          models
  src/spline.rs, stream.rs   two files in one entry
  src/search/           a folder: every file in it
  src/arm.rs, arm/      a module and its folder
host/                 the host: CLI (plan, gen-bench, import-problems, watch)
  src/cli/              one module per subcommand
```

## Elsewhere

```
  src/unlisted.rs       a second code block does not count
```
"""

FILES = {
    "core/src/lib.rs": "",
    "core/src/model.rs": "",
    "core/src/spline.rs": "",
    "core/src/stream.rs": "",
    "core/src/search/mod.rs": "",
    "core/src/search/deep/open.rs": "",
    "core/src/arm.rs": "",
    "core/src/arm/stop.rs": "",
    "host/src/main.rs": MAIN,
    "host/src/cli/mod.rs": "",
}


class ArchitectureTree(unittest.TestCase):
    def setUp(self):
        self.root = Path(tempfile.mkdtemp(prefix="check_docs_"))
        self.saved = check_docs.ROOT
        check_docs.ROOT = self.root
        self.write("docs/ARCHITECTURE.md", TREE)
        for path, text in FILES.items():
            self.write(path, text)

    def tearDown(self):
        check_docs.ROOT = self.saved

    def write(self, path, text):
        (self.root / path).parent.mkdir(parents=True, exist_ok=True)
        (self.root / path).write_text(text, encoding="utf-8")

    def problems(self):
        out = []
        check_docs.check_architecture(out)
        return out

    def test_a_tree_that_covers_everything_passes(self):
        self.assertEqual(self.problems(), [])

    def test_a_file_in_no_entry_is_named(self):
        self.write("core/src/unlisted.rs", "")
        self.write("host/src/load.rs", "")
        got = self.problems()
        self.assertEqual(len(got), 2, got)
        self.assertIn("core/src/unlisted.rs is in no entry", got[0])
        self.assertIn("host/src/load.rs is in no entry", got[1])

    def test_an_entry_naming_what_is_not_there(self):
        os.remove(self.root / "core/src/stream.rs")
        got = self.problems()
        self.assertEqual(len(got), 1, got)
        self.assertIn("names core/src/stream.rs, which is not there", got[0])

    def test_a_crate_root_needs_the_crate_entry(self):
        self.write("python/src/lib.rs", "")
        got = self.problems()
        self.assertEqual(got, ["docs/ARCHITECTURE.md: the tree has no entry `python/` (for python/src/lib.rs)"])

    def test_subcommands_as_clap_names_them(self):
        self.assertEqual(check_docs.subcommands(), ["plan", "gen-bench", "import-problems", "watch"])
        self.write("host/src/main.rs", MAIN.replace("    Plan(cli::plan::Args),\n",
                                                     "    Plan(cli::plan::Args),\n    BenchOnline(A),\n"))
        got = self.problems()
        self.assertEqual(len(got), 1, got)
        self.assertIn("`omcbsa bench-online` is not in the tree's CLI (..) list", got[0])

    def test_a_listed_name_that_is_no_subcommand(self):
        self.write("docs/ARCHITECTURE.md", TREE.replace("watch)", "watch, fly)"))
        got = self.problems()
        self.assertEqual(len(got), 1, got)
        self.assertIn("names `fly`, which is no subcommand", got[0])


if __name__ == "__main__":
    unittest.main()
