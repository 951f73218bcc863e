//! Opening the native window (size, renderer, drag and drop) and turning a scripted run's
//! failure into the caller's error once the window has closed.

use super::state::{App, MEASUREMENTS_WIDTH, PANEL_WIDTH};
use crate::ViewerOptions;
use eframe::egui;
use isogrid::Error;
use std::sync::{Arc, Mutex};

pub fn run(options: ViewerOptions) -> isogrid::Result<()> {
    crate::logging::init();
    let failure: Arc<Mutex<Option<String>>> = Arc::default();
    let inner_size = match options.size {
        // Room for the image at one pixel per point next to the panel.
        Some([w, h]) => [
            w as f32 + PANEL_WIDTH + MEASUREMENTS_WIDTH + 64.0,
            (h as f32 + 24.0).max(640.0),
        ],
        None => [1280.0, 800.0],
    };
    let native = eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default()
            .with_title("isogrid view")
            .with_inner_size(inner_size)
            .with_drag_and_drop(true),
        renderer: eframe::Renderer::Wgpu,
        wgpu_options: window_wgpu_options(),
        ..Default::default()
    };
    let app_failure = failure.clone();
    eframe::run_native(
        "isogrid view",
        native,
        Box::new(move |cc| Ok(Box::new(App::new(&cc.egui_ctx, options, app_failure)))),
    )
    .map_err(|e| Error::unsupported(format!("cannot open the viewer window: {e}")))?;
    let failed = failure.lock().ok().and_then(|mut f| f.take());
    match failed {
        Some(message) => Err(Error::invalid(message)),
        None => Ok(()),
    }
}

/// egui's defaults, but on the same backends as the renderer ([`isogrid_gpu::preferred_backends`]):
/// egui alone would also open GL, whose Mesa driver can crash the process at exit.
fn window_wgpu_options() -> eframe::egui_wgpu::WgpuConfiguration {
    use eframe::egui_wgpu::{WgpuConfiguration, WgpuSetup, WgpuSetupCreateNew};
    let mut setup = WgpuSetupCreateNew::without_display_handle();
    setup.instance_descriptor.backends = isogrid_gpu::preferred_backends();
    WgpuConfiguration {
        wgpu_setup: WgpuSetup::CreateNew(setup),
        ..Default::default()
    }
}
