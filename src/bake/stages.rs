//! The time and peak heap of each stage of a bake, for `--stats` and the summary the command
//! prints. Peak heap is what `heap::CountingAlloc` saw during the stage; 0 where the program
//! did not install it.

use crate::heap;
use std::time::Instant;

/// Time and peak heap of one stage.
#[derive(Clone, Debug, PartialEq)]
pub struct StageRecord {
    /// `input`, `tiling`, `sampling`, `patch-order`, `encoding`, `mesh-out`, …
    pub name: &'static str,
    /// Wall time.
    pub seconds: f64,
    /// Highest live heap bytes during the stage (everything live, earlier stages' results
    /// included).
    pub peak_heap_bytes: usize,
}

/// The records of the stages run so far.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Stages {
    records: Vec<StageRecord>,
}

impl Stages {
    /// No stage yet.
    pub fn new() -> Stages {
        Stages::default()
    }

    /// Runs `f` as stage `name` and records it.
    pub fn run<T>(&mut self, name: &'static str, f: impl FnOnce() -> T) -> T {
        heap::reset_peak();
        let start = Instant::now();
        let out = f();
        self.records.push(StageRecord {
            name,
            seconds: start.elapsed().as_secs_f64(),
            peak_heap_bytes: heap::peak(),
        });
        out
    }

    /// Every record, in the order the stages ran.
    pub fn records(&self) -> &[StageRecord] {
        &self.records
    }

    /// Seconds of stage `name` (summed if it ran more than once; 0 if it never ran).
    pub fn seconds(&self, name: &str) -> f64 {
        self.records
            .iter()
            .filter(|r| r.name == name)
            .map(|r| r.seconds)
            .sum()
    }

    /// The highest peak of any stage.
    pub fn peak_heap_bytes(&self) -> usize {
        self.records
            .iter()
            .map(|r| r.peak_heap_bytes)
            .max()
            .unwrap_or(0)
    }
}
