//! Scalar volumes: a regular grid of samples in the file's storage order.
//!
//! Sample `(i, j, k)` sits at linear index `i + nx * (j + ny * k)` (i fastest), exactly as the file
//! stored it: no reorientation, no resampling. Its physical position is `origin + (i·sx, j·sy, k·sz)`
//! along the file's axes; `direction` (rows are the world directions of the i, j, k axes) is kept as
//! metadata only. Cells are the `(nx-1)(ny-1)(nz-1)` cubes between samples.

use crate::error::{Error, Result};

/// Largest number of samples per axis: metacell positions are 16-bit in units of 2 cells (§3.1).
pub const MAX_DIM: usize = 131_072;

/// The scalar types a volume stores. Readers keep a file's type where it is one of these (i8
/// widens to i16 exactly); a sample's side of the isovalue is decided in its own type, never after
/// a rounding conversion (see `extract::scalar`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ScalarType {
    U8,
    U16,
    I16,
    F32,
    U32,
    I32,
    U64,
    I64,
    F64,
}

impl ScalarType {
    /// Every sample type.
    pub const ALL: [ScalarType; 9] = [
        ScalarType::U8,
        ScalarType::U16,
        ScalarType::I16,
        ScalarType::F32,
        ScalarType::U32,
        ScalarType::I32,
        ScalarType::U64,
        ScalarType::I64,
        ScalarType::F64,
    ];
    /// The type of a [`ScalarType::name`] ("u8", "f64", ...).
    pub fn named(name: &str) -> Option<ScalarType> {
        Self::ALL.into_iter().find(|t| t.name() == name)
    }
    pub fn size(self) -> usize {
        match self {
            ScalarType::U8 => 1,
            ScalarType::U16 | ScalarType::I16 => 2,
            ScalarType::F32 | ScalarType::U32 | ScalarType::I32 => 4,
            ScalarType::U64 | ScalarType::I64 | ScalarType::F64 => 8,
        }
    }
    pub fn name(self) -> &'static str {
        match self {
            ScalarType::U8 => "u8",
            ScalarType::U16 => "u16",
            ScalarType::I16 => "i16",
            ScalarType::F32 => "f32",
            ScalarType::U32 => "u32",
            ScalarType::I32 => "i32",
            ScalarType::U64 => "u64",
            ScalarType::I64 => "i64",
            ScalarType::F64 => "f64",
        }
    }
    pub fn is_integer(self) -> bool {
        !matches!(self, ScalarType::F32 | ScalarType::F64)
    }
    /// Whether every value of the type is exactly an f64 (wider integers round beyond 2^53).
    pub fn fits_f64(self) -> bool {
        !matches!(self, ScalarType::U64 | ScalarType::I64)
    }
    /// `v`, a value of this type held in an f64, as the shortest text that reads back to it in
    /// the type's own precision: an f32 as `-12.976177`, not the f64 `-12.976177215576172`.
    pub fn display_value(self, v: f64) -> String {
        match self {
            ScalarType::F32 => (v as f32).to_string(),
            _ => v.to_string(),
        }
    }
}

/// A sample type the extraction is generic over.
pub trait Scalar: Copy + PartialOrd + Send + Sync + bytemuck::Pod + 'static {
    const TYPE: ScalarType;
    /// The sample as f64: exact for every type but u64 and i64 beyond ±2^53, which round to
    /// nearest (classification never goes through it).
    fn to_f64(self) -> f64;
}

macro_rules! scalar {
    ($($t:ty => $variant:ident),*) => {$(
        impl Scalar for $t {
            const TYPE: ScalarType = ScalarType::$variant;
            fn to_f64(self) -> f64 {
                self as f64
            }
        }
    )*};
}
scalar!(u8 => U8, u16 => U16, i16 => I16, f32 => F32, u32 => U32, i32 => I32, u64 => U64, i64 => I64, f64 => F64);

/// Owned samples of one of the supported types.
#[derive(Debug, Clone, PartialEq)]
pub enum VolumeData {
    U8(Vec<u8>),
    U16(Vec<u16>),
    I16(Vec<i16>),
    F32(Vec<f32>),
    U32(Vec<u32>),
    I32(Vec<i32>),
    U64(Vec<u64>),
    I64(Vec<i64>),
    F64(Vec<f64>),
}

/// Evaluates `$body` with `$s` bound to the typed slice that `$samples` (a [`Samples`]) holds,
/// whichever sample type it is: the one place that lists every type for code generic over
/// [`Scalar`], in this crate and the others (`isogrid::volume::with_samples!`).
#[doc(hidden)]
#[macro_export]
macro_rules! with_samples {
    ($samples:expr, $s:ident => $body:expr) => {
        match $samples {
            $crate::volume::Samples::U8($s) => $body,
            $crate::volume::Samples::U16($s) => $body,
            $crate::volume::Samples::I16($s) => $body,
            $crate::volume::Samples::F32($s) => $body,
            $crate::volume::Samples::U32($s) => $body,
            $crate::volume::Samples::I32($s) => $body,
            $crate::volume::Samples::U64($s) => $body,
            $crate::volume::Samples::I64($s) => $body,
            $crate::volume::Samples::F64($s) => $body,
        }
    };
}
pub use crate::with_samples;

/// Borrowed samples of one of the supported types (e.g. a numpy array's buffer).
#[derive(Debug, Clone, Copy)]
pub enum Samples<'a> {
    U8(&'a [u8]),
    U16(&'a [u16]),
    I16(&'a [i16]),
    F32(&'a [f32]),
    U32(&'a [u32]),
    I32(&'a [i32]),
    U64(&'a [u64]),
    I64(&'a [i64]),
    F64(&'a [f64]),
}

impl VolumeData {
    pub fn len(&self) -> usize {
        self.samples().len()
    }
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    pub fn scalar_type(&self) -> ScalarType {
        self.samples().scalar_type()
    }
    pub fn samples(&self) -> Samples<'_> {
        match self {
            VolumeData::U8(v) => Samples::U8(v),
            VolumeData::U16(v) => Samples::U16(v),
            VolumeData::I16(v) => Samples::I16(v),
            VolumeData::F32(v) => Samples::F32(v),
            VolumeData::U32(v) => Samples::U32(v),
            VolumeData::I32(v) => Samples::I32(v),
            VolumeData::U64(v) => Samples::U64(v),
            VolumeData::I64(v) => Samples::I64(v),
            VolumeData::F64(v) => Samples::F64(v),
        }
    }
}

impl<'a> Samples<'a> {
    pub fn len(&self) -> usize {
        match self {
            Samples::U8(v) => v.len(),
            Samples::U16(v) => v.len(),
            Samples::I16(v) => v.len(),
            Samples::F32(v) => v.len(),
            Samples::U32(v) => v.len(),
            Samples::I32(v) => v.len(),
            Samples::U64(v) => v.len(),
            Samples::I64(v) => v.len(),
            Samples::F64(v) => v.len(),
        }
    }
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    pub fn scalar_type(&self) -> ScalarType {
        match self {
            Samples::U8(_) => ScalarType::U8,
            Samples::U16(_) => ScalarType::U16,
            Samples::I16(_) => ScalarType::I16,
            Samples::F32(_) => ScalarType::F32,
            Samples::U32(_) => ScalarType::U32,
            Samples::I32(_) => ScalarType::I32,
            Samples::U64(_) => ScalarType::U64,
            Samples::I64(_) => ScalarType::I64,
            Samples::F64(_) => ScalarType::F64,
        }
    }
    /// Sample `index` as f64 (for tests and slow paths; hot loops are generic over [`Scalar`]).
    pub fn get_f64(&self, index: usize) -> f64 {
        match self {
            Samples::U8(v) => v[index] as f64,
            Samples::U16(v) => v[index] as f64,
            Samples::I16(v) => v[index] as f64,
            Samples::F32(v) => v[index] as f64,
            Samples::U32(v) => v[index].to_f64(),
            Samples::I32(v) => v[index].to_f64(),
            Samples::U64(v) => v[index].to_f64(),
            Samples::I64(v) => v[index].to_f64(),
            Samples::F64(v) => v[index].to_f64(),
        }
    }
    /// Smallest and largest finite sample, ignoring NaN and ±∞ (an infinite sample would make
    /// every normalised isovalue infinite); `None` when there is no finite sample.
    pub fn value_range(&self) -> Option<(f64, f64)> {
        fn range<T: Scalar>(v: &[T]) -> Option<(f64, f64)> {
            use rayon::prelude::*;
            v.par_chunks(1 << 16)
                .filter_map(|chunk| {
                    let mut it = chunk.iter().copied().filter(|x| x.to_f64().is_finite());
                    let first = it.next()?;
                    let (lo, hi) = it.fold((first, first), |(lo, hi), x| {
                        (if x < lo { x } else { lo }, if x > hi { x } else { hi })
                    });
                    Some((lo.to_f64(), hi.to_f64()))
                })
                .reduce_with(|a, b| (a.0.min(b.0), a.1.max(b.1)))
        }
        match self {
            Samples::U8(v) => range(v),
            Samples::U16(v) => range(v),
            Samples::I16(v) => range(v),
            Samples::F32(v) => range(v),
            Samples::U32(v) => range(v),
            Samples::I32(v) => range(v),
            Samples::U64(v) => range(v),
            Samples::I64(v) => range(v),
            Samples::F64(v) => range(v),
        }
    }
}

/// The anatomical convention of a file's world coordinates: which way +x and +y point. Formats
/// differ: DICOM, ITK's MetaImage and NRRD's `left-posterior-superior` are LPS (patient space);
/// NIfTI, FreeSurfer and NRRD's `right-anterior-superior` are RAS; arrays, Zarr, TIFF, MRC and VTK
/// files have none. Two volumes of one patient in different conventions differ in the signs of x
/// and y, so a volume sampled at another's world points is first taken into its frame
/// ([`Geometry::in_frame`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub enum WorldFrame {
    /// No convention is known: world coordinates are taken as they are.
    #[default]
    Unknown,
    /// +x left, +y posterior, +z superior (DICOM patient space).
    Lps,
    /// +x right, +y anterior, +z superior (NIfTI scanner or template space).
    Ras,
}

impl WorldFrame {
    /// The convention's name, as reports show it.
    pub fn name(self) -> &'static str {
        match self {
            WorldFrame::Unknown => "unknown",
            WorldFrame::Lps => "LPS",
            WorldFrame::Ras => "RAS",
        }
    }

    /// Whether coordinates in this convention must be converted to be read in `other`'s: both
    /// are known and they differ.
    pub fn converts_to(self, other: WorldFrame) -> bool {
        self != WorldFrame::Unknown && other != WorldFrame::Unknown && self != other
    }

    /// The anatomical direction each of the i, j and k axes of `direction` (rows, in this
    /// convention's coordinates) points closest to, as radiology tools write it: `"RAS"` for a
    /// NIfTI template, `"LIA"` for FreeSurfer's conformed volumes, `"LPS"` for a DICOM axial
    /// series. `None` where no convention is known.
    pub fn axis_codes(self, direction: &[[f64; 3]; 3]) -> Option<String> {
        // The letters of +x, +y, +z, then of −x, −y, −z.
        let letters = match self {
            WorldFrame::Unknown => return None,
            WorldFrame::Lps => ["L", "P", "S", "R", "A", "I"],
            WorldFrame::Ras => ["R", "A", "S", "L", "P", "I"],
        };
        Some(
            direction
                .iter()
                .map(|row| {
                    let axis = (0..3)
                        .max_by(|&a, &b| row[a].abs().total_cmp(&row[b].abs()))
                        .expect("three components");
                    letters[axis + if row[axis] < 0.0 { 3 } else { 0 }]
                })
                .collect(),
        )
    }
}

/// Whether the i, j, k axes of `direction` (rows) are a mirror image of x, y, z (a negative
/// determinant, as when one axis is flipped): a volume stored so, drawn in index × spacing
/// space, would show its world mirrored, so its cameras are mirrored ([`crate::Camera::mirrored`]).
pub fn directions_mirror(direction: &[[f64; 3]; 3]) -> bool {
    let d = direction;
    let det = d[0][0] * (d[1][1] * d[2][2] - d[1][2] * d[2][1])
        - d[0][1] * (d[1][0] * d[2][2] - d[1][2] * d[2][0])
        + d[0][2] * (d[1][0] * d[2][1] - d[1][1] * d[2][0]);
    det < 0.0
}

/// Geometry shared by owned volumes and borrowed views.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Geometry {
    /// Samples per axis (nx, ny, nz).
    pub dims: [usize; 3],
    /// Physical distance between samples along i, j, k (file units, usually mm).
    pub spacing: [f64; 3],
    /// Physical position of sample (0, 0, 0).
    pub origin: [f64; 3],
    /// Rows: world direction of the i, j, k axes. Renderers draw in index × spacing space and take
    /// only its handedness ([`directions_mirror`]).
    pub direction: [[f64; 3]; 3],
    /// The convention of `origin` and `direction`.
    pub frame: WorldFrame,
}

impl Geometry {
    pub fn new(dims: [usize; 3]) -> Self {
        Geometry {
            dims,
            spacing: [1.0; 3],
            origin: [0.0; 3],
            direction: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            frame: WorldFrame::Unknown,
        }
    }

    /// The same samples placed in `frame`'s world coordinates: where both conventions are known
    /// and differ (LPS and RAS), x and y of the origin and of every axis direction change sign;
    /// otherwise the geometry as it is.
    pub fn in_frame(&self, frame: WorldFrame) -> Geometry {
        if !self.frame.converts_to(frame) {
            return *self;
        }
        let flip = |v: [f64; 3]| [-v[0], -v[1], v[2]];
        Geometry {
            origin: flip(self.origin),
            direction: self.direction.map(flip),
            frame,
            ..*self
        }
    }
    pub fn sample_count(&self) -> usize {
        self.dims.iter().product()
    }
    /// Cells per axis: one fewer than samples (0 for an axis of a single sample).
    pub fn cell_dims(&self) -> [usize; 3] {
        self.dims.map(|n| n.saturating_sub(1))
    }
    pub(crate) fn validate(&self, len: usize) -> Result<()> {
        for (axis, &n) in self.dims.iter().enumerate() {
            if n == 0 || n > MAX_DIM {
                return Err(Error::too_large(format!(
                    "dimension {} along axis {} is outside 1..={MAX_DIM}",
                    n, axis
                )));
            }
        }
        let count = self
            .dims
            .iter()
            .try_fold(1usize, |acc, &n| acc.checked_mul(n));
        if count != Some(len) {
            return Err(Error::invalid(format!(
                "dims {}x{}x{} need {} samples but {} were given",
                self.dims[0],
                self.dims[1],
                self.dims[2],
                count.map_or("too many".to_string(), |c| c.to_string()),
                len
            )));
        }
        for s in self.spacing {
            if !(s.is_finite() && s > 0.0) {
                return Err(Error::invalid(format!(
                    "spacing {s} is not a positive finite number"
                )));
            }
        }
        if self.origin.iter().any(|o| !o.is_finite()) {
            return Err(Error::invalid("origin is not finite"));
        }
        Ok(())
    }
}

/// An owned scalar volume.
#[derive(Debug, Clone, PartialEq)]
pub struct Volume {
    geometry: Geometry,
    data: VolumeData,
}

impl Volume {
    /// A volume with unit spacing and zero origin. Fails when `data` does not hold `nx·ny·nz` samples
    /// or a dimension is outside `1..=131072`.
    pub fn new(dims: [usize; 3], data: VolumeData) -> Result<Self> {
        Self::with_geometry(Geometry::new(dims), data)
    }
    pub fn with_geometry(geometry: Geometry, data: VolumeData) -> Result<Self> {
        geometry.validate(data.len())?;
        Ok(Volume { geometry, data })
    }
    pub fn with_spacing(mut self, spacing: [f64; 3]) -> Result<Self> {
        self.geometry.spacing = spacing;
        self.geometry.validate(self.data.len())?;
        Ok(self)
    }
    pub fn with_origin(mut self, origin: [f64; 3]) -> Result<Self> {
        self.geometry.origin = origin;
        self.geometry.validate(self.data.len())?;
        Ok(self)
    }
    pub fn geometry(&self) -> &Geometry {
        &self.geometry
    }
    pub fn dims(&self) -> [usize; 3] {
        self.geometry.dims
    }
    pub fn spacing(&self) -> [f64; 3] {
        self.geometry.spacing
    }
    pub fn origin(&self) -> [f64; 3] {
        self.geometry.origin
    }
    pub fn scalar_type(&self) -> ScalarType {
        self.data.scalar_type()
    }
    pub fn data(&self) -> &VolumeData {
        &self.data
    }
    pub fn into_data(self) -> VolumeData {
        self.data
    }
    /// Sample (i, j, k) as f64.
    pub fn get(&self, i: usize, j: usize, k: usize) -> f64 {
        let [nx, ny, _] = self.geometry.dims;
        self.data.samples().get_f64(i + nx * (j + ny * k))
    }
    /// Smallest and largest finite sample (see [`Samples::value_range`]).
    pub fn value_range(&self) -> Option<(f64, f64)> {
        self.data.samples().value_range()
    }
    /// A borrowed view, the form extraction takes.
    pub fn view(&self) -> VolumeView<'_> {
        VolumeView {
            geometry: self.geometry,
            samples: self.data.samples(),
        }
    }
}

/// A borrowed volume: geometry plus a slice of samples in i-fastest order.
#[derive(Debug, Clone, Copy)]
pub struct VolumeView<'a> {
    geometry: Geometry,
    samples: Samples<'a>,
}

impl<'a> VolumeView<'a> {
    /// Checks that `samples` holds exactly `nx·ny·nz` values and the geometry is sane.
    pub fn new(geometry: Geometry, samples: Samples<'a>) -> Result<Self> {
        geometry.validate(samples.len())?;
        Ok(VolumeView { geometry, samples })
    }
    pub fn geometry(&self) -> &Geometry {
        &self.geometry
    }
    pub fn dims(&self) -> [usize; 3] {
        self.geometry.dims
    }
    pub fn samples(&self) -> Samples<'a> {
        self.samples
    }
    pub fn scalar_type(&self) -> ScalarType {
        self.samples.scalar_type()
    }
    pub fn value_range(&self) -> Option<(f64, f64)> {
        self.samples.value_range()
    }
    pub fn get(&self, i: usize, j: usize, k: usize) -> f64 {
        let [nx, ny, _] = self.geometry.dims;
        self.samples.get_f64(i + nx * (j + ny * k))
    }
}
