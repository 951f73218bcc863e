//! One volume of a 4-D file (NIfTI, FreeSurfer MGH; the fourth axis is time, `t`): which one
//! `--index t=N` picks, and how many bytes lie before and around it. A file of several volumes
//! read without an index is an error naming them, never a silent pick of the first.

use crate::read_options::AxisPick;
use crate::samples::{byte_count, sample_count, ElemType};
use isogrid::{Error, Result};

/// The volume a pick chooses of a file, and its size.
pub(crate) struct PickedVolume {
    /// Its index along t (0 for a 3-D file).
    pub t: usize,
    /// Its sample count.
    pub count: usize,
    /// Its bytes.
    pub volume_bytes: u64,
    /// The bytes of all the file's volumes.
    pub all_bytes: u64,
}

impl PickedVolume {
    /// The bytes of the volumes before the one picked.
    pub fn bytes_before(&self) -> u64 {
        self.volume_bytes * self.t as u64
    }
}

/// The volume `pick` chooses of a file (`what`, e.g. "NIfTI file") holding `times` volumes of
/// `dims` samples of `elem`: `t=N` of a file of several, else the only one. An index of another
/// axis, out of range or given twice, or a missing one, is an error.
pub(crate) fn pick_volume(
    pick: AxisPick,
    what: &str,
    dims: [usize; 3],
    times: usize,
    elem: ElemType,
) -> Result<PickedVolume> {
    let t = pick_index(pick, times, what)?;
    let count = sample_count(dims)?;
    let volume_bytes = byte_count(count, elem)?;
    let all_bytes = volume_bytes
        .checked_mul(times as u64)
        .ok_or_else(|| Error::too_large("the volumes' size overflows 64 bits"))?;
    Ok(PickedVolume {
        t,
        count,
        volume_bytes,
        all_bytes,
    })
}

fn pick_index(pick: AxisPick, times: usize, what: &str) -> Result<usize> {
    crate::read_options::refuse_repeated_axes(pick)?;
    let flag = pick.flag;
    let t = times;
    if t == 1 && !pick.indices.is_empty() {
        return Err(Error::invalid(format!(
            "{flag} picks a volume of a 4-D file, and this {what} holds one 3-D volume"
        )));
    }
    let described = format!("{what} of {t} volumes (t=0..{})", t.saturating_sub(1));
    for (name, index) in pick.indices {
        if !name.eq_ignore_ascii_case("t") {
            return Err(Error::invalid(format!(
                "{flag} names {name}, which is not an axis of this {described}: use t"
            )));
        }
        if *index >= t as u64 {
            return Err(Error::invalid(format!(
                "{} is out of range: this is a {described}",
                flag.with(&[(name, &index.to_string())])
            )));
        }
    }
    match pick.indices.first() {
        Some(&(_, index)) => Ok(index as usize),
        None if t == 1 => Ok(0),
        None => Err(Error::invalid(format!(
            "this is a 4-D {described}: pass {} to read one",
            flag.with(&[("t", "N")])
        ))),
    }
}
