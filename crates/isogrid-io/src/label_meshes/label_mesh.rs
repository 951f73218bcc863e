//! [`LabelMesh`], one label's mesh as the exporters take it.

use isogrid::mc::McMesh;
use isogrid::Label;

/// One label's mesh, its table entry (value, name, colour) and its values of an attribute.
#[derive(Debug, Clone, Copy)]
pub struct LabelMesh<'a> {
    pub label: &'a Label,
    /// The label's value as text (`isogrid::labels::display_value`: signed volumes keep their
    /// sign).
    pub value: &'a str,
    pub mesh: &'a McMesh,
    /// One value per vertex of `mesh` (NaN where there is none), or none.
    pub values: Option<&'a [f32]>,
}
