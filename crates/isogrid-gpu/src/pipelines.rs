//! Bind group layouts and pipelines of every pass, built once per [`crate::Renderer`]. Shader
//! modules are `common.wgsl` (+ `cell_decode.wgsl` and the page storage, `cell_data.wgsl` or the
//! tracer's `trace_pages.wgsl`, for passes that read cells) + the role's file.

use crate::gpu_types::{LIST_FULL, LIST_NEW};
use wgpu::{BindGroupLayout, ComputePipeline, Device, RenderPipeline, ShaderStages};

pub(crate) const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// World normal (xyz) and eye distance (w) of the raster hit.
pub(crate) const SURFACE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
/// Cluster and record index (the paper's RG32UI target).
pub(crate) const IDS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rg32Uint;
/// Weighted normal sum (xyz) and weight (w) of the EWA pass.
pub(crate) const EWA_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
pub(crate) const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
/// Final world normal (xyz) and eye distance (w).
pub(crate) const FINAL_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;

pub(crate) const COMMON: &str = include_str!("../shaders/common.wgsl");
/// Cell decoding over one page per bind group (the raster passes, the single-page tracer).
pub(crate) const CELL_DATA: &str = concat!(
    include_str!("../shaders/cell_decode.wgsl"),
    include_str!("../shaders/cell_data.wgsl")
);
/// The per-pixel cell test shared by the hardware and the compute cell raster.
pub(crate) const CELL_HIT: &str = include_str!("../shaders/cell_hit.wgsl");
/// The instance lists and pixel spans of the compute raster and splat passes.
pub(crate) const COMPUTE_LISTS: &str = include_str!("../shaders/compute_lists.wgsl");
/// EWA splat setup and per-pixel weight, shared by the hardware and the compute splats.
pub(crate) const EWA_SPLAT: &str = include_str!("../shaders/ewa_splat.wgsl");
/// Cell decoding over up to [`crate::gpu_types::TRACE_PAGES`] pages bound at once (the tracer).
pub(crate) const TRACE_PAGES_DATA: &str = concat!(
    include_str!("../shaders/cell_decode.wgsl"),
    include_str!("../shaders/trace_pages.wgsl")
);

pub(crate) struct Pipelines {
    pub scene_compute: BindGroupLayout,
    pub scene_render: BindGroupLayout,
    pub page_compute: BindGroupLayout,
    pub page_render: BindGroupLayout,
    pub depth_input: BindGroupLayout,
    pub surface_input: BindGroupLayout,
    pub ids_input: BindGroupLayout,
    pub shade_inputs: BindGroupLayout,
    pub mesh: BindGroupLayout,
    pub dispatch_args: BindGroupLayout,
    pub raster_targets: BindGroupLayout,
    pub ewa_targets: BindGroupLayout,
    pub expand_visible: ComputePipeline,
    pub expand_new: ComputePipeline,
    pub size_dispatches: ComputePipeline,
    pub compute_raster: ComputeRasterPipelines,
    pub visibility: ComputePipeline,
    pub cells: RenderPipeline,
    pub probe: RenderPipeline,
    pub ewa: RenderPipeline,
    pub shade: RenderPipeline,
    pub shade_outputs: BindGroupLayout,
    pub shade_compute: ComputePipeline,
    pub mesh_pipeline: RenderPipeline,
    pub trace: crate::pathtrace::TracePipelines,
}

/// The compute cell raster's passes (`shaders/cells_compute.wgsl`).
pub(crate) struct ComputeRasterPipelines {
    pub depth_full: ComputePipeline,
    pub depth_new: ComputePipeline,
    pub resolve_full: ComputePipeline,
    pub resolve_new: ComputePipeline,
    pub probe: ComputePipeline,
    pub clear: ComputePipeline,
    pub splat_full: ComputePipeline,
    pub splat_new: ComputePipeline,
    pub resolve_splats: ComputePipeline,
}

pub(crate) fn uniform(binding: u32, visibility: ShaderStages) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

pub(crate) fn storage(
    binding: u32,
    visibility: ShaderStages,
    read_only: bool,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

pub(crate) fn texture(
    binding: u32,
    visibility: ShaderStages,
    sample_type: wgpu::TextureSampleType,
    view_dimension: wgpu::TextureViewDimension,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Texture {
            sample_type,
            view_dimension,
            multisampled: false,
        },
        count: None,
    }
}

pub(crate) const FLOAT: wgpu::TextureSampleType =
    wgpu::TextureSampleType::Float { filterable: false };
pub(crate) const D2: wgpu::TextureViewDimension = wgpu::TextureViewDimension::D2;

pub(crate) fn layout(
    device: &Device,
    label: &str,
    entries: &[wgpu::BindGroupLayoutEntry],
) -> BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(label),
        entries,
    })
}

pub(crate) fn module(device: &Device, label: &str, parts: &[&str]) -> wgpu::ShaderModule {
    device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(parts.concat().into()),
    })
}

pub(crate) fn pipeline_layout(
    device: &Device,
    label: &str,
    groups: &[&BindGroupLayout],
) -> wgpu::PipelineLayout {
    let groups: Vec<Option<&BindGroupLayout>> = groups.iter().map(|g| Some(*g)).collect();
    device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: &groups,
        immediate_size: 0,
    })
}

pub(crate) fn compute(
    device: &Device,
    label: &str,
    layout: &wgpu::PipelineLayout,
    module: &wgpu::ShaderModule,
    entry: &str,
) -> ComputePipeline {
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(label),
        layout: Some(layout),
        module,
        entry_point: Some(entry),
        compilation_options: Default::default(),
        cache: None,
    })
}

struct RenderSpec<'a> {
    label: &'a str,
    layout: &'a wgpu::PipelineLayout,
    module: &'a wgpu::ShaderModule,
    vertex: &'a str,
    fragment: &'a str,
    targets: &'a [Option<wgpu::ColorTargetState>],
    depth: bool,
}

fn render(device: &Device, spec: RenderSpec) -> RenderPipeline {
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(spec.label),
        layout: Some(spec.layout),
        vertex: wgpu::VertexState {
            module: spec.module,
            entry_point: Some(spec.vertex),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: wgpu::PrimitiveState {
            topology: wgpu::PrimitiveTopology::TriangleList,
            front_face: wgpu::FrontFace::Ccw,
            cull_mode: None,
            ..Default::default()
        },
        depth_stencil: spec.depth.then(|| wgpu::DepthStencilState {
            format: DEPTH_FORMAT,
            depth_write_enabled: Some(true),
            // Reversed-Z: nearer is larger.
            depth_compare: Some(wgpu::CompareFunction::Greater),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module: spec.module,
            entry_point: Some(spec.fragment),
            compilation_options: Default::default(),
            targets: spec.targets,
        }),
        multiview_mask: None,
        cache: None,
    })
}

fn target(format: wgpu::TextureFormat) -> Option<wgpu::ColorTargetState> {
    Some(wgpu::ColorTargetState {
        format,
        blend: None,
        write_mask: wgpu::ColorWrites::ALL,
    })
}

impl Pipelines {
    pub fn new(device: &Device) -> Self {
        let vf = ShaderStages::VERTEX | ShaderStages::FRAGMENT;
        let c = ShaderStages::COMPUTE;
        let v = ShaderStages::VERTEX;
        let f = ShaderStages::FRAGMENT;
        let d3 = wgpu::TextureViewDimension::D3;
        // Group 0: frame uniforms, visibility bits (last frame, new this frame), original volume.
        let scene_compute = layout(
            device,
            "scene (compute)",
            &[
                uniform(0, c),
                storage(1, c, false),
                texture(2, c, FLOAT, d3),
                storage(3, c, false),
            ],
        );
        let scene_render = layout(
            device,
            "scene (render)",
            &[
                uniform(0, vf),
                texture(2, vf, FLOAT, d3),
                storage(3, f, false),
            ],
        );
        // Group 1: one page of the grid.
        let page_compute = layout(
            device,
            "page (compute)",
            &[
                uniform(0, c),
                storage(1, c, true),
                storage(2, c, true),
                storage(3, c, false),
                storage(4, c, false),
                storage(5, c, false),
                storage(6, c, false),
            ],
        );
        let page_render = layout(
            device,
            "page (render)",
            &[
                uniform(0, v),
                storage(1, v, true),
                storage(2, v, true),
                storage(3, v, true),
            ],
        );
        let depth_input = layout(
            device,
            "raster depth input",
            &[texture(0, f, wgpu::TextureSampleType::Depth, D2)],
        );
        let surface_input = layout(device, "raster surface input", &[texture(0, f, FLOAT, D2)]);
        let ids_input = layout(
            device,
            "cluster id input",
            &[texture(0, c, wgpu::TextureSampleType::Uint, D2)],
        );
        let shade_inputs = layout(
            device,
            "shading inputs",
            &[
                texture(0, f | c, FLOAT, D2),
                texture(1, f | c, FLOAT, D2),
                texture(2, f | c, wgpu::TextureSampleType::Uint, D2),
            ],
        );
        let mesh = layout(device, "mc mesh", &[uniform(0, v), storage(1, v, true)]);
        let dispatch_args = layout(device, "dispatch arguments", &[storage(0, c, false)]);
        let write_only = |binding, format| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: c,
            ty: wgpu::BindingType::StorageTexture {
                access: wgpu::StorageTextureAccess::WriteOnly,
                format,
                view_dimension: D2,
            },
            count: None,
        };
        let raster_targets = layout(
            device,
            "compute raster targets",
            &[
                storage(0, c, false),
                write_only(1, SURFACE_FORMAT),
                write_only(2, IDS_FORMAT),
            ],
        );
        let ewa_targets = layout(
            device,
            "compute ewa targets",
            &[
                storage(0, c, false),
                texture(1, c, FLOAT, D2),
                write_only(2, EWA_FORMAT),
            ],
        );
        let shade_outputs = layout(
            device,
            "compute shading outputs",
            &[write_only(0, COLOR_FORMAT), write_only(1, FINAL_FORMAT)],
        );

        let expand_module = module(
            device,
            "expand.wgsl",
            &[COMMON, CELL_DATA, include_str!("../shaders/expand.wgsl")],
        );
        let expand_layout = pipeline_layout(device, "expand", &[&scene_compute, &page_compute]);
        let expand_visible = compute(
            device,
            "expand visible clusters",
            &expand_layout,
            &expand_module,
            "expand_visible",
        );
        let expand_new = compute(
            device,
            "expand newly visible clusters",
            &expand_layout,
            &expand_module,
            "expand_new",
        );

        let size_dispatches = compute(
            device,
            "size compute raster dispatches",
            &pipeline_layout(
                device,
                "size dispatches",
                &[&scene_compute, &page_compute, &dispatch_args],
            ),
            &expand_module,
            "size_dispatches",
        );

        let compute_raster_module = module(
            device,
            "cells_compute.wgsl",
            &[
                COMMON,
                CELL_DATA,
                COMPUTE_LISTS,
                CELL_HIT,
                include_str!("../shaders/cells_compute.wgsl"),
            ],
        );
        let compute_raster_layout = pipeline_layout(
            device,
            "compute raster",
            &[&scene_compute, &page_compute, &raster_targets],
        );
        let ewa_compute_module = module(
            device,
            "ewa_compute.wgsl",
            &[
                COMMON,
                CELL_DATA,
                COMPUTE_LISTS,
                EWA_SPLAT,
                include_str!("../shaders/ewa_compute.wgsl"),
            ],
        );
        let ewa_compute_layout = pipeline_layout(
            device,
            "compute ewa",
            &[&scene_compute, &page_compute, &ewa_targets],
        );
        let specialised = |label: &str,
                           layout: &wgpu::PipelineLayout,
                           module: &wgpu::ShaderModule,
                           entry: &str,
                           constants: &[(&str, f64)]| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(label),
                layout: Some(layout),
                module,
                entry_point: Some(entry),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants,
                    ..Default::default()
                },
                cache: None,
            })
        };
        let raster = |label: &str, list: u64, resolve: bool| {
            let constants = [
                ("RASTER_LIST", list as f64),
                ("RASTER_RESOLVE", resolve as u8 as f64),
            ];
            specialised(
                label,
                &compute_raster_layout,
                &compute_raster_module,
                "raster_cells",
                &constants,
            )
        };
        let splat = |label: &str, list: u64| {
            specialised(
                label,
                &ewa_compute_layout,
                &ewa_compute_module,
                "splat_cells",
                &[("EWA_LIST", list as f64)],
            )
        };
        let compute_raster = ComputeRasterPipelines {
            depth_full: raster("compute raster depth (full list)", LIST_FULL, false),
            depth_new: raster("compute raster depth (new list)", LIST_NEW, false),
            resolve_full: raster("compute raster resolve (full list)", LIST_FULL, true),
            resolve_new: raster("compute raster resolve (new list)", LIST_NEW, true),
            probe: compute(
                device,
                "compute raster probes",
                &compute_raster_layout,
                &compute_raster_module,
                "probe_cells",
            ),
            clear: compute(
                device,
                "compute raster clear",
                &compute_raster_layout,
                &compute_raster_module,
                "clear_targets",
            ),
            splat_full: splat("compute ewa splats (full list)", LIST_FULL),
            splat_new: splat("compute ewa splats (new list)", LIST_NEW),
            resolve_splats: compute(
                device,
                "compute ewa resolve",
                &ewa_compute_layout,
                &ewa_compute_module,
                "resolve_splats",
            ),
        };

        let visibility_module = module(
            device,
            "visibility.wgsl",
            &[COMMON, include_str!("../shaders/visibility.wgsl")],
        );
        let visibility_layout =
            pipeline_layout(device, "visibility", &[&scene_compute, &ids_input]);
        let visibility = compute(
            device,
            "visibility update",
            &visibility_layout,
            &visibility_module,
            "update_visibility",
        );

        // The fragment shader writes the crossing's depth, which is never nearer than the
        // rectangle's (the box's nearest corner): declaring that (conservative depth) keeps the
        // early depth test, which rejects cells behind what is already drawn before any sampling.
        let cells_source = include_str!("../shaders/cells.wgsl");
        let cells_source = if device
            .features()
            .contains(wgpu::Features::SHADER_EARLY_DEPTH_TEST)
        {
            cells_source.replace(
                "@fragment\nfn fs_cell",
                "@fragment @early_depth_test(less_equal)\nfn fs_cell",
            )
        } else {
            cells_source.to_string()
        };
        let cells_module = module(
            device,
            "cells.wgsl",
            &[COMMON, CELL_DATA, CELL_HIT, &cells_source],
        );
        let cells_layout = pipeline_layout(device, "cells", &[&scene_render, &page_render]);
        let cells = render(
            device,
            RenderSpec {
                label: "cell raster",
                layout: &cells_layout,
                module: &cells_module,
                vertex: "vs_cell",
                fragment: "fs_cell",
                targets: &[target(SURFACE_FORMAT), target(IDS_FORMAT)],
                depth: true,
            },
        );

        let probe_module = module(
            device,
            "probe.wgsl",
            &[COMMON, CELL_DATA, include_str!("../shaders/probe.wgsl")],
        );
        let probe_layout = pipeline_layout(
            device,
            "probe",
            &[&scene_render, &page_render, &depth_input],
        );
        let probe = render(
            device,
            RenderSpec {
                label: "visibility probes",
                layout: &probe_layout,
                module: &probe_module,
                vertex: "vs_probe",
                fragment: "fs_probe",
                // The pass needs an attachment for its size; probes only write visibility bits.
                targets: &[Some(wgpu::ColorTargetState {
                    format: IDS_FORMAT,
                    blend: None,
                    write_mask: wgpu::ColorWrites::empty(),
                })],
                depth: false,
            },
        );

        let ewa_module = module(
            device,
            "ewa.wgsl",
            &[
                COMMON,
                CELL_DATA,
                EWA_SPLAT,
                include_str!("../shaders/ewa.wgsl"),
            ],
        );
        let ewa_layout = pipeline_layout(
            device,
            "ewa",
            &[&scene_render, &page_render, &surface_input],
        );
        let additive = wgpu::BlendComponent {
            src_factor: wgpu::BlendFactor::One,
            dst_factor: wgpu::BlendFactor::One,
            operation: wgpu::BlendOperation::Add,
        };
        let ewa = render(
            device,
            RenderSpec {
                label: "ewa normal splats",
                layout: &ewa_layout,
                module: &ewa_module,
                vertex: "vs_splat",
                fragment: "fs_splat",
                targets: &[Some(wgpu::ColorTargetState {
                    format: EWA_FORMAT,
                    blend: Some(wgpu::BlendState {
                        color: additive,
                        alpha: additive,
                    }),
                    write_mask: wgpu::ColorWrites::ALL,
                })],
                depth: false,
            },
        );

        let shade_module = module(
            device,
            "shade.wgsl",
            &[COMMON, include_str!("../shaders/shade.wgsl")],
        );
        let shade_layout = pipeline_layout(device, "shade", &[&scene_render, &shade_inputs]);
        let shade = render(
            device,
            RenderSpec {
                label: "deferred shading",
                layout: &shade_layout,
                module: &shade_module,
                vertex: "vs_fullscreen",
                fragment: "fs_shade",
                targets: &[target(COLOR_FORMAT), target(FINAL_FORMAT)],
                depth: false,
            },
        );
        let shade_compute = compute(
            device,
            "deferred shading (compute)",
            &pipeline_layout(
                device,
                "shade (compute)",
                &[&scene_compute, &shade_inputs, &shade_outputs],
            ),
            &shade_module,
            "shade_pixels",
        );

        let mesh_module = module(
            device,
            "mesh.wgsl",
            &[COMMON, include_str!("../shaders/mesh.wgsl")],
        );
        let mesh_layout = pipeline_layout(device, "mesh", &[&scene_render, &mesh]);
        let mesh_pipeline = render(
            device,
            RenderSpec {
                label: "mc mesh raster",
                layout: &mesh_layout,
                module: &mesh_module,
                vertex: "vs_mesh",
                fragment: "fs_mesh",
                targets: &[target(SURFACE_FORMAT), target(IDS_FORMAT)],
                depth: true,
            },
        );

        Pipelines {
            scene_compute,
            scene_render,
            page_compute,
            page_render,
            depth_input,
            surface_input,
            ids_input,
            shade_inputs,
            mesh,
            dispatch_args,
            raster_targets,
            ewa_targets,
            expand_visible,
            expand_new,
            size_dispatches,
            compute_raster,
            visibility,
            cells,
            probe,
            ewa,
            shade,
            shade_outputs,
            shade_compute,
            mesh_pipeline,
            trace: crate::pathtrace::TracePipelines::new(device),
        }
    }
}
