//! A fault in a mapped file ends the process with one line saying why, instead of a crash.
//!
//! Reading a page of a map whose file has since become shorter (another program truncated an
//! input during the command), or writing a page of a mapped temporary file when the disk is
//! full, raises `SIGBUS`, whose default action kills the process with no message at all. So
//! every file map registers its range here, with the line to print should it fault, formatted
//! when the map is made ([`Covered`]); the first registration installs a `SIGBUS` handler. A
//! fault inside a registered range prints that line on stderr, removes the command's pending
//! output files and ends the process with exit code 1, the binary's code for bad input. A
//! fault anywhere else is passed to the handler that was installed before (std's stack
//! overflow check) or, where there was none, to the default action: it stays the crash it was.
//!
//! The handler runs on whichever thread faulted, at any instruction, so it does only what is
//! async-signal-safe: loads and swaps of atomics, `write(2)`, `unlink(2)`, `sigaction(2)` and
//! `_exit(2)`. It neither allocates nor locks, which is why it keeps tables of its own:
//!
//! - the live file maps, a fixed table of atomics (`Ranges`): start, length and a pointer to
//!   the message, each slot published under a sequence number so that a half-written slot is
//!   never read;
//! - the pending output files (temporary files of outputs being written, lock files), each as
//!   a C string, filled by `output`'s pending files ([`RemovedOnFault`]). The handler cannot
//!   call `output::remove_pending`, which takes a mutex and builds C strings; it unlinks these
//!   stored paths instead. The sampling checkpoints are not in it and stay, for `--resume`.
//!
//! A full table leaves a new entry out: a map beyond `MAP_SLOTS` live ones still works but
//! faults as before (`SIGBUS`), and a pending file beyond `PATH_SLOTS` is left behind by a
//! fault, for the next command writing that output to remove. A bake holds far fewer: a map
//! per input file and a few per stage; a lock file per output and per checkpoint, and the
//! temporary file of the one being written.
//!
//! On targets other than Unix there is no `SIGBUS` (Windows refuses to truncate a mapped
//! file), and the types here are empty.

use std::path::Path;

/// What a map holds, which decides the line printed when it faults.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Backing<'a> {
    /// A file the command reads, named by this path: it faults when another program makes it
    /// shorter.
    Input(&'a Path),
    /// The conversion cache written for the mesh at this path.
    CacheOf(&'a Path),
    /// An unlinked temporary file of this process: it faults when a write finds no room.
    Temporary,
}

impl Backing<'_> {
    /// The line printed when the map faults, newline included.
    #[cfg_attr(not(unix), allow(dead_code))]
    fn message(self) -> String {
        match self {
            Backing::Input(path) => format!(
                "error: {}: the file became shorter while patchvis was reading it (another \
                 program truncated or rewrote it); run patchvis again once it is complete\n",
                path.display()
            ),
            Backing::CacheOf(path) => format!(
                "error: {}: its conversion cache became shorter while patchvis was reading it \
                 (another program truncated it); run patchvis again to convert the mesh afresh\n",
                path.display()
            ),
            // Where `tempfile::tempfile()` puts them.
            Backing::Temporary => format!(
                "error: no space left for patchvis's temporary files in {} ($TMPDIR, or /tmp \
                 when it is unset); free space there or set TMPDIR to a directory with more \
                 room, then run patchvis again\n",
                std::env::temp_dir().display()
            ),
        }
    }
}

#[cfg(unix)]
pub(crate) use unix::{Covered, RemovedOnFault};

#[cfg(not(unix))]
pub(crate) use elsewhere::{Covered, RemovedOnFault};

#[cfg(unix)]
mod unix {
    use std::ffi::{CString, c_int, c_void};
    use std::path::Path;
    use std::sync::Once;
    use std::sync::atomic::{AtomicBool, AtomicPtr, AtomicUsize, Ordering, fence};

    use super::Backing;

    /// Most file maps covered at once.
    const MAP_SLOTS: usize = 64;

    /// Most pending output files removed by a fault.
    const PATH_SLOTS: usize = 64;

    /// The exit code of a command ended by a fault: the binary's code for bad input
    /// (`src/main.rs`).
    const EXIT_CODE: c_int = 1;

    /// The live file maps of the process.
    static MAPS: Ranges<MAP_SLOTS> = Ranges::new();

    /// The pending output files of the process.
    static PENDING: Paths<PATH_SLOTS> = Paths::new();

    /// The handler that was installed before ours (`SIG_DFL` if none), and whether it takes
    /// `siginfo_t` (`SA_SIGINFO`).
    static PREVIOUS: AtomicUsize = AtomicUsize::new(libc::SIG_DFL);
    static PREVIOUS_TAKES_INFO: AtomicBool = AtomicBool::new(false);

    /// Set by the first fault reported; a fault on another thread meanwhile waits for its
    /// exit.
    static REPORTING: AtomicBool = AtomicBool::new(false);

    /// A map's range, registered for as long as this lives. Declared before the map it
    /// covers, so that it is dropped (unregistered) before the map is unmapped.
    pub(crate) struct Covered {
        /// Its slot in [`MAPS`]; `None` when the table was full.
        slot: Option<usize>,
        /// The line printed on a fault; the table points into it.
        _message: Box<[u8]>,
    }

    impl Covered {
        /// Registers `bytes`, the whole of a file map, as holding `backing`.
        pub(crate) fn new(bytes: &[u8], backing: Backing<'_>) -> Covered {
            install();
            let message = backing.message().into_bytes().into_boxed_slice();
            let slot = MAPS.register(bytes.as_ptr() as usize, bytes.len(), &message);
            Covered {
                slot,
                _message: message,
            }
        }
    }

    impl Drop for Covered {
        fn drop(&mut self) {
            if let Some(slot) = self.slot {
                MAPS.unregister(slot);
            }
        }
    }

    impl std::fmt::Debug for Covered {
        fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            f.debug_struct("Covered").field("slot", &self.slot).finish()
        }
    }

    /// A pending output file, removed by the fault handler while this lives.
    #[derive(Debug)]
    pub(crate) struct RemovedOnFault {
        /// Its slot in [`PENDING`] and the path the slot points to; `None` when the table was
        /// full or the path holds a NUL byte (no such file can exist).
        listed: Option<(usize, CString)>,
    }

    impl RemovedOnFault {
        /// Lists `path` (a file just created) for removal on a fault.
        pub(crate) fn new(path: &Path) -> RemovedOnFault {
            use std::os::unix::ffi::OsStrExt;
            let listed = CString::new(path.as_os_str().as_bytes())
                .ok()
                .and_then(|path| Some((PENDING.register(path.as_ptr())?, path)));
            RemovedOnFault { listed }
        }
    }

    impl Drop for RemovedOnFault {
        fn drop(&mut self) {
            if let Some((slot, path)) = self.listed.take()
                && !PENDING.unregister(slot, path.as_ptr())
            {
                // The handler took the path and may be unlinking it: it must stay allocated
                // (the process is ending anyway).
                std::mem::forget(path);
            }
        }
    }

    /// Installs the handler, once per process.
    fn install() {
        static INSTALLED: Once = Once::new();
        INSTALLED.call_once(|| {
            // SAFETY: `sigaction` is plain data; all zeros is a valid value (no handler, no
            // flags, an empty mask on every Unix libc).
            let mut previous: libc::sigaction = unsafe { std::mem::zeroed() };
            // SAFETY: a null new action only reads the current one into `previous`.
            if unsafe { libc::sigaction(libc::SIGBUS, std::ptr::null(), &mut previous) } != 0 {
                return;
            }
            PREVIOUS.store(previous.sa_sigaction, Ordering::Relaxed);
            PREVIOUS_TAKES_INFO.store(previous.sa_flags & libc::SA_SIGINFO != 0, Ordering::Relaxed);
            // SAFETY: as above, all zeros is a valid `sigaction`.
            let mut action: libc::sigaction = unsafe { std::mem::zeroed() };
            let handler: extern "C" fn(c_int, *mut libc::siginfo_t, *mut c_void) = on_sigbus;
            action.sa_sigaction = handler as libc::sighandler_t;
            // On the thread's alternate signal stack where it has one (std sets one up for the
            // threads it starts, for its own stack overflow handler).
            action.sa_flags = libc::SA_SIGINFO | libc::SA_ONSTACK;
            // SAFETY: `action` is initialised; the handler has the `SA_SIGINFO` signature and
            // does only async-signal-safe work (the module header). `PREVIOUS` is stored
            // before it is installed, with the `Once`'s ordering.
            unsafe {
                libc::sigemptyset(&mut action.sa_mask);
                libc::sigaction(libc::SIGBUS, &action, std::ptr::null_mut());
            }
        });
    }

    /// The `SIGBUS` handler.
    extern "C" fn on_sigbus(signal: c_int, info: *mut libc::siginfo_t, context: *mut c_void) {
        // SAFETY: with `SA_SIGINFO` the kernel passes a valid `siginfo_t`. Its address field
        // is meaningful for a fault the kernel raised (`si_code > 0`); a `SIGBUS` sent by
        // `kill` or `raise` (`si_code <= 0`) is passed on without reading it.
        let address = unsafe {
            if (*info).si_code > 0 {
                Some((*info).si_addr() as usize)
            } else {
                None
            }
        };
        if let Some((message, len)) = address.and_then(|a| MAPS.find(a)) {
            end(message, len);
        }
        pass_on(signal, info, context);
    }

    /// Prints the `len` bytes at `message`, removes the pending files and exits.
    fn end(message: *const u8, len: usize) -> ! {
        if REPORTING.swap(true, Ordering::AcqRel) {
            // Another thread faulted first and is about to exit; its `_exit` ends this one.
            loop {
                // SAFETY: `pause` only waits for a signal.
                unsafe { libc::pause() };
            }
        }
        let mut at = 0;
        while at < len {
            // SAFETY: `message..message + len` is the live message of a registered map (see
            // `Ranges::find`); `write` reads only that much of it.
            let written = unsafe { libc::write(2, message.add(at).cast(), len - at) };
            match written {
                n if n > 0 => at += n as usize,
                // Reading `errno` is a load from thread-local storage: it does not allocate.
                _ if std::io::Error::last_os_error().kind() == std::io::ErrorKind::Interrupted => {}
                _ => break,
            }
        }
        PENDING.take_all(|path| {
            // SAFETY: `path` is a NUL-terminated string that the handler now owns: its owner
            // will not free it (`Paths::unregister` fails once it is taken).
            unsafe { libc::unlink(path) };
        });
        // SAFETY: `_exit` ends the process at once, running nothing of this one.
        unsafe { libc::_exit(EXIT_CODE) }
    }

    /// Hands a fault that is not in a covered map to the handler installed before, or to the
    /// default action: this returns, the instruction runs again and faults again, now with
    /// that action.
    fn pass_on(signal: c_int, info: *mut libc::siginfo_t, context: *mut c_void) {
        let previous = PREVIOUS.load(Ordering::Relaxed);
        if previous == libc::SIG_DFL || previous == libc::SIG_IGN {
            // SAFETY: `sigaction` is plain data, all zeros a valid value; setting `SIG_DFL` is
            // async-signal-safe. (An ignored `SIGBUS` cannot be ignored for a fault: the
            // kernel applies the default action, so it is restored too.)
            unsafe {
                let mut action: libc::sigaction = std::mem::zeroed();
                action.sa_sigaction = libc::SIG_DFL;
                libc::sigemptyset(&mut action.sa_mask);
                libc::sigaction(libc::SIGBUS, &action, std::ptr::null_mut());
            }
            return;
        }
        if PREVIOUS_TAKES_INFO.load(Ordering::Relaxed) {
            // SAFETY: `previous` is a handler that `sigaction` reported with `SA_SIGINFO`, so
            // it has this signature, and it was installed for exactly this call.
            let handler: extern "C" fn(c_int, *mut libc::siginfo_t, *mut c_void) =
                unsafe { std::mem::transmute(previous) };
            handler(signal, info, context);
        } else {
            // SAFETY: as above, a handler reported without `SA_SIGINFO` takes the signal only.
            let handler: extern "C" fn(c_int) = unsafe { std::mem::transmute(previous) };
            handler(signal);
        }
    }

    /// Tags of a range slot's state (its low two bits); the rest of the state counts the
    /// changes, so that a reader sees whether the slot changed while it read it.
    const FREE: usize = 0;
    const FILLING: usize = 1;
    const LIVE: usize = 2;

    /// The state after `state` with `tag`: the next change.
    fn next(state: usize, tag: usize) -> usize {
        (state & !3).wrapping_add(4) | tag
    }

    /// One registered map.
    struct RangeSlot {
        state: AtomicUsize,
        start: AtomicUsize,
        len: AtomicUsize,
        message: AtomicPtr<u8>,
        message_len: AtomicUsize,
    }

    /// A fixed table of address ranges and their messages, read without locks (a sequence
    /// lock per slot) and so from a signal handler.
    pub(super) struct Ranges<const N: usize> {
        slots: [RangeSlot; N],
    }

    impl<const N: usize> Ranges<N> {
        pub(super) const fn new() -> Ranges<N> {
            Ranges {
                slots: [const {
                    RangeSlot {
                        state: AtomicUsize::new(FREE),
                        start: AtomicUsize::new(0),
                        len: AtomicUsize::new(0),
                        message: AtomicPtr::new(std::ptr::null_mut()),
                        message_len: AtomicUsize::new(0),
                    }
                }; N],
            }
        }

        /// Registers `start..start + len` with `message`, which must outlive the
        /// registration; its slot, or `None` when every slot is taken.
        pub(super) fn register(&self, start: usize, len: usize, message: &[u8]) -> Option<usize> {
            self.slots.iter().position(|slot| {
                let state = slot.state.load(Ordering::Relaxed);
                if state & 3 != FREE
                    || slot
                        .state
                        .compare_exchange(
                            state,
                            next(state, FILLING),
                            Ordering::Relaxed,
                            Ordering::Relaxed,
                        )
                        .is_err()
                {
                    return false;
                }
                // The fields' stores may not move before the claim (a reader then sees the
                // state change).
                fence(Ordering::Release);
                slot.start.store(start, Ordering::Relaxed);
                slot.len.store(len, Ordering::Relaxed);
                slot.message
                    .store(message.as_ptr().cast_mut(), Ordering::Relaxed);
                slot.message_len.store(message.len(), Ordering::Relaxed);
                slot.state.store(next(state, LIVE), Ordering::Release);
                true
            })
        }

        /// Frees `slot`, which [`register`](Self::register) returned.
        pub(super) fn unregister(&self, slot: usize) {
            let state = &self.slots[slot].state;
            state.store(next(state.load(Ordering::Relaxed), FREE), Ordering::Release);
        }

        /// The message (start, length) of the live range holding `address`.
        ///
        /// What it points to is alive while its map is: a fault at `address` is an access
        /// through a reference to that map, so the map, and the registration its owner drops
        /// before unmapping it, outlive the fault's handling.
        pub(super) fn find(&self, address: usize) -> Option<(*const u8, usize)> {
            self.slots.iter().find_map(|slot| {
                let before = slot.state.load(Ordering::Acquire);
                if before & 3 != LIVE {
                    return None;
                }
                let start = slot.start.load(Ordering::Relaxed);
                let len = slot.len.load(Ordering::Relaxed);
                let message = slot.message.load(Ordering::Relaxed);
                let message_len = slot.message_len.load(Ordering::Relaxed);
                fence(Ordering::Acquire);
                let unchanged = slot.state.load(Ordering::Relaxed) == before;
                let inside = address.wrapping_sub(start) < len;
                (unchanged && inside).then_some((message.cast_const(), message_len))
            })
        }
    }

    /// A fixed table of C strings, taken by a signal handler with atomic swaps.
    pub(super) struct Paths<const N: usize> {
        slots: [AtomicPtr<libc::c_char>; N],
    }

    impl<const N: usize> Paths<N> {
        pub(super) const fn new() -> Paths<N> {
            Paths {
                slots: [const { AtomicPtr::new(std::ptr::null_mut()) }; N],
            }
        }

        /// Lists `path`, which must stay allocated while listed; its slot, or `None` when
        /// every slot is taken.
        pub(super) fn register(&self, path: *const libc::c_char) -> Option<usize> {
            self.slots.iter().position(|slot| {
                slot.compare_exchange(
                    std::ptr::null_mut(),
                    path.cast_mut(),
                    Ordering::AcqRel,
                    Ordering::Relaxed,
                )
                .is_ok()
            })
        }

        /// Unlists `path` from `slot`: true if it was still there, false if
        /// [`take_all`](Self::take_all) took it (and so may still use it).
        pub(super) fn unregister(&self, slot: usize, path: *const libc::c_char) -> bool {
            self.slots[slot]
                .compare_exchange(
                    path.cast_mut(),
                    std::ptr::null_mut(),
                    Ordering::AcqRel,
                    Ordering::Relaxed,
                )
                .is_ok()
        }

        /// Empties the table, calling `f` on each path taken.
        pub(super) fn take_all(&self, mut f: impl FnMut(*const libc::c_char)) {
            for slot in &self.slots {
                let path = slot.swap(std::ptr::null_mut(), Ordering::AcqRel);
                if !path.is_null() {
                    f(path);
                }
            }
        }
    }

    #[cfg(test)]
    mod tests {
        use super::*;

        #[test]
        fn a_range_is_found_from_its_first_to_its_last_byte_while_registered() {
            let table = Ranges::<4>::new();
            let (one, two) = (b"one".as_slice(), b"two".as_slice());
            let a = table.register(0x1000, 0x2000, one).unwrap();
            let b = table.register(0x8000, 16, two).unwrap();
            assert_ne!(a, b);
            let found = |address| table.find(address);
            assert_eq!(found(0x1000), Some((one.as_ptr(), 3)));
            assert_eq!(found(0x2fff), Some((one.as_ptr(), 3)));
            assert_eq!(found(0x800f), Some((two.as_ptr(), 3)));
            for outside in [0, 0xfff, 0x3000, 0x7fff, 0x8010, usize::MAX] {
                assert_eq!(found(outside), None, "{outside:#x}");
            }
            table.unregister(a);
            assert_eq!(found(0x1000), None);
            assert_eq!(found(0x8000), Some((two.as_ptr(), 3)));
            // The freed slot is taken again.
            assert_eq!(table.register(0x1000, 1, two), Some(a));
            assert_eq!(found(0x1000), Some((two.as_ptr(), 3)));
        }

        #[test]
        fn a_full_range_table_leaves_the_next_map_uncovered_until_a_slot_frees() {
            let table = Ranges::<2>::new();
            let message = b"m".as_slice();
            let first = table.register(0x1000, 0x1000, message).unwrap();
            table.register(0x2000, 0x1000, message).unwrap();
            // The map itself is not refused: its faults are simply not reported.
            assert_eq!(table.register(0x3000, 0x1000, message), None);
            assert_eq!(table.find(0x3000), None);
            table.unregister(first);
            assert_eq!(table.register(0x3000, 0x1000, message), Some(first));
            assert!(table.find(0x3000).is_some());
        }

        #[test]
        fn paths_are_taken_once_and_their_owner_then_keeps_them_alive() {
            let table = Paths::<2>::new();
            let (a, b, c) = (c"a".as_ptr(), c"b".as_ptr(), c"c".as_ptr());
            let slot_a = table.register(a).unwrap();
            let slot_b = table.register(b).unwrap();
            assert_eq!(table.register(c), None, "full");
            assert!(
                table.unregister(slot_b, b),
                "still listed: the owner frees it"
            );
            let mut taken = Vec::new();
            table.take_all(|p| taken.push(p));
            assert_eq!(taken, [a]);
            assert!(
                !table.unregister(slot_a, a),
                "taken: the owner must not free it"
            );
            table.take_all(|_| panic!("taken twice"));
        }

        /// The message `MAPS` holds for `address`, as text.
        fn message_at(address: usize) -> Option<String> {
            let (message, len) = MAPS.find(address)?;
            // SAFETY: the message of a live registration; the callers keep its map alive.
            let message = unsafe { std::slice::from_raw_parts(message, len) };
            Some(String::from_utf8_lossy(message).into_owned())
        }

        #[test]
        fn a_covered_range_has_its_line_until_dropped() {
            // Any bytes do: registering does not look at them. A heap buffer, kept alive, so
            // that no other test's map can take its addresses after the drop.
            let buffer = vec![0u8; 10_000];
            let address = buffer.as_ptr() as usize + 9_999;
            let covered = Covered::new(&buffer, Backing::Input(Path::new("m.ply")));
            let text = message_at(address).expect("registered");
            assert!(
                text.starts_with("error: m.ply: the file became shorter while patchvis was"),
                "{text}"
            );
            assert!(text.ends_with("once it is complete\n") && text.lines().count() == 1);
            drop(covered);
            assert_eq!(message_at(address), None);
        }

        #[test]
        fn file_and_temporary_maps_are_covered() {
            use std::io::Write;
            let mut file = tempfile::tempfile().unwrap();
            file.write_all(&[7; 10_000]).unwrap();
            let input = Backing::Input(Path::new("dir/m.ply"));
            let bytes = crate::mapped::FileBytes::open(&file, 10_000, input).unwrap();
            assert!(bytes.is_file_backed());
            let text = message_at(bytes.as_ptr() as usize + 4096).expect("registered");
            assert!(
                text.starts_with("error: dir/m.ply: the file became shorter"),
                "{text}"
            );
            let records = crate::mapped::Array::<u64>::zeroed_in_file(1000).unwrap();
            let text = message_at(records.as_ptr() as usize).expect("registered");
            let dir = std::env::temp_dir().display().to_string();
            let expected = format!("error: no space left for patchvis's temporary files in {dir} ");
            assert!(text.starts_with(&expected), "{text}");
        }

        #[test]
        fn a_pending_file_is_listed_for_the_handler_while_it_lives() {
            let name = "/nonexistent/.a-pending-file-test.patchvis-tmp";
            let pending = RemovedOnFault::new(Path::new(name));
            let (slot, path) = pending.listed.as_ref().expect("listed");
            assert_eq!(path.to_bytes(), name.as_bytes());
            assert_eq!(
                PENDING.slots[*slot].load(Ordering::Acquire).cast_const(),
                path.as_ptr()
            );
        }
    }
}

#[cfg(not(unix))]
mod elsewhere {
    use super::Backing;
    use std::path::Path;

    /// Nothing to register where there is no `SIGBUS`.
    #[derive(Debug)]
    pub(crate) struct Covered;

    impl Covered {
        pub(crate) fn new(_bytes: &[u8], _backing: Backing<'_>) -> Covered {
            Covered
        }
    }

    /// Nothing to register where there is no `SIGBUS`.
    #[derive(Debug)]
    pub(crate) struct RemovedOnFault;

    impl RemovedOnFault {
        pub(crate) fn new(_path: &Path) -> RemovedOnFault {
            RemovedOnFault
        }
    }
}
