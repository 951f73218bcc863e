//! The library's error type: a kind to match on and a one-line message for people.

use std::fmt;
use std::path::{Path, PathBuf};

/// What went wrong, coarsely, so callers can react without parsing messages.
#[non_exhaustive]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ErrorKind {
    /// The operating system refused a read or write.
    Io,
    /// A file is malformed, truncated or inconsistent with itself.
    Corrupt,
    /// A file is well formed but uses something we do not read (an encoding, a type).
    Unsupported,
    /// An argument is out of range or inconsistent (dims vs data length, an isovalue, a precision).
    InvalidInput,
    /// A size exceeds what the format or the data structure can address (e.g. the 128K grid limit).
    TooLarge,
    /// The caller asked the work to stop ([`crate::progress::Progress::cancel`]); nothing was
    /// finished or written.
    Cancelled,
}

/// An error with a kind, a message, and the file it concerns when there is one.
///
/// `Display` prints one line: `path: message` (or just `message`).
#[derive(Debug)]
pub struct Error {
    kind: ErrorKind,
    message: String,
    path: Option<PathBuf>,
    source: Option<std::io::Error>,
}

/// Short for `std::result::Result<T, isogrid::Error>`.
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    pub fn new(kind: ErrorKind, message: impl Into<String>) -> Self {
        Error {
            kind,
            message: message.into(),
            path: None,
            source: None,
        }
    }
    pub fn corrupt(message: impl Into<String>) -> Self {
        Self::new(ErrorKind::Corrupt, message)
    }
    pub fn unsupported(message: impl Into<String>) -> Self {
        Self::new(ErrorKind::Unsupported, message)
    }
    pub fn invalid(message: impl Into<String>) -> Self {
        Self::new(ErrorKind::InvalidInput, message)
    }
    pub fn too_large(message: impl Into<String>) -> Self {
        Self::new(ErrorKind::TooLarge, message)
    }
    pub fn cancelled(message: impl Into<String>) -> Self {
        Self::new(ErrorKind::Cancelled, message)
    }
    /// Wraps an I/O error; a truncated read (`UnexpectedEof`) becomes `Corrupt` since the file is short.
    pub fn io(err: std::io::Error) -> Self {
        let kind = if err.kind() == std::io::ErrorKind::UnexpectedEof {
            ErrorKind::Corrupt
        } else {
            ErrorKind::Io
        };
        let message = if kind == ErrorKind::Corrupt {
            "file is truncated".to_string()
        } else {
            err.to_string()
        };
        Error {
            kind,
            message,
            path: None,
            source: Some(err),
        }
    }
    /// Names the file this error is about, unless an inner layer already did.
    pub fn with_path(mut self, path: impl AsRef<Path>) -> Self {
        if self.path.is_none() {
            self.path = Some(path.as_ref().to_path_buf());
        }
        self
    }
    pub fn kind(&self) -> ErrorKind {
        self.kind
    }
    pub fn message(&self) -> &str {
        &self.message
    }
    pub fn path(&self) -> Option<&Path> {
        self.path.as_deref()
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.path {
            Some(p) => write!(f, "{}: {}", p.display(), self.message),
            None => f.write_str(&self.message),
        }
    }
}

impl std::error::Error for Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        self.source.as_ref().map(|e| e as _)
    }
}

impl From<std::io::Error> for Error {
    fn from(err: std::io::Error) -> Self {
        Error::io(err)
    }
}

/// Adds a path to errors in a `Result`, for readers and writers.
pub trait ResultExt<T> {
    fn at_path(self, path: impl AsRef<Path>) -> Result<T>;
}

impl<T, E: Into<Error>> ResultExt<T> for std::result::Result<T, E> {
    fn at_path(self, path: impl AsRef<Path>) -> Result<T> {
        self.map_err(|e| e.into().with_path(path))
    }
}
