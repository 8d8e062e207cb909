//! The `aloha-sim` family of `bench-online`: the committed recording reads whole, a broken
//! file is an error that names the file and the field, and a recorded episode mapped into a
//! cell is embodied whole (the mapping puts the hands within reach).

use std::io::{Read, Write};
use std::path::{Path, PathBuf};

use omcbsa::online::aloha::{read_family, Cell, FleetKind, Layout};
use omcbsa::online::bench::{run_episode, whole_windows};
use omcbsa::online::reach::out_of_reach;
use omcbsa::online::OnlineOptions;

mod common;
use common::on_big_stack;

fn committed() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/aloha_sim")
}

#[test]
fn the_committed_family_reads_whole() {
    let family = read_family(&committed()).unwrap();
    let index = &family.index;
    assert_eq!((index.dt, index.steps, index.hands.len()), (0.02, 401, 2));
    assert_eq!(index.recorder.packages["mujoco"], "2.3.7");
    assert_eq!(index.recorder.packages["dm-control"], "1.0.14");
    assert_eq!(index.recorder.packages["gym-aloha"], "0.1.5");
    // Every seed of the range, per task: nothing left out for being hard or failed.
    for task in ["transfer", "insertion"] {
        let seeds: Vec<u64> = (family.episodes.iter())
            .filter(|e| e.entry.task == task)
            .map(|e| e.entry.seed)
            .collect();
        assert_eq!(seeds, (100..150).collect::<Vec<u64>>(), "{task}");
    }
    assert!(family.episodes.iter().any(|e| !e.entry.success));
    for e in &family.episodes {
        assert_eq!(e.hands.len(), 2);
        assert!(e.hands.iter().all(|h| h.len() == 401), "{}", e.entry.file);
    }
}

/// A copy of the committed index with only its first episode, and that episode's text.
fn one_episode_copy(dir: &Path) -> String {
    let index = std::fs::read_to_string(committed().join("index.json")).unwrap();
    let lines: Vec<&str> = index.lines().collect();
    let first = lines.iter().position(|l| l.contains("\"file\"")).unwrap();
    let last = lines.iter().rposition(|l| l.contains("\"file\"")).unwrap();
    let mut kept: Vec<String> = lines[..first].iter().map(|l| l.to_string()).collect();
    kept.push(lines[first].trim_end_matches(',').to_string());
    kept.extend(lines[last + 1..].iter().map(|l| l.to_string()));
    std::fs::write(dir.join("index.json"), kept.join("\n")).unwrap();
    let mut text = String::new();
    flate2::read::GzDecoder::new(
        std::fs::File::open(committed().join("transfer_100.json.gz")).unwrap(),
    )
    .read_to_string(&mut text)
    .unwrap();
    text
}

fn write_gz(path: &Path, text: &str) {
    let mut gz = flate2::write::GzEncoder::new(
        std::fs::File::create(path).unwrap(),
        flate2::Compression::fast(),
    );
    gz.write_all(text.as_bytes()).unwrap();
    gz.finish().unwrap();
}

#[test]
fn a_broken_file_is_an_error_naming_the_file_and_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let text = one_episode_copy(dir.path());
    let file = dir.path().join("transfer_100.json.gz");
    write_gz(&file, &text);
    assert_eq!(read_family(dir.path()).unwrap().episodes.len(), 1);
    let poses_line = |k: usize| {
        text.lines()
            .filter(|l| l.contains("quat_xyzw"))
            .nth(k)
            .unwrap()
    };
    let cases: [(String, &str); 5] = [
        // A quaternion that is not a unit one.
        (
            text.replacen(
                poses_line(3),
                r#"      {"position":[0.1,0.2,0.3],"quat_xyzw":[0.0,0.0,0.5,1.0]},"#,
                1,
            ),
            "transfer_100.json.gz: hands[0].poses[3].quat_xyzw: norm",
        ),
        // A pose missing: fewer poses than the index's steps.
        (
            text.replacen(&format!("{}\n", poses_line(401 + 5)), "", 1),
            "transfer_100.json.gz: hands[1].poses: 400 poses, but the index says 401 steps",
        ),
        // A number where an array belongs.
        (
            text.replacen(
                poses_line(7),
                r#"      {"position":0.1,"quat_xyzw":[0.0,0.0,0.0,1.0]},"#,
                1,
            ),
            "transfer_100.json.gz: hands[0].poses[7].position: invalid type",
        ),
        // A seed that is not the index's.
        (
            text.replacen("\"seed\": 100,", "\"seed\": 101,", 1),
            "transfer_100.json.gz: seed: 101, but the index says seed 100",
        ),
        // Another format.
        (
            text.replacen("omcbsa-aloha-episode/1", "omcbsa-problem/1", 1),
            "transfer_100.json.gz: format: expected \"omcbsa-aloha-episode/1\"",
        ),
    ];
    for (broken, expected) in cases {
        write_gz(&file, &broken);
        let err = read_family(dir.path()).unwrap_err();
        assert!(err.contains(expected), "expected {expected:?} in {err:?}");
    }
    // Not gzip at all.
    std::fs::write(&file, &text).unwrap();
    let err = read_family(dir.path()).unwrap_err();
    assert!(err.contains("transfer_100.json.gz: cannot read"), "{err}");
    // The index naming a file outside the family's directory.
    let index = std::fs::read_to_string(dir.path().join("index.json")).unwrap();
    std::fs::write(
        dir.path().join("index.json"),
        index.replace("\"transfer_100.json.gz\"", "\"../transfer_100.json.gz\""),
    )
    .unwrap();
    let err = read_family(dir.path()).unwrap_err();
    assert!(
        err.contains("index.json: episodes[0].file: \"../transfer_100.json.gz\": a file name"),
        "{err}"
    );
    // No index.
    let err = read_family(&dir.path().join("missing")).unwrap_err();
    assert!(err.contains("missing/index.json"), "{err}");
}

/// The first insertion episode on two Gen3s at the table's corners: every pose within some
/// arm's reach, and planned whole (in windows) into a timeline the validator accepts.
#[test]
fn a_recorded_episode_is_embodied_whole() {
    on_big_stack(|| {
        let family = read_family(&committed()).unwrap();
        let i = (family.episodes.iter())
            .position(|e| e.entry.task == "insertion")
            .unwrap();
        let cell = Cell {
            layout: Layout::Corners,
            fleet: FleetKind::Gen3,
            arms: 2,
        };
        let episode = family.episode(i, &cell);
        assert_eq!(out_of_reach(&episode).unwrap(), None);
        let (options, chunking) = whole_windows(&OnlineOptions::default());
        let run = run_episode(&episode, &options, chunking).unwrap();
        assert!(run.embodied, "{}: {:?}", episode.name, run.error);
    });
}
