//! Opening the data files that a header names (NRRD `data file`, MetaImage `ElementDataFile`) and
//! the files the readers open themselves, gzip-compressed or not.

use isogrid::{Error, Result, ResultExt};
use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

/// `name` as a header gives it: relative to the header's folder `base` unless absolute.
pub(crate) fn resolve(base: &Path, name: &str) -> PathBuf {
    let p = Path::new(name);
    if p.is_absolute() {
        p.to_path_buf()
    } else {
        base.join(p)
    }
}

/// Opens `path` for reading after checking it is a regular file: opening a FIFO would block and
/// a folder cannot hold samples. Errors name `path`.
pub(crate) fn open_regular(path: &Path) -> Result<File> {
    let meta = std::fs::metadata(path).at_path(path)?;
    if !meta.is_file() {
        return Err(
            Error::invalid("is not a regular file (a folder, FIFO or device)").with_path(path),
        );
    }
    File::open(path).at_path(path)
}

/// A file that may be gzip-compressed (detected from its first bytes, as `.nii.gz` and `.mgz`
/// are), open at its start.
pub(crate) struct MaybeGzip {
    /// The decompressed bytes (the file's own where it is not compressed).
    pub reader: Box<dyn Read>,
    pub gzipped: bool,
    /// The file's length on disk.
    pub file_len: u64,
}

/// Opens a regular file that may be gzip-compressed.
pub(crate) fn open_maybe_gzip(path: &Path) -> Result<MaybeGzip> {
    let mut file = isogrid::fs::open_regular(path)?;
    let file_len = file.metadata()?.len();
    let mut magic = [0u8; 2];
    let gzipped = file.read(&mut magic)? == 2 && magic == GZIP_MAGIC;
    file.seek(SeekFrom::Start(0))?;
    let reader: Box<dyn Read> = if gzipped {
        Box::new(flate2::read::MultiGzDecoder::new(BufReader::new(file)))
    } else {
        Box::new(BufReader::new(file))
    };
    Ok(MaybeGzip {
        reader,
        gzipped,
        file_len,
    })
}

/// Up to the first `len` bytes of a file (its header; fewer where the file is shorter) and the
/// file's length, for reading the samples by region; `None` for a gzip-compressed file, which must
/// be decompressed from its start.
pub(crate) fn uncompressed_head(path: &Path, len: usize) -> Result<Option<(Vec<u8>, u64)>> {
    let mut file = isogrid::fs::open_regular(path)?;
    let file_len = file.metadata()?.len();
    let mut raw = vec![0u8; len];
    let mut got = 0;
    while got < len {
        match file.read(&mut raw[got..])? {
            0 => break,
            n => got += n,
        }
    }
    raw.truncate(got);
    if raw.starts_with(&GZIP_MAGIC) {
        return Ok(None);
    }
    Ok(Some((raw, file_len)))
}

const GZIP_MAGIC: [u8; 2] = [0x1f, 0x8b];
