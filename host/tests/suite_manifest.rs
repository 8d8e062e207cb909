//! The published suite: `omcbsa gen-bench OUTDIR` with its defaults writes exactly the files
//! whose SHA-256 checksums docs/bench/suite.sha256 lists (in `sha256sum` format, so
//! `cd OUTDIR && sha256sum -c .../suite.sha256` checks a suite made anywhere).
//!
//! Slow (the whole 608-problem suite, about a minute and a half of one core with the release
//! build), and it runs with every `cargo test`: it is the proof that the suite the results
//! come from can be made again. After a change that is meant to change the suite, write the
//! new checksums with `OMCBSA_BLESS_SUITE=1 cargo test -p omcbsa --test suite_manifest`.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use sha2::{Digest, Sha256};

fn manifest_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/bench/suite.sha256")
}

/// Every file under `dir`, by its path relative to `dir` ('/'-separated), with its checksum.
fn checksums(dir: &Path) -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    let mut pending = vec![dir.to_path_buf()];
    while let Some(d) = pending.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                pending.push(path);
                continue;
            }
            let relative: Vec<String> = (path.strip_prefix(dir).unwrap().components())
                .map(|c| c.as_os_str().to_string_lossy().into_owned())
                .collect();
            let digest = Sha256::digest(std::fs::read(&path).unwrap());
            let hex: String = digest.iter().map(|b| format!("{b:02x}")).collect();
            out.insert(relative.join("/"), hex);
        }
    }
    out
}

/// `sha256sum` lines: checksum, two spaces, path.
fn parse(text: &str) -> BTreeMap<String, String> {
    (text.lines())
        .map(|line| {
            let (sum, path) = line
                .split_once("  ")
                .unwrap_or_else(|| panic!("not a sha256sum line: {line:?}"));
            (path.to_string(), sum.to_string())
        })
        .collect()
}

#[test]
fn the_default_suite_is_the_published_one() {
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_omcbsa"))
        .arg("gen-bench")
        .arg(dir.path())
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "gen-bench with its defaults failed: {}{stdout}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        stdout.starts_with("608 problems (608 known solvable"),
        "{stdout}"
    );
    let got = checksums(dir.path());
    if std::env::var_os("OMCBSA_BLESS_SUITE").is_some() {
        let text: String = (got.iter())
            .map(|(path, sum)| format!("{sum}  {path}\n"))
            .collect();
        std::fs::write(manifest_path(), text).unwrap();
        eprintln!("wrote {}", manifest_path().display());
        return;
    }
    let want = parse(&std::fs::read_to_string(manifest_path()).unwrap());
    let missing: Vec<&String> = want.keys().filter(|p| !got.contains_key(*p)).collect();
    let extra: Vec<&String> = got.keys().filter(|p| !want.contains_key(*p)).collect();
    let differ: Vec<&String> = (want.iter())
        .filter(|(p, sum)| got.get(*p).is_some_and(|g| g != *sum))
        .map(|(p, _)| p)
        .collect();
    assert!(
        missing.is_empty() && extra.is_empty() && differ.is_empty(),
        "the default suite is not the published one ({}): {} files missing {:?}, {} not \
         listed {:?}, {} differ {:?}",
        manifest_path().display(),
        missing.len(),
        &missing[..missing.len().min(10)],
        extra.len(),
        &extra[..extra.len().min(10)],
        differ.len(),
        &differ[..differ.len().min(10)],
    );
    assert_eq!(got.len(), 1217, "608 problems, 608 witnesses and the index");
}
