//! Hardware-in-the-loop, online: the scripted box-flip policy's chunks planned as they arrive
//! and streamed to three Python mock arms through the executor's online API (run `bash
//! hw-adapter/mock/setup_venv.sh` first). `run_on_mock_arms` checks that every mock received
//! exactly the replayed stream of the pushes (within 1e-6 rad) and nothing beyond a joint's
//! position, velocity or acceleration limit (`omcbsa_mock::record::check_followed`), and
//! validates the whole sent timeline (approach and chunks: limits, velocity, collisions,
//! tracking of the poses each step was planned for).

use omcbsa::online::run::{run_on_mock_arms, RunScript};
use omcbsa::online::OnlineError;
use omcbsa_hw::Event;
use omcbsa_mock::mock::venv_python;
use std::sync::{Mutex, MutexGuard};

/// Three mocks per test: the tests of this file run one at a time (six Python mocks at the
/// control rate would starve each other on a 2-core machine).
static SERIAL: Mutex<()> = Mutex::new(());

fn serial() -> MutexGuard<'static, ()> {
    SERIAL.lock().unwrap_or_else(|e| e.into_inner())
}

#[test]
fn chunks_stream_to_three_mock_arms_without_stopping() {
    let _serial = serial();
    let python = venv_python().unwrap_or_else(|e| panic!("{e}"));
    let dir = tempfile_dir("online-ok");
    let script = RunScript {
        chunks: 3,
        ..RunScript::default()
    };
    let out = run_big_stack(script, python, dir);
    assert!(out.chunk_errors.is_empty(), "{:?}", out.chunk_errors);
    assert_eq!(out.latencies.len(), 3);
    // No stop between chunks: the queue never ran dry while the chunks came.
    assert!(
        !out.events
            .iter()
            .any(|e| matches!(e, Event::QueueDry { .. })),
        "{:?}",
        out.events
    );
    assert!(out.validation.is_valid(), "{}", out.validation.summary());
    assert_eq!(out.cycles.len(), 3);
    assert!(out.pushes.len() == 3 && out.pushes.windows(2).all(|w| w[0].start < w[1].start));
    assert!(
        out.assignment.iter().all(Option::is_some),
        "{:?}",
        out.assignment
    );
}

#[test]
fn unreachable_and_late_chunks_hold_the_arms_safely_and_are_reported() {
    let _serial = serial();
    let python = venv_python().unwrap_or_else(|e| panic!("{e}"));
    let dir = tempfile_dir("online-faults");
    let script = RunScript {
        chunks: 3,
        unreachable_chunk: Some(1),
        late_chunk: Some(2),
        ..RunScript::default()
    };
    let out = run_big_stack(script, python, dir);
    // Chunk 1 named the hand and the step it cannot reach, and was not sent.
    match out.chunk_errors.as_slice() {
        [(1, OnlineError::Unreachable { hand: 0, step, .. })] => assert_eq!(*step, 8 + 8),
        other => panic!("expected chunk 1's hand 0 unreachable at step 16, got {other:?}"),
    }
    // Chunk 2 came after the queue ran dry: the arms held (reported) and then resumed.
    assert!(
        out.events
            .iter()
            .any(|e| matches!(e, Event::QueueDry { .. })),
        "{:?}",
        out.events
    );
    assert!(out
        .events
        .iter()
        .any(|e| matches!(e, Event::Resumed { .. })));
    // What was sent, holds included, is valid and within the limits (checked on the mocks'
    // records in `run_on_mock_arms`).
    assert!(out.validation.is_valid(), "{}", out.validation.summary());
    assert_eq!(out.latencies.len(), 2);
}

/// The run, in a thread with the stack the planners and the chunk problems need (the test
/// harness's threads have 2 MiB).
fn run_big_stack(
    script: RunScript,
    python: std::path::PathBuf,
    dir: std::path::PathBuf,
) -> omcbsa::online::run::RunOutcome {
    std::thread::Builder::new()
        .stack_size(16 << 20)
        .spawn(move || run_on_mock_arms(&script, &python, &dir, &mut |l| eprintln!("{l}")))
        .expect("spawn")
        .join()
        .expect("the run thread")
        .unwrap_or_else(|e| panic!("{e}"))
}

fn tempfile_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("omcbsa-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}
