//! The backend policy, with the adapter lookup replaced by each case's answer: `cpu` never asks,
//! `gpu` needs an adapter, `auto` prefers a hardware adapter, weighs a software one by the
//! measured rule, and falls back to the CPU only for modes it has.

use isogrid::ErrorKind;
use isogrid_render::policy::software_adapter_wins;
use isogrid_render::{
    cpu_draws, decide, AdapterSummary, Backend, Mode, Placement, Primary, RenderRequest,
    RequestParts,
};

fn request(mode: Mode, backend: Backend, primary: Option<Primary>) -> RenderRequest {
    RenderRequest::new(RequestParts {
        mode,
        backend,
        primary,
        size: (320, 240),
        ..RequestParts::default()
    })
    .unwrap()
}

fn adapter(software: bool) -> Option<AdapterSummary> {
    Some(AdapterSummary {
        name: if software {
            "llvmpipe (Vulkan)"
        } else {
            "H100 (Vulkan)"
        }
        .into(),
        software,
    })
}

fn never() -> Option<AdapterSummary> {
    panic!("the adapter was looked up although the answer could not matter")
}

#[test]
fn cpu_never_looks_for_an_adapter() {
    for mode in [Mode::Cgc, Mode::PathTrace] {
        let d = decide(&request(mode, Backend::Cpu, None), never).unwrap();
        assert_eq!((d.placement, d.note), (Placement::Cpu, None));
    }
}

#[test]
fn gpu_takes_any_adapter_and_fails_without_one() {
    for software in [false, true] {
        let d = decide(&request(Mode::PathTrace, Backend::Gpu, None), || {
            adapter(software)
        });
        assert_eq!(d.unwrap().placement, Placement::Gpu);
    }
    let err = decide(&request(Mode::Cgc, Backend::Gpu, None), || None).unwrap_err();
    assert_eq!(err.kind(), ErrorKind::Unsupported);
    assert!(err.to_string().contains("no"), "{err}");
}

#[test]
fn auto_prefers_hardware_and_falls_back_to_the_cpu_where_it_can() {
    for mode in Mode::ALL {
        let r = request(mode, Backend::Auto, None);
        assert_eq!(
            decide(&r, || adapter(false)).unwrap().placement,
            Placement::Gpu
        );
        match decide(&r, || None) {
            Ok(d) => {
                assert!(cpu_draws(mode), "{mode}");
                assert_eq!(d.placement, Placement::Cpu);
                assert!(d.note.unwrap().contains("no GPU adapter"));
            }
            Err(e) => {
                assert!(!cpu_draws(mode), "{mode}: {e}");
                assert!(e.to_string().contains(mode.name()), "{e}");
            }
        }
    }
    // Naming the primary rays asks for the GPU path tracer, which has no CPU stand-in.
    let traced = request(Mode::PathTrace, Backend::Auto, Some(Primary::Traced));
    assert_eq!(
        decide(&traced, || adapter(true)).unwrap().placement,
        Placement::Gpu
    );
    assert!(decide(&traced, || None)
        .unwrap_err()
        .to_string()
        .contains("traced"));
}

#[test]
fn auto_on_a_software_adapter_follows_the_measured_rule() {
    for mode in Mode::ALL {
        let r = request(mode, Backend::Auto, None);
        let d = decide(&r, || adapter(true)).unwrap();
        let expected = if !cpu_draws(mode) || software_adapter_wins(mode) {
            Placement::Gpu
        } else {
            Placement::Cpu
        };
        assert_eq!(d.placement, expected, "{mode}");
        if d.placement == Placement::Cpu {
            assert!(d.note.unwrap().contains("llvmpipe"));
        }
    }
}
