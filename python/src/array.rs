//! Borrowing a numpy array as an isogrid volume without copying it.
//!
//! Axis rule (the Python docs state it for users): the axis that varies fastest in memory is x.
//! A C-ordered array of shape `(nz, ny, nx)` and a Fortran-ordered array of shape `(nx, ny, nz)`
//! both hold sample `(i, j, k)` at element `i + nx·(j + ny·k)`, which is exactly isogrid's
//! storage order, so their buffers are used as they are. The caller says which order it means
//! (`fortran`); the array must then be contiguous in that order and aligned, or this refuses:
//! converting is the Python layer's job, where it is visible.

use crate::errors::invalid;
use isogrid::{Geometry, Samples, VolumeView, WorldFrame};
use numpy::{Element, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;

/// A read-only borrow of a numpy array of one of the sample types, kept as it is (no conversion:
/// a sample's side of the isovalue is decided in its own type).
pub enum BorrowedArray<'py> {
    U8(PyReadonlyArrayDyn<'py, u8>),
    U16(PyReadonlyArrayDyn<'py, u16>),
    I16(PyReadonlyArrayDyn<'py, i16>),
    F32(PyReadonlyArrayDyn<'py, f32>),
    U32(PyReadonlyArrayDyn<'py, u32>),
    I32(PyReadonlyArrayDyn<'py, i32>),
    U64(PyReadonlyArrayDyn<'py, u64>),
    I64(PyReadonlyArrayDyn<'py, i64>),
    F64(PyReadonlyArrayDyn<'py, f64>),
}

/// The borrowed array and where its samples sit.
pub struct VolumeArg<'py> {
    array: BorrowedArray<'py>,
    geometry: Geometry,
}

impl<'py> VolumeArg<'py> {
    /// Checks `array` (3-D, a supported native dtype, contiguous in the stated order, aligned)
    /// and records its isogrid dims (`nx, ny, nz`) and `spacing` (`sx, sy, sz`).
    pub fn new(array: &Bound<'py, PyAny>, fortran: bool, spacing: [f64; 3]) -> PyResult<Self> {
        let borrowed = if let Ok(a) = array.extract() {
            BorrowedArray::U8(a)
        } else if let Ok(a) = array.extract() {
            BorrowedArray::U16(a)
        } else if let Ok(a) = array.extract() {
            BorrowedArray::I16(a)
        } else if let Ok(a) = array.extract() {
            BorrowedArray::F32(a)
        } else if let Ok(a) = array.extract() {
            BorrowedArray::U32(a)
        } else if let Ok(a) = array.extract() {
            BorrowedArray::I32(a)
        } else if let Ok(a) = array.extract() {
            BorrowedArray::U64(a)
        } else if let Ok(a) = array.extract() {
            BorrowedArray::I64(a)
        } else if let Ok(a) = array.extract() {
            BorrowedArray::F64(a)
        } else {
            return Err(invalid(
                "expected a numpy array of uint8, uint16, int16, uint32, int32, uint64, int64, \
                 float32 or float64 in native byte order",
            ));
        };
        let (shape, c_order, f_order) = match &borrowed {
            BorrowedArray::U8(a) => layout(a),
            BorrowedArray::U16(a) => layout(a),
            BorrowedArray::I16(a) => layout(a),
            BorrowedArray::F32(a) => layout(a),
            BorrowedArray::U32(a) => layout(a),
            BorrowedArray::I32(a) => layout(a),
            BorrowedArray::U64(a) => layout(a),
            BorrowedArray::I64(a) => layout(a),
            BorrowedArray::F64(a) => layout(a),
        };
        let shape: [usize; 3] = shape.try_into().map_err(|shape: Vec<usize>| {
            invalid(format!(
                "expected a 3-D array, got {} dimension{} (shape {shape:?})",
                shape.len(),
                if shape.len() == 1 { "" } else { "s" }
            ))
        })?;
        let dims = if fortran {
            if !f_order {
                return Err(invalid("array is not Fortran-contiguous"));
            }
            shape
        } else {
            if !c_order {
                return Err(invalid("array is not C-contiguous"));
            }
            [shape[2], shape[1], shape[0]]
        };
        let geometry = Geometry {
            spacing,
            ..Geometry::new(dims)
        };
        Ok(VolumeArg {
            array: borrowed,
            geometry,
        })
    }

    /// Sets where the volume sits in the world: the position of sample (0, 0, 0) and, as rows,
    /// the directions of the x, y, z axes (metadata), in the convention `frame` names (`"LPS"`,
    /// `"RAS"`); `None` keeps the defaults (no convention).
    pub fn place(
        mut self,
        origin: Option<Vec<f64>>,
        direction: Option<Vec<Vec<f64>>>,
        frame: Option<&str>,
    ) -> PyResult<Self> {
        let place = Placement::new(None, origin, direction)?;
        self.geometry.origin = place.origin.unwrap_or(self.geometry.origin);
        self.geometry.direction = place.direction.unwrap_or(self.geometry.direction);
        self.geometry.frame = frame_arg(frame)?;
        Ok(self)
    }

    /// The samples as an isogrid view, borrowing the numpy buffer.
    pub fn view(&self) -> PyResult<VolumeView<'_>> {
        let samples = match &self.array {
            BorrowedArray::U8(a) => Samples::U8(slice(a)?),
            BorrowedArray::U16(a) => Samples::U16(slice(a)?),
            BorrowedArray::I16(a) => Samples::I16(slice(a)?),
            BorrowedArray::F32(a) => Samples::F32(slice(a)?),
            BorrowedArray::U32(a) => Samples::U32(slice(a)?),
            BorrowedArray::I32(a) => Samples::I32(slice(a)?),
            BorrowedArray::U64(a) => Samples::U64(slice(a)?),
            BorrowedArray::I64(a) => Samples::I64(slice(a)?),
            BorrowedArray::F64(a) => Samples::F64(slice(a)?),
        };
        VolumeView::new(self.geometry, samples).map_err(crate::errors::to_py)
    }
}

fn layout<T: Element>(a: &PyReadonlyArrayDyn<'_, T>) -> (Vec<usize>, bool, bool) {
    (
        a.shape().to_vec(),
        a.is_c_contiguous(),
        a.is_fortran_contiguous(),
    )
}

fn slice<'a, T: Element>(a: &'a PyReadonlyArrayDyn<'_, T>) -> PyResult<&'a [T]> {
    a.as_slice()
        .map_err(|_| invalid("array is not contiguous and aligned"))
}

/// The world frame a Volume's `frame` names: `"LPS"`, `"RAS"`, or `None` for none.
pub fn frame_arg(frame: Option<&str>) -> PyResult<WorldFrame> {
    match frame {
        None => Ok(WorldFrame::Unknown),
        Some("LPS") => Ok(WorldFrame::Lps),
        Some("RAS") => Ok(WorldFrame::Ras),
        Some(other) => Err(invalid(format!(
            "frame must be \"LPS\", \"RAS\" or None, not {other:?}"
        ))),
    }
}

/// The name of `frame` as a Volume's `frame` holds it (`None`: no convention).
pub fn frame_name(frame: WorldFrame) -> Option<&'static str> {
    (frame != WorldFrame::Unknown).then(|| frame.name())
}

/// `spacing` as three positive finite numbers (the library checks them again).
pub fn spacing3(spacing: Vec<f64>) -> PyResult<[f64; 3]> {
    triple(spacing, "spacing")
}

/// Spacing, origin and directions that replace a volume file's (each when given).
pub struct Placement {
    spacing: Option<[f64; 3]>,
    origin: Option<[f64; 3]>,
    direction: Option<[[f64; 3]; 3]>,
}

impl Placement {
    pub fn new(
        spacing: Option<Vec<f64>>,
        origin: Option<Vec<f64>>,
        direction: Option<Vec<Vec<f64>>>,
    ) -> PyResult<Self> {
        let direction = match direction {
            None => None,
            Some(rows) => {
                let n = rows.len();
                let rows: [Vec<f64>; 3] = rows
                    .try_into()
                    .map_err(|_| invalid(format!("direction must have 3 rows, got {n}")))?;
                let [x, y, z] = rows.map(|r| triple(r, "direction row"));
                Some([x?, y?, z?])
            }
        };
        Ok(Placement {
            spacing: spacing.map(spacing3).transpose()?,
            origin: origin.map(|o| triple(o, "origin")).transpose()?,
            direction,
        })
    }

    /// Gives `volume` the spacing, origin and directions given.
    pub fn apply(&self, volume: &mut isogrid::Volume) -> isogrid::Result<()> {
        let mut g = *volume.geometry();
        g.spacing = self.spacing.unwrap_or(g.spacing);
        g.origin = self.origin.unwrap_or(g.origin);
        g.direction = self.direction.unwrap_or(g.direction);
        let empty = isogrid::Volume::new([1, 1, 1], isogrid::VolumeData::U8(vec![0]))?;
        let data = std::mem::replace(volume, empty).into_data();
        *volume = isogrid::Volume::with_geometry(g, data)?;
        Ok(())
    }
}

/// Three finite numbers (x, y, z).
pub fn triple(values: Vec<f64>, name: &str) -> PyResult<[f64; 3]> {
    let n = values.len();
    let t: [f64; 3] = values
        .try_into()
        .map_err(|_| invalid(format!("{name} must have 3 values (x, y, z), got {n}")))?;
    if t.iter().any(|v| !v.is_finite()) {
        return Err(invalid(format!("{name} must be finite, got {t:?}")));
    }
    Ok(t)
}
