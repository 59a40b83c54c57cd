//! Writing outputs safely: atomically, through a temporary file with a fixed name
//! (`atomic.rs`), and only after their paths were checked against the inputs, each other and
//! the file system (`paths.rs`). Beside the stages: the sampler's checkpoints, the `.pvis`
//! writer, `--mesh-out`, `patchvis gen` and the binary's reports all write through it.

mod atomic;
mod paths;

pub use atomic::{AtomicFile, parent_dir, temp_path, write_atomic};
pub use paths::{NamedPath, OutputError, check_outputs};
