//! Writing outputs safely: atomically, through a temporary file with a fixed name
//! (`atomic.rs`), only after their paths were checked against the inputs, each other and the
//! file system (`paths.rs`), under a lock that keeps any other command from writing them
//! meanwhile (`lock.rs`), and with nothing left behind when a signal ends the command
//! (`pending.rs`). Beside the stages: the sampler's checkpoints, the `.pvis` writer,
//! `--mesh-out`, `patchvis gen` and the binary's reports all write through it.

mod atomic;
mod lock;
mod paths;
mod pending;

pub use atomic::{AtomicFile, parent_dir, resolve_target, temp_path, write_atomic};
pub use lock::{OutputLock, lock_path};
pub use paths::{NamedPath, OutputError, check_outputs};
pub use pending::remove_pending;
