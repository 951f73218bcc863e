//! The lines a command prints on standard output, written so that a failed write is an error the
//! command returns instead of a panic: a reader that went away (a closed pipe, `| head -1`) ends
//! the command quietly with success, as ripgrep does; any other failure (`> /dev/full`) is a
//! one-line error and a non-zero exit.

use std::fmt;
use std::io::Write;

/// A write to standard output that failed.
#[derive(Debug)]
pub struct StdoutError(pub std::io::Error);

impl fmt::Display for StdoutError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "cannot write to standard output: {}", self.0)
    }
}

impl std::error::Error for StdoutError {}

impl StdoutError {
    /// Whether the reader closed the pipe: nobody is left to tell, so the command ends quietly.
    pub fn reader_went_away(&self) -> bool {
        self.0.kind() == std::io::ErrorKind::BrokenPipe
    }
}

/// Writes `args` and a newline to standard output.
pub fn write_line(args: fmt::Arguments) -> Result<(), StdoutError> {
    let mut out = std::io::stdout().lock();
    out.write_fmt(args)
        .and_then(|()| out.write_all(b"\n"))
        .map_err(StdoutError)
}

/// Writes `text` as it is (clap's help and version text).
pub fn write_text(text: &str) -> Result<(), StdoutError> {
    let mut out = std::io::stdout().lock();
    out.write_all(text.as_bytes())
        .and_then(|()| out.flush())
        .map_err(StdoutError)
}

/// Flushes what is buffered, so that its failure is reported before the command says success.
pub fn flush() -> Result<(), StdoutError> {
    std::io::stdout().lock().flush().map_err(StdoutError)
}

/// `println!` that returns a [`StdoutError`] from the calling function instead of panicking.
macro_rules! outln {
    ($($arg:tt)*) => {
        $crate::stdout::write_line(format_args!($($arg)*))?
    };
}
