//! Replays every committed fuzzing input — the corpus each target grew (`fuzz/corpus/`) and
//! the inputs that once crashed it (`fuzz/regressions/`) — through the same entry points the
//! fuzz targets call (`rsl::fuzzing`): none may panic. (Fuzzing itself runs with cargo-fuzz;
//! fuzz/README.md.)

use std::path::Path;

fn inputs(dir: &Path) -> Vec<std::path::PathBuf> {
    let Ok(entries) = std::fs::read_dir(dir) else { return Vec::new() };
    let mut files: Vec<_> = entries.filter_map(|e| e.ok().map(|e| e.path())).filter(|p| p.is_file()).collect();
    files.sort();
    files
}

#[test]
fn every_corpus_and_regression_input_is_handled_without_a_panic() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz");
    for (name, target) in rsl::fuzzing::TARGETS {
        let corpus = inputs(&root.join("corpus").join(name));
        assert!(!corpus.is_empty(), "no corpus for fuzz target {name}");
        let regressions = inputs(&root.join("regressions").join(name));
        for file in corpus.iter().chain(&regressions) {
            let bytes = std::fs::read(file).unwrap();
            let outcome = std::panic::catch_unwind(|| target(&bytes));
            assert!(outcome.is_ok(), "fuzz target {name} panicked on {}", file.display());
        }
        eprintln!("{name}: {} corpus inputs, {} regressions", corpus.len(), regressions.len());
    }
}
