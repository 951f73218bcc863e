//! GPU pass timings: the timestamp slots of one frame, the queries each pass writes, and the
//! per-pass medians over frames reported as [`PassTimings`].

use crate::error::GpuError;
use crate::output::PassTimings;
use crate::wgpu_util::Gpu;
use std::cell::Cell;

// Timestamp slots of one frame: begin/end of each pass.
pub(super) const TS_EXPAND: u32 = 0;
pub(super) const TS_RASTER: u32 = 2;
pub(super) const TS_PROBE: u32 = 4;
pub(super) const TS_EXPAND_NEW: u32 = 6;
pub(super) const TS_RASTER_NEW: u32 = 8;
pub(super) const TS_EWA: u32 = 10;
pub(super) const TS_VISIBILITY: u32 = 12;
pub(super) const TS_SHADE: u32 = 14;
pub(super) const TS_TRACE: u32 = 16;
const TS_PER_FRAME: u32 = 18;
/// Passes with timestamp slots.
const TIMED_PASSES: usize = (TS_PER_FRAME / 2) as usize;
/// Frames whose timestamps are kept.
const TIMED_FRAMES: u32 = 64;

/// The timestamp queries of one render call's first (up to [`TIMED_FRAMES`]) frames.
pub(super) struct Timestamps {
    set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    readback: wgpu::Buffer,
    /// Frames with timestamp slots.
    frames: u32,
}

impl Timestamps {
    /// Records the resolve of every timed frame's queries and their copy to the read-back buffer;
    /// once, after the last frame.
    pub fn resolve(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.resolve_query_set(&self.set, 0..TS_PER_FRAME * self.frames, &self.resolve, 0);
        encoder.copy_buffer_to_buffer(&self.resolve, 0, &self.readback, 0, self.resolve.size());
    }
}

/// Hands out the current frame's timestamp writes per pass and remembers which passes ran.
pub(super) struct PassClock<'q> {
    timestamps: Option<&'q Timestamps>,
    /// The current frame's first slot; `None` for frames past the timed ones.
    base: Cell<Option<u32>>,
    ran: Cell<[bool; TIMED_PASSES]>,
}

impl<'q> PassClock<'q> {
    pub fn new(timestamps: Option<&'q Timestamps>) -> Self {
        PassClock {
            timestamps,
            base: Cell::new(None),
            ran: Cell::new([false; TIMED_PASSES]),
        }
    }

    pub fn start_frame(&self, f: u32) {
        self.base
            .set((f < TIMED_FRAMES).then_some(f * TS_PER_FRAME));
    }

    /// The query set and begin slot of the pass timed in `slot`, marking that pass as run.
    fn slot(&self, slot: u32) -> Option<(&'q wgpu::QuerySet, u32)> {
        let mut ran = self.ran.get();
        ran[(slot / 2) as usize] = true;
        self.ran.set(ran);
        self.timestamps
            .zip(self.base.get())
            .map(|(t, base)| (&t.set, base + slot))
    }

    pub fn render(&self, slot: u32) -> Option<wgpu::RenderPassTimestampWrites<'q>> {
        self.slot(slot)
            .map(|(query_set, begin)| wgpu::RenderPassTimestampWrites {
                query_set,
                beginning_of_pass_write_index: Some(begin),
                end_of_pass_write_index: Some(begin + 1),
            })
    }

    pub fn compute(&self, slot: u32) -> Option<wgpu::ComputePassTimestampWrites<'q>> {
        self.slot(slot)
            .map(|(query_set, begin)| wgpu::ComputePassTimestampWrites {
                query_set,
                beginning_of_pass_write_index: Some(begin),
                end_of_pass_write_index: Some(begin + 1),
            })
    }
}

impl Timestamps {
    /// Timestamp queries for the first frames of `frames`, where the device has them.
    pub fn new(gpu: &Gpu, frames: u32) -> Option<Timestamps> {
        let timed_frames = frames.min(TIMED_FRAMES);
        gpu.timestamps.then(|| {
            let count = TS_PER_FRAME * timed_frames;
            let set = gpu.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("pass timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count,
            });
            let resolve = gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamp resolve"),
                size: 8 * count as u64,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            let readback = gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamp readback"),
                size: 8 * count as u64,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            Timestamps {
                set,
                resolve,
                readback,
                frames: timed_frames,
            }
        })
    }
}

/// Reads the resolved timestamps back into per-pass medians; empty without timestamps.
pub(super) fn read_timings(
    gpu: &Gpu,
    timestamps: Option<&Timestamps>,
    clock: &PassClock<'_>,
) -> Result<PassTimings, GpuError> {
    Ok(match timestamps {
        Some(t) => {
            let ticks: Vec<u64> = bytemuck::pod_collect_to_vec(&gpu.read_buffer(&t.readback)?);
            let period_ms = gpu.queue.get_timestamp_period() as f64 * 1e-6;
            pass_timings(period_ms, &ticks, t.frames, &clock.ran.get())
        }
        None => PassTimings::default(),
    })
}

fn pass_timings(
    period_ms: f64,
    ticks: &[u64],
    frames: u32,
    ran: &[bool; TIMED_PASSES],
) -> PassTimings {
    // Frames after the first (the first one draws every cluster), unless there is only one.
    let frames: Vec<u32> = if frames > 1 {
        (1..frames).collect()
    } else {
        vec![0]
    };
    let pass = |slot: u32, f: u32| -> Option<f64> {
        if !ran[(slot / 2) as usize] {
            return None;
        }
        let base = (f * TS_PER_FRAME + slot) as usize;
        let (a, b) = (*ticks.get(base)?, *ticks.get(base + 1)?);
        Some(b.saturating_sub(a) as f64 * period_ms)
    };
    let sum = |slots: &[u32]| -> Option<f64> {
        let per_frame: Vec<f64> = frames
            .iter()
            .filter_map(|&f| {
                let times: Vec<f64> = slots.iter().filter_map(|&s| pass(s, f)).collect();
                (!times.is_empty()).then(|| times.iter().sum())
            })
            .collect();
        median(per_frame)
    };
    let span = median(
        frames
            .iter()
            .filter_map(|&f| {
                let ran_slots: Vec<u32> = (0..TIMED_PASSES as u32)
                    .filter(|&i| ran[i as usize])
                    .map(|i| 2 * i)
                    .collect();
                let first = ticks.get((f * TS_PER_FRAME + *ran_slots.first()?) as usize)?;
                let last = ticks.get((f * TS_PER_FRAME + *ran_slots.last()? + 1) as usize)?;
                Some(last.saturating_sub(*first) as f64 * period_ms)
            })
            .collect(),
    );
    PassTimings {
        raster_ms: sum(&[TS_RASTER, TS_RASTER_NEW, TS_EWA]),
        ewa_ms: sum(&[TS_EWA]),
        shade_ms: sum(&[TS_SHADE]),
        cull_ms: sum(&[TS_EXPAND, TS_PROBE, TS_EXPAND_NEW, TS_VISIBILITY]),
        frame_ms: span,
        trace_ms: sum(&[TS_TRACE]),
    }
}

fn median(mut v: Vec<f64>) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    Some(v[v.len() / 2])
}
