//! A FIFO with a thread that reads everything written into it: a destination that
//! must be written in place, never replaced (it stands in for `/dev/null`).

use std::io::Read;
use std::path::Path;
use std::thread::JoinHandle;

/// Makes a FIFO at `path` (with `mkfifo`) and starts a thread that returns all the
/// bytes written into it. Check that the FIFO is still one before joining: a
/// replaced FIFO leaves the thread blocked on open.
pub fn fifo_with_reader(path: &Path) -> JoinHandle<Vec<u8>> {
    let made = std::process::Command::new("mkfifo")
        .arg(path)
        .status()
        .expect("mkfifo runs");
    assert!(made.success(), "mkfifo {}", path.display());
    let path = path.to_path_buf();
    std::thread::spawn(move || {
        let mut got = Vec::new();
        std::fs::File::open(&path)
            .and_then(|mut f| f.read_to_end(&mut got))
            .expect("the FIFO is read");
        got
    })
}
