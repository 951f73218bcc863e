//! `isogrid mc`: the Marching Cubes mesh the paper compares with (Table 3).

use crate::args::{InputArgs, IsoArgs, LabelArgs, ThreadArgs};
use crate::color_by::{AttributeInput, ColorByArgs};
use crate::grid_source::is_cgc;
use crate::outputs::{self, Output};
use crate::report::{MeshReport, Seconds};
use crate::{input, progress};
use anyhow::{bail, Context, Result};
use isogrid::mc::{
    label_meshes, label_meshes_with_values, try_marching_cubes_with_progress, Inside, McMesh,
    MeshSpace,
};
use isogrid::{CellGrid, Progress};
use isogrid_io::label_meshes::{file_names, LabelMesh, LabelMeshOutput};
use isogrid_io::mesh_write::MeshFileFormat;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

#[derive(clap::Args)]
pub struct Args {
    /// Volume: .nii/.nii.gz, .nrrd/.nhdr, .npy, .tif/.tiff, .mha/.mhd, .mgh/.mgz, .mrc/.map, .vti, a DICOM
    /// folder, or raw with --raw-shape; with --labels also a .cgc file of labels (`extract
    /// --labels`), whose selected labels are meshed from their cells without the volume.
    pub input: PathBuf,
    #[command(flatten)]
    pub iso: IsoArgs,
    #[command(flatten)]
    pub threads: ThreadArgs,
    #[command(flatten)]
    pub input_args: InputArgs,
    /// Write the mesh: .ply (binary), .obj, .stl (binary, for 3D printing), .vtp (VTK XML
    /// PolyData, for ParaView) or .glb (glTF 2.0, for Blender and the web); with
    /// --labels, .glb (glTF 2.0: a named, coloured mesh per label), .vtp (one mesh, each
    /// triangle's label and colour as cell arrays), a new folder of neuroglancer precomputed
    /// meshes (any name without an extension), or one file per label named from a template
    /// holding {name} or {value}, e.g. "organs/{name}.stl" (.stl, .obj, .ply, .vtp or .glb).
    #[arg(
        short,
        long,
        value_name = "MESH.ply|.obj|.stl|.vtp|.glb|FOLDER|TEMPLATE"
    )]
    pub output: Option<PathBuf>,
    #[command(flatten)]
    pub label: LabelArgs,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Vertex coordinates: `world` (the volume's patient space: origin, spacing and directions,
    /// where 3D Slicer, ITK-SNAP and nibabel's affine place the image) or `index` (sample indices).
    #[arg(long, value_enum, default_value_t = Space::World)]
    pub space: Space,
    #[command(flatten)]
    pub color: ColorByArgs,
}

/// `--space`.
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub enum Space {
    World,
    Index,
}

impl Space {
    fn mesh_space(self) -> MeshSpace {
        match self {
            Space::World => MeshSpace::World,
            Space::Index => MeshSpace::Index,
        }
    }
}

/// Refuses per-vertex values where `format` has no place for them.
fn check_values(format: MeshFileFormat, path: &Path, values: bool) -> Result<()> {
    if values && !format.holds_values() {
        bail!(
            "{}: {} has no per-vertex values; write the mesh as .ply (MeshLab's vertex quality), \
             .vtp (a ParaView point array) or .glb (the vertex attribute _VALUE) with --color-by",
            path.display(),
            format.name()
        );
    }
    Ok(())
}

pub fn run(args: Args) -> Result<()> {
    if args.label.labels.is_some() {
        return run_labels(args);
    }
    if args.label.smooth.is_some() {
        bail!("--smooth smooths label indicators, and needs --labels");
    }
    if is_cgc(&args.input) {
        bail!(
            "{}: a .cgc file holds a grid, not a volume: mc meshes a label grid's labels \
             (--labels) and an isosurface from its volume",
            args.input.display()
        );
    }
    // Fail before the work, not after it.
    let output = args.output.as_deref().map(|path| Output {
        role: "the mesh",
        path,
        extensions: &[".ply", ".obj", ".stl", ".vtp", ".glb"],
    });
    let read_options = args.input_args.read_options()?;
    let attribute = args.color.attribute(&args.input, &read_options)?;
    outputs::check(
        &AttributeInput::inputs(&args.input, attribute.as_ref()),
        output.as_slice(),
    )?;
    // Refused before the work, not after it.
    let format = args.output.as_deref().map(MeshFileFormat::of).transpose()?;
    if let (Some(format), Some(out)) = (format, &args.output) {
        check_values(format, out, attribute.is_some())?;
    }
    let (volume, read) = input::read_volume(&args.input, &read_options)?;
    let iso = args
        .iso
        .iso()
        .resolve(&volume.view())
        .with_context(|| args.input.display().to_string())?;
    let pool = args.threads.pool()?;
    let start = Instant::now();
    // Slab by slab under a bar; Ctrl-C stops it at the next slab, with nothing written.
    let watch = Arc::new(Progress::new());
    let mesh = progress::watched("marching cubes", &watch, || {
        pool.install(|| {
            try_marching_cubes_with_progress(&volume.view(), iso, Inside::AtOrAbove, &watch)
        })
    });
    let mut mesh = match mesh {
        Err(e) if e.kind() == isogrid::ErrorKind::Cancelled => {
            return Err(
                anyhow::Error::from(e).context("Marching Cubes stopped by Ctrl-C, nothing written")
            )
        }
        r => r.with_context(|| format!("{}: Marching Cubes failed", args.input.display()))?,
    };
    let extract = start.elapsed().as_secs_f64();
    if mesh.triangle_count() == 0 {
        let range = volume.view().value_range();
        eprintln!(
            "isogrid: note: {}: {}",
            args.input.display(),
            isogrid::grid::isosurface_empty_note(
                volume.dims().map(|d| d as u32),
                volume.scalar_type(),
                range.map_or([0.0; 2], |(lo, hi)| [lo, hi]),
                iso,
                || range.is_none(),
            )
        );
    }
    let values = match &attribute {
        Some(attribute) => {
            let points = mesh.index_positions(volume.geometry().spacing);
            Some(pool.install(|| attribute.sample_points(volume.geometry(), &points, &args.input))?)
        }
        None => None,
    };
    // The library's positions are in the renderer's frame (origin and directions left out).
    let space = args.space.mesh_space();
    mesh.place(volume.geometry(), space)
        .with_context(|| args.input.display().to_string())?;
    let mut write = 0.0;
    if let Some(out) = &args.output {
        let start = Instant::now();
        let named = attribute.as_ref().zip(values.as_deref());
        let format = format.expect("a format for every output");
        format.write(&mesh, out, named.map(|(a, v)| (a.name.as_str(), v)))?;
        write = start.elapsed().as_secs_f64();
    }
    let dims = volume.dims().map(|d| d as u32);
    let report = MeshReport {
        dims,
        iso,
        vertices: mesh.vertex_count() as u64,
        triangles: mesh.triangle_count() as u64,
        bytes: mesh.memory_bytes(),
        labels: None,
        seconds: Seconds {
            read,
            extract,
            write,
        },
    };
    report.print(args.json)
}

/// The labels `--labels` selects of the label grid in the `.cgc` file `args.input` (memory-mapped;
/// only the selected labels' clusters are read), and the seconds it took. The grid's labels,
/// smoothing and precision were fixed when it was extracted.
fn open_label_grid(args: &Args) -> Result<(CellGrid, f64)> {
    let path = args.input.display();
    if args.label.smooth.is_some() {
        bail!("{path}: a .cgc file's labels were smoothed (or not) when it was extracted; drop --smooth");
    }
    if args.label.labels_of.is_some() {
        bail!("{path}: --labels-of picks a label image of an OME-Zarr image; a .cgc file holds one grid");
    }
    let start = Instant::now();
    let grid = isogrid::cgc::open(&args.input)?;
    let Some(labels) = grid.labels() else {
        bail!(
            "{path}: this .cgc file holds an isosurface, not labels; mc takes an isosurface from \
             its volume (`isogrid mc VOLUME --iso V`)"
        );
    };
    let selection = args.label.labels.as_ref().expect("called with --labels");
    let signed = isogrid::labels::signed_labels(grid.info().scalar_type);
    let shown = labels
        .shown(Some(selection), None, signed)
        .with_context(|| path.to_string())?;
    // Every label: the grid as it is, not a copy of it.
    let grid = match shown.iter().all(|&s| s) {
        true => grid,
        false => grid
            .showing_labels(&shown)
            .with_context(|| path.to_string())?,
    };
    Ok((grid, start.elapsed().as_secs_f64()))
}

/// `--labels`: the label grid of the volume (`isogrid extract --labels`) or of a `.cgc` file, one
/// Marching Cubes mesh per label from its cells, placed in `--space`, written as .glb, .vtp or
/// precomputed meshes; with the values of `--color-by`'s volume at its vertices, or of the grid's
/// own attribute.
fn run_labels(args: Args) -> Result<()> {
    let options = args.label.options(None).expect("called with --labels");
    let output = args
        .output
        .as_deref()
        .map(LabelMeshOutput::of)
        .transpose()?;
    let read_options = args.input_args.read_options()?;
    let attribute = args.color.attribute(&args.input, &read_options)?;
    if let Some(out) = output.filter(|o| attribute.is_some() && !o.holds_values()) {
        bail!(
            "--color-by: {} carry no per-vertex values; write the label meshes as .glb (the \
             vertex attribute _VALUE) or .vtp (a ParaView point array), or one .ply or .vtp per \
             label",
            out.describe()
        );
    }
    let mut inputs = AttributeInput::inputs(&args.input, attribute.as_ref());
    inputs.extend(args.label.label_table.as_deref());
    if let Some(LabelMeshOutput::Glb(path) | LabelMeshOutput::Vtp(path)) = output {
        let file = Output {
            role: "the meshes",
            path,
            extensions: &[".glb", ".vtp"],
        };
        outputs::check(&inputs, &[file])?;
    }
    if let Some(LabelMeshOutput::Precomputed(path)) = output {
        if path.symlink_metadata().is_ok() {
            bail!(
                "{}: already exists; the precomputed meshes are written as a new folder",
                path.display()
            );
        }
        outputs::check_folder("the precomputed meshes", path)?;
    }
    // A template's folder is made when it is not there yet, in a folder that is.
    let new_template_folder = match output {
        Some(LabelMeshOutput::Each(template, _)) => template
            .parent()
            .filter(|d| !d.as_os_str().is_empty() && d.symlink_metadata().is_err()),
        _ => None,
    };
    if let Some(folder) = new_template_folder {
        outputs::check_folder("the label meshes' folder", folder)?;
    }
    let pool = args.threads.pool()?;
    let table = args.label.table()?;
    let (mut grid, read, mut extract) = if is_cgc(&args.input) {
        let (grid, read) = open_label_grid(&args)?;
        (grid, read, 0.0)
    } else {
        // Read as `extract --labels` reads it: a .seg.nrrd's segments, layers, names and colours.
        // In the pool: a folder of masks is read in parallel, on --threads threads.
        let (source, read) = pool.install(|| {
            input::read_label_volume(&args.input, args.label.labels_of.as_deref(), &read_options)
        })?;
        let options =
            args.label
                .resolve_names(&options, &args.input, &source.names, table.as_deref())?;
        let spinner = progress::spinner("extracting labels".into());
        let start = Instant::now();
        let grid = pool
            .install(|| isogrid_io::labels::extract_label_volume(&source, &options))
            .with_context(|| format!("{}: extraction failed", args.input.display()))?;
        spinner.finish_and_clear();
        (grid, read, start.elapsed().as_secs_f64())
    };
    let mut absent = Vec::new();
    if let Some(table) = &table {
        absent = isogrid_io::labels::apply_label_names(&mut grid, table);
    }
    let spinner = progress::spinner("meshing labels".into());
    let start = Instant::now();
    // Per-vertex values: --color-by's volume sampled at the vertices, else the grid's own
    // attribute (a .cgc file's) as its cells hold it, where the output keeps them.
    let keeps_values = output.as_ref().is_some_and(LabelMeshOutput::holds_values);
    let own_attribute = grid
        .attribute()
        .filter(|_| attribute.is_none() && keeps_values);
    let geometry = isogrid::extract::attribute::grid_geometry(grid.info());
    let (mut meshes, mut values): (Vec<McMesh>, Vec<Option<Vec<f32>>>) = match own_attribute {
        Some(_) => pool.install(|| label_meshes_with_values(&grid)),
        None => pool
            .install(|| label_meshes(&grid))
            .map(|meshes| meshes.into_iter().map(|m| (m, None)).collect()),
    }
    .with_context(|| format!("{}: label meshing failed", args.input.display()))?
    .into_iter()
    .unzip();
    let mut attribute_name = own_attribute.map(|a| a.info().name.clone());
    if let Some(attribute) = &attribute {
        let points: Vec<[f64; 3]> = meshes
            .iter()
            .flat_map(|m| m.index_positions(geometry.spacing))
            .collect();
        let mut sampled = pool
            .install(|| attribute.sample_points(&geometry, &points, &args.input))?
            .into_iter();
        values = meshes
            .iter()
            .map(|m| Some(sampled.by_ref().take(m.positions.len()).collect()))
            .collect();
        attribute_name = Some(attribute.name.clone());
    }
    extract += start.elapsed().as_secs_f64();
    let space = args.space.mesh_space();
    for mesh in &mut meshes {
        mesh.place(&geometry, space)
            .with_context(|| args.input.display().to_string())?;
    }
    spinner.finish_and_clear();
    let dropped = grid.attribute().map(|a| &a.info().name);
    if let (Some(name), Some(out)) = (dropped, &output) {
        if !out.holds_values() {
            eprintln!(
                "isogrid: note: {}: the meshes' format carries no per-vertex values, so the \
                 attribute {name:?} is left out (.glb, .vtp and .ply keep it)",
                args.input.display()
            );
        }
    }
    let labels = grid.labels().expect("a label grid has labels");
    let signed = isogrid::labels::signed_labels(grid.info().scalar_type);
    args.label.note_absent(&absent, signed);
    let label_values: Vec<String> = labels
        .table()
        .iter()
        .map(|l| isogrid::labels::display_value(l.value, signed))
        .collect();
    let label_meshes: Vec<LabelMesh> = labels
        .table()
        .iter()
        .zip(&label_values)
        .zip(meshes.iter().zip(&values))
        .filter(|(_, (mesh, _))| mesh.triangle_count() > 0)
        .map(|((label, value), (mesh, values))| LabelMesh {
            label,
            value,
            mesh,
            values: values.as_deref(),
        })
        .collect();
    if label_meshes.is_empty() {
        let message = format!(
            "{}: the volume holds no selected label with a surface",
            args.input.display()
        );
        if output.is_some() {
            bail!("{message}; nothing written");
        }
        eprintln!("isogrid: note: {message}");
    }
    let mut write = 0.0;
    if let Some(output) = &output {
        let start = Instant::now();
        if let (LabelMeshOutput::Each(template, _), None) = (output, new_template_folder) {
            // The files' names are known now, from the labels' names; in a new folder, none can
            // be an input or another output.
            let files = file_names(template, &label_meshes)?;
            let outputs: Vec<Output> = files
                .iter()
                .map(|path| Output {
                    role: "a label's mesh",
                    path,
                    extensions: &[".stl", ".obj", ".ply", ".vtp", ".glb"],
                })
                .collect();
            outputs::check(&inputs, &outputs)?;
        }
        output.write(&label_meshes, attribute_name.as_deref())?;
        write = start.elapsed().as_secs_f64();
    }
    let sum = |f: fn(&McMesh) -> usize| label_meshes.iter().map(|m| f(m.mesh) as u64).sum();
    let report = MeshReport {
        dims: grid.info().dims,
        iso: isogrid::extract::labels::LABEL_ISO,
        vertices: sum(McMesh::vertex_count),
        triangles: sum(McMesh::triangle_count),
        bytes: label_meshes.iter().map(|m| m.mesh.memory_bytes()).sum(),
        labels: Some(label_meshes.len() as u64),
        seconds: Seconds {
            read,
            extract,
            write,
        },
    };
    report.print(args.json)
}
