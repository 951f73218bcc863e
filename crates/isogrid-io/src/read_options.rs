//! What a caller can tell the readers beyond the path: a raw spec, a DICOM series, a
//! Zarr level and index.

use crate::raw::RawSpec;

/// How to read files whose format cannot be detected.
#[derive(Debug, Clone, Default)]
pub struct ReadOptions {
    /// Read the file as headerless raw samples with this shape, type and byte order.
    pub raw: Option<RawSpec>,
    /// DICOM: read this SeriesInstanceUID (default: the series with the most slices).
    pub series: Option<String>,
    /// Level and extra-axis indices of a Zarr / OME-Zarr input; the indices also pick the
    /// channel and time point of an ImageJ or OME-TIFF hyperstack.
    pub zarr: ZarrOptions,
}

/// Which level and which entries of extra axes to read from a Zarr array or OME-Zarr image.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ZarrOptions {
    /// OME-Zarr multiscale level; 0 is full resolution.
    pub level: usize,
    /// Index along each non-spatial axis, by axis name (`t`, `c`, …).
    pub indices: Vec<(String, u64)>,
    /// A PEM file of the root certificates that `https://` stores are checked against instead of
    /// Mozilla's (a site's own certificate authority); front ends take it from
    /// [`ssl_cert_file_from_env`].
    pub trusted_certificates: Option<std::path::PathBuf>,
    /// The option that gave `indices`, which errors about them name (`--index`; `--color-index`
    /// for the file a surface is coloured by; Python's `index=`).
    pub index_flag: IndexFlag,
}

/// The option that picks entries of axes beyond x, y and z, as errors write it: a command-line
/// flag (`--index t=3,c=0`) or a Python keyword argument (`index={"t": 3, "c": 0}`), so each
/// front end's errors name what its users type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IndexFlag {
    /// A flag such as `--index`.
    Cli(&'static str),
    /// A keyword argument such as `index`.
    Python(&'static str),
}

impl IndexFlag {
    /// The option with these entries (axis name, entry as text) given.
    pub fn with(self, entries: &[(&str, &str)]) -> String {
        match self {
            IndexFlag::Cli(flag) => {
                let entries: Vec<String> =
                    entries.iter().map(|(a, i)| format!("{a}={i}")).collect();
                format!("{flag} {}", entries.join(","))
            }
            IndexFlag::Python(keyword) => {
                let entries: Vec<String> = entries
                    .iter()
                    .map(|(a, i)| format!("\"{a}\": {i}"))
                    .collect();
                format!("{keyword}={{{}}}", entries.join(", "))
            }
        }
    }
}

impl std::fmt::Display for IndexFlag {
    /// The option's name: `--index`, or `index=`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            IndexFlag::Cli(flag) => f.write_str(flag),
            IndexFlag::Python(keyword) => write!(f, "{keyword}="),
        }
    }
}

impl Default for ZarrOptions {
    fn default() -> Self {
        ZarrOptions {
            level: 0,
            indices: Vec::new(),
            trusted_certificates: None,
            index_flag: IndexFlag::Cli("--index"),
        }
    }
}

impl ZarrOptions {
    /// The entries of extra axes these options pick.
    pub fn pick(&self) -> AxisPick<'_> {
        AxisPick {
            indices: &self.indices,
            flag: self.index_flag,
        }
    }
}

/// The entries of axes beyond x, y and z that a caller picks (by axis name: `t`, `c`, …), and the
/// flag that picked them, which errors name.
#[derive(Debug, Clone, Copy)]
pub struct AxisPick<'a> {
    pub indices: &'a [(String, u64)],
    pub flag: IndexFlag,
}

impl AxisPick<'static> {
    /// No entry picked: a file with axes beyond x, y and z of more than one entry is refused.
    pub const NONE: AxisPick<'static> = AxisPick {
        indices: &[],
        flag: IndexFlag::Cli("--index"),
    };
}

/// The PEM file named by the `SSL_CERT_FILE` environment variable (the one OpenSSL, curl and
/// Python read), if set and not empty.
pub fn ssl_cert_file_from_env() -> Option<std::path::PathBuf> {
    std::env::var_os("SSL_CERT_FILE")
        .filter(|path| !path.is_empty())
        .map(std::path::PathBuf::from)
}

/// Refuses an index that names an axis twice (`t=0,t=1` would otherwise read t=0 and ignore
/// the second value without a word).
pub(crate) fn refuse_repeated_axes(pick: AxisPick) -> isogrid::Result<()> {
    for (n, (name, index)) in pick.indices.iter().enumerate() {
        if let Some((earlier, other)) = pick.indices[..n]
            .iter()
            .find(|(earlier, _)| earlier.eq_ignore_ascii_case(name))
        {
            return Err(isogrid::Error::invalid(format!(
                "{} gives axis {name} twice ({earlier}={other} and {name}={index}); give each \
                 axis once",
                pick.flag
            )));
        }
    }
    Ok(())
}

/// Refuses an `--index` for an input it cannot apply to: only Zarr arrays (read before this is
/// asked), TIFF files (ImageJ and OME hyperstacks), NIfTI files (4-D) and MGH files (frames) have
/// axes beyond x, y and z to pick from, and any other reader would ignore the index without a word.
pub(crate) fn refuse_unused_index(
    path: &std::path::Path,
    options: &ReadOptions,
) -> isogrid::Result<()> {
    let four_d = path.file_name().is_some_and(|n| {
        let name = n.to_string_lossy();
        crate::nifti::is_nifti_name(&name)
            || crate::nifti::is_nifti_pair_name(&name)
            || crate::mgh::is_mgh_name(&name)
    });
    if options.zarr.indices.is_empty() || is_tiff_file(path) || four_d {
        return Ok(());
    }
    refuse_repeated_axes(options.zarr.pick()).map_err(|e| e.with_path(path))?;
    Err(isogrid::Error::invalid(format!(
        "{} picks a channel or time point of a Zarr, TIFF, 4-D NIfTI or MGH image; this input \
         has no axes beyond x, y and z",
        options.zarr.index_flag
    ))
    .with_path(path))
}

/// A file named `.tif`/`.tiff`, or starting with a TIFF or BigTIFF byte-order mark.
fn is_tiff_file(path: &std::path::Path) -> bool {
    use std::io::Read;
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    if name.ends_with(".tif") || name.ends_with(".tiff") {
        return path.is_file();
    }
    let mut head = [0u8; 4];
    path.is_file()
        && std::fs::File::open(path)
            .and_then(|mut f| f.read_exact(&mut head))
            .is_ok()
        && matches!(&head, b"II*\0" | b"MM\0*" | b"II+\0" | b"MM\0+")
}
