//! `isogrid mc`: the Marching Cubes mesh the paper compares with (Table 3).

use crate::args::{InputArgs, IsoArgs, ThreadArgs};
use crate::color_by::AttributeInput;
use crate::outputs::{self, Output};
use crate::report::{print_json, MeshReport, Seconds};
use crate::{input, progress};
use anyhow::{bail, Context, Result};
use isogrid::mc::{marching_cubes, McMesh, MeshSpace};
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(clap::Args)]
pub struct Args {
    /// Volume: .nii/.nii.gz, .nrrd/.nhdr, .npy, .tif/.tiff, .mha/.mhd, .mrc/.map, a DICOM folder,
    /// or raw with --raw-shape.
    pub input: PathBuf,
    #[command(flatten)]
    pub iso: IsoArgs,
    #[command(flatten)]
    pub threads: ThreadArgs,
    #[command(flatten)]
    pub input_args: InputArgs,
    /// Write the mesh: .ply (binary) or .obj.
    #[arg(short, long, value_name = "MESH.ply|.obj")]
    pub output: Option<PathBuf>,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Vertex coordinates: `world` (the volume's patient space: origin, spacing and directions,
    /// where 3D Slicer, ITK-SNAP and nibabel's affine place the image) or `index` (sample indices).
    #[arg(long, value_enum, default_value_t = Space::World)]
    pub space: Space,
    /// Sample another volume at every vertex (trilinear; resampled in world space when its grid
    /// differs, NaN outside it) and write it as the PLY vertex property `quality` (MeshLab's
    /// vertex scalar).
    #[arg(long, value_name = "ATTR")]
    pub color_by: Option<String>,
}

/// `--space`.
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub enum Space {
    World,
    Index,
}

fn obj_has_no_values(path: &Path) -> anyhow::Error {
    anyhow::anyhow!(
        "{}: OBJ has no per-vertex values; write the mesh as .ply with --color-by",
        path.display()
    )
}

pub fn write_mesh(mesh: &McMesh, path: &Path, values: Option<&[f32]>) -> Result<()> {
    match path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("ply") => mesh.write_ply_with_values(path, values)?,
        Some("obj") if values.is_some() => return Err(obj_has_no_values(path)),
        Some("obj") => mesh.write_obj(path)?,
        _ => bail!("{}: mesh output must end in .ply or .obj", path.display()),
    }
    Ok(())
}

pub fn run(args: Args) -> Result<()> {
    // Fail before the work, not after it.
    let output = args.output.as_deref().map(|path| Output {
        role: "the mesh",
        path,
        extensions: &[".ply", ".obj"],
    });
    let read_options = args.input_args.read_options()?;
    let attribute =
        AttributeInput::from_flag(args.color_by.as_deref(), &args.input, &read_options)?;
    outputs::check(
        &AttributeInput::inputs(&args.input, attribute.as_ref()),
        output.as_slice(),
    )?;
    // Refused before the work, as write_mesh would refuse it after.
    if let (Some(_), Some(out)) = (&attribute, &args.output) {
        if !out.to_string_lossy().to_ascii_lowercase().ends_with(".ply") {
            return Err(obj_has_no_values(out));
        }
    }
    let (volume, read) = input::read_volume(&args.input, &read_options)?;
    let iso = args
        .iso
        .iso()
        .resolve(&volume.view())
        .with_context(|| args.input.display().to_string())?;
    let spinner = progress::spinner("marching cubes".into());
    let pool = args.threads.pool()?;
    let start = Instant::now();
    let mut mesh = pool.install(|| marching_cubes(&volume.view(), iso));
    let extract = start.elapsed().as_secs_f64();
    let values = match &attribute {
        Some(attribute) => {
            let points = mesh.index_positions(volume.geometry().spacing);
            Some(pool.install(|| attribute.sample_points(volume.geometry(), &points, &args.input))?)
        }
        None => None,
    };
    // The library's positions are in the renderer's frame (origin and directions left out).
    let space = match args.space {
        Space::World => MeshSpace::World,
        Space::Index => MeshSpace::Index,
    };
    mesh.place(&volume.geometry(), space)
        .with_context(|| args.input.display().to_string())?;
    spinner.finish_and_clear();
    let mut write = 0.0;
    if let Some(out) = &args.output {
        let start = Instant::now();
        write_mesh(&mesh, out, values.as_deref())?;
        write = start.elapsed().as_secs_f64();
    }
    let dims = volume.dims().map(|d| d as u32);
    let report = MeshReport {
        dims,
        iso,
        vertices: mesh.vertex_count() as u64,
        triangles: mesh.triangle_count() as u64,
        bytes: mesh.memory_bytes(),
        seconds: Seconds {
            read,
            extract,
            write,
        },
    };
    if args.json {
        print_json(&report)
    } else {
        report.print_human()?;
        Ok(())
    }
}
