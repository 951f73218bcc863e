//! isogrid errors as Python exceptions, keeping the library's one-line messages.
//!
//! | `ErrorKind` | Python exception |
//! |---|---|
//! | `Io` | `OSError` built from the errno, so Python picks `FileNotFoundError`, `PermissionError`, … |
//! | `Corrupt`, `Unsupported` | `isogrid.IsogridError` (a `ValueError`): the file is bad, not the call |
//! | `InvalidInput`, `TooLarge` | `ValueError` |

use isogrid::{Error, ErrorKind};
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::PyErr;

pyo3::create_exception!(
    isogrid,
    IsogridError,
    PyValueError,
    "A file isogrid cannot use: malformed, truncated, inconsistent or of an unsupported kind."
);

/// Converts a library error; use as `.map_err(to_py)`.
pub fn to_py(err: Error) -> PyErr {
    let text = err.to_string();
    match err.kind() {
        ErrorKind::Io => {
            let errno = std::error::Error::source(&err)
                .and_then(|s| s.downcast_ref::<std::io::Error>())
                .and_then(|e| e.raw_os_error());
            match (errno, err.path()) {
                // OSError(errno, strerror, filename) becomes the matching subclass, with
                // `.errno` and `.filename` set like the built-in `open()` does.
                (Some(errno), Some(path)) => PyOSError::new_err((
                    errno,
                    err.message().to_string(),
                    path.to_string_lossy().into_owned(),
                )),
                (Some(errno), None) => PyOSError::new_err((errno, text)),
                _ => PyOSError::new_err(text),
            }
        }
        ErrorKind::Corrupt | ErrorKind::Unsupported => IsogridError::new_err(text),
        _ => PyValueError::new_err(text),
    }
}

pub fn invalid(message: impl Into<String>) -> PyErr {
    PyValueError::new_err(message.into())
}
