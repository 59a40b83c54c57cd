//! The reader under test as a child process: `sh -c CMD` with its stdin and stdout piped, one
//! request line out and one reply line back, each reply awaited at most a set time (a reader
//! that hangs fails the vector instead of the run). Its stderr is copied to the harness's
//! line by line, so that a reader's stray child holding it cannot keep the harness's stderr
//! open after the harness is done.

use std::io::{self, BufRead, BufReader, Write};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::thread;
use std::time::Duration;

/// Why a request got no reply.
#[derive(Debug)]
pub enum PeerError {
    /// The reader closed its stdout (exited or crashed).
    Gone,
    /// No reply within the time allowed.
    Timeout(Duration),
    /// The request could not be written (the reader closed its stdin), or a reply was not
    /// UTF-8.
    Io(io::Error),
}

impl std::fmt::Display for PeerError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PeerError::Gone => f.write_str("the reader exited"),
            PeerError::Timeout(t) => write!(f, "no reply within {:.1} s", t.as_secs_f64()),
            PeerError::Io(e) => write!(f, "talking to the reader: {e}"),
        }
    }
}

/// A running reader.
pub struct Peer {
    child: Child,
    /// `None` once closed.
    stdin: Option<ChildStdin>,
    replies: Receiver<io::Result<String>>,
    timeout: Duration,
}

impl Peer {
    /// Starts `command` through `sh -c`.
    pub fn start(command: &str, timeout: Duration) -> io::Result<Peer> {
        let mut child = Command::new("sh")
            .arg("-c")
            .arg(command)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()?;
        let stderr = child.stderr.take().expect("piped stderr");
        thread::spawn(move || {
            for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                eprintln!("{line}");
            }
        });
        let stdin = child.stdin.take().expect("piped stdin");
        let stdout = child.stdout.take().expect("piped stdout");
        let (send, replies) = mpsc::channel();
        thread::spawn(move || {
            for line in BufReader::new(stdout).lines() {
                if send.send(line).is_err() {
                    break;
                }
            }
        });
        Ok(Peer {
            child,
            stdin: Some(stdin),
            replies,
            timeout,
        })
    }

    /// Sends `request` and returns the reply line (without its line ending).
    pub fn ask(&mut self, request: &str) -> Result<String, PeerError> {
        let stdin = self.stdin.as_mut().ok_or(PeerError::Gone)?;
        writeln!(stdin, "{request}")
            .and_then(|()| stdin.flush())
            .map_err(|e| match e.kind() {
                io::ErrorKind::BrokenPipe => PeerError::Gone,
                _ => PeerError::Io(e),
            })?;
        match self.replies.recv_timeout(self.timeout) {
            Ok(Ok(line)) => Ok(line.trim_end_matches('\r').to_string()),
            Ok(Err(e)) => Err(PeerError::Io(e)),
            Err(RecvTimeoutError::Timeout) => Err(PeerError::Timeout(self.timeout)),
            Err(RecvTimeoutError::Disconnected) => Err(PeerError::Gone),
        }
    }
}

impl Drop for Peer {
    /// Asks the reader to quit and closes its stdin, gives it half a second, then kills it.
    fn drop(&mut self) {
        if let Some(mut stdin) = self.stdin.take() {
            let _ = writeln!(stdin, "quit").and_then(|()| stdin.flush());
        }
        for _ in 0..50 {
            if matches!(self.child.try_wait(), Ok(Some(_))) {
                return;
            }
            thread::sleep(Duration::from_millis(10));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}
