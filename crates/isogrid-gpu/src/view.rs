//! [`ViewState`]: what one view of an uploaded grid keeps between frames — the cluster visibility
//! bits of the visibility buffer (paper §3.3), the frame counter that rotates the probe cells, and
//! the path tracer's accumulated samples (§3.6). Kept apart from the [`GpuGrid`], so that one
//! uploaded grid can be drawn by several views (windows, cameras) without them resetting each
//! other.

use crate::error::GpuError;
use crate::upload::GpuGrid;
use crate::wgpu_util::Gpu;

/// Clusters the visibility buffers hold at least (the paper's 1M, 128 KiB per buffer).
const MIN_VISIBILITY_CLUSTERS: u64 = 1 << 20;

/// The state of one view across render calls ([`crate::Renderer::render_view`],
/// [`crate::Renderer::path_trace_view`]): visibility persists while the grid, camera, mode and
/// culling options stay the same, and path-traced samples accumulate while the grid, camera,
/// bounces, albedo, environment and primary rays do; anything else starts that part afresh.
/// Created empty; its buffers are allocated on first use.
#[derive(Default)]
pub struct ViewState {
    visibility: Option<Visibility>,
    /// What the visibility bits were last computed for.
    visibility_key: Option<String>,
    /// Frames drawn so far; picks each frame's probe cell (`expand.wgsl`).
    frame_index: u32,
    pub(crate) accumulation: Option<Accumulation>,
}

/// The two cluster visibility buffers (bit per cluster): visible last frame, and newly found
/// visible by this frame's probes. Clones share the buffers.
#[derive(Clone)]
pub(crate) struct Visibility {
    pub last_frame: wgpu::Buffer,
    pub new: wgpu::Buffer,
    bytes: u64,
}

/// Running per-pixel sums of one path-traced view.
pub(crate) struct Accumulation {
    pub key: String,
    pub sum: wgpu::Buffer,
    pub samples: u32,
}

impl ViewState {
    pub fn new() -> ViewState {
        ViewState::default()
    }

    /// Forgets the visibility of earlier frames: the next frame draws every cluster fully.
    pub fn reset_visibility(&mut self) {
        self.visibility_key = None;
    }

    /// The visibility buffers (shared) for drawing `grid` with the view and options `key` names: kept
    /// from the last call when it drew the same, else (re)allocated to the grid's clusters as
    /// needed and reset to "every cluster visible", so that the first frame is complete.
    pub(crate) fn visibility_for(
        &mut self,
        gpu: &Gpu,
        grid: &GpuGrid,
        key: String,
    ) -> Result<Visibility, GpuError> {
        let key = format!("grid {} {key}", grid.id);
        let bytes = grid.clusters().max(MIN_VISIBILITY_CLUSTERS).div_ceil(32) * 4;
        if self.visibility.as_ref().is_none_or(|v| v.bytes != bytes) {
            let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
            self.visibility = Some(Visibility {
                last_frame: gpu.buffer("visible clusters (last frame)", bytes, usage)?,
                new: gpu.buffer("newly visible clusters", bytes, usage)?,
                bytes,
            });
            self.visibility_key = None;
        }
        let visibility = self.visibility.as_ref().expect("allocated above");
        if self.visibility_key.as_deref() != Some(key.as_str()) {
            gpu.queue
                .write_buffer(&visibility.last_frame, 0, &vec![0xffu8; bytes as usize]);
            gpu.queue
                .write_buffer(&visibility.new, 0, &vec![0u8; bytes as usize]);
            self.visibility_key = Some(key);
        }
        Ok(visibility.clone())
    }

    /// The index of the first of `frames` frames about to be drawn, counting them as drawn.
    pub(crate) fn take_frames(&mut self, frames: u32) -> u32 {
        let first = self.frame_index;
        self.frame_index = self.frame_index.wrapping_add(frames);
        first
    }
}
