//! A request is checked from its parts before anything runs, with one-line errors of the
//! library's kinds.

use isogrid::ErrorKind;
use isogrid_render::{
    cpu_draws, Aov, Backend, CameraSpec, EnvSource, Mode, Primary, RenderRequest, RequestParts,
    MAX_BOUNCES,
};

fn refused(parts: RequestParts, kind: ErrorKind, mention: &str) {
    let err = RenderRequest::new(parts.clone()).expect_err(&format!("{parts:?} should fail"));
    assert_eq!(err.kind(), kind, "{err}");
    let text = err.to_string();
    assert!(text.contains(mention), "{text} should mention {mention}");
    assert_eq!(text.lines().count(), 1, "{text}");
}

#[test]
fn consistent_parts_make_a_request() {
    for mode in Mode::ALL {
        let backend = if cpu_draws(mode) {
            Backend::Cpu
        } else {
            Backend::Gpu
        };
        let r = RenderRequest::new(RequestParts {
            mode,
            backend,
            size: (64, 48),
            aovs: vec![Aov::Depth, Aov::Cluster],
            ..RequestParts::default()
        })
        .unwrap();
        assert_eq!(
            (r.mode(), r.backend(), r.width(), r.height()),
            (mode, backend, 64, 48)
        );
    }
    // A look-at camera keeps the request's size; a view frames the grid's box.
    let look = CameraSpec::LookAt {
        eye: [0.0, 0.0, 10.0],
        target: [0.0; 3],
        up: [0.0, 1.0, 0.0],
        fovy_degrees: 30.0,
    };
    let r = RenderRequest::new(RequestParts {
        camera: look,
        size: (20, 10),
        ..RequestParts::default()
    })
    .unwrap();
    let c = r.camera(([0.0; 3], [1.0; 3]), None, false).unwrap();
    assert_eq!((c.width, c.height, c.eye), (20, 10, [0.0, 0.0, 10.0]));
    assert!(!c.mirrored);
    // A grid whose axes mirror its world gets the same camera, mirrored.
    let m = r.camera(([0.0; 3], [1.0; 3]), None, true).unwrap();
    assert_eq!(
        m,
        isogrid::Camera {
            mirrored: true,
            ..c
        }
    );
    // A standard view frames the grid's box, a surface view the surface's (the grid's when the
    // surface is empty), whichever box is the larger.
    let (grid_box, surface_box) = (([0.0; 3], [40.0; 3]), ([5.0, 6.0, 7.0], [9.0, 8.0, 20.0]));
    let preset =
        |(lo, hi): ([f64; 3], [f64; 3])| isogrid::Camera::preset(2, lo, hi, 20, 10).unwrap();
    for (camera, surface, framed) in [
        (CameraSpec::View(2), Some(surface_box), grid_box),
        (CameraSpec::SurfaceView(2), Some(surface_box), surface_box),
        (CameraSpec::SurfaceView(2), None, grid_box),
    ] {
        let r = RenderRequest::new(RequestParts {
            camera: camera.clone(),
            size: (20, 10),
            ..RequestParts::default()
        })
        .unwrap();
        assert_eq!(
            r.camera(grid_box, surface, false).unwrap(),
            preset(framed),
            "{camera:?}"
        );
    }
    assert_ne!(preset(grid_box), preset(surface_box));
}

#[test]
fn inconsistent_parts_are_refused_before_anything_runs() {
    let base = RequestParts {
        size: (32, 32),
        ..RequestParts::default()
    };
    let invalid = ErrorKind::InvalidInput;
    refused(
        RequestParts {
            size: (0, 10),
            ..base.clone()
        },
        invalid,
        "0x10",
    );
    refused(
        RequestParts {
            size: (1 << 15, 1 << 14),
            ..base.clone()
        },
        invalid,
        "pixels",
    );
    refused(
        RequestParts {
            camera: CameraSpec::View(3),
            ..base.clone()
        },
        invalid,
        "view 3",
    );
    refused(
        RequestParts {
            camera: CameraSpec::SurfaceView(0),
            ..base.clone()
        },
        invalid,
        "view 0",
    );
    refused(
        RequestParts {
            camera: CameraSpec::LookAt {
                eye: [0.0, 0.0, 5.0],
                target: [0.0; 3],
                up: [0.0, 0.0, 1.0],
                fovy_degrees: 40.0,
            },
            ..base.clone()
        },
        invalid,
        "parallel",
    );
    refused(
        RequestParts {
            samples: 0,
            ..base.clone()
        },
        invalid,
        "samples",
    );
    refused(
        RequestParts {
            frames: 0,
            ..base.clone()
        },
        invalid,
        "frames",
    );
    refused(
        RequestParts {
            mode: Mode::PathTrace,
            bounces: MAX_BOUNCES + 1,
            ..base.clone()
        },
        invalid,
        "bounces",
    );
    for mode in [Mode::CgcNoEwa, Mode::Mc, Mode::Cr] {
        refused(
            RequestParts {
                mode,
                backend: Backend::Cpu,
                ..base.clone()
            },
            invalid,
            "GPU",
        );
    }
    refused(
        RequestParts {
            primary: Some(Primary::Traced),
            ..base.clone()
        },
        invalid,
        "primary",
    );
    refused(
        RequestParts {
            mode: Mode::PathTrace,
            backend: Backend::Cpu,
            primary: Some(Primary::Raster),
            ..base.clone()
        },
        invalid,
        "primary",
    );
    refused(
        RequestParts {
            environment: EnvSource::Map("sky.hdr".into()),
            ..base.clone()
        },
        invalid,
        "path tracing",
    );
    refused(
        RequestParts {
            aovs: vec![Aov::Normal, Aov::Normal],
            ..base.clone()
        },
        invalid,
        "twice",
    );
    // The environment map is read with the request: a missing one names its file.
    let missing = std::env::temp_dir().join("isogrid-render-no-such-map.hdr");
    let err = RenderRequest::new(RequestParts {
        mode: Mode::PathTrace,
        environment: EnvSource::Map(missing.clone()),
        ..base.clone()
    })
    .unwrap_err();
    assert!(
        err.to_string().contains("isogrid-render-no-such-map.hdr"),
        "{err}"
    );
}

#[test]
fn names_parse_back() {
    for mode in Mode::ALL {
        assert_eq!(mode.name().parse::<Mode>().unwrap(), mode);
        assert_eq!(mode.to_string(), mode.name());
    }
    for backend in [Backend::Auto, Backend::Cpu, Backend::Gpu] {
        assert_eq!(backend.name().parse::<Backend>().unwrap(), backend);
    }
    for aov in Aov::ALL {
        assert_eq!(aov.name().parse::<Aov>().unwrap(), aov);
    }
    assert_eq!("TRACED".parse::<Primary>().unwrap(), Primary::Traced);
    assert!("wireframe"
        .parse::<Mode>()
        .unwrap_err()
        .to_string()
        .contains("mode"));
    assert!("tpu"
        .parse::<Backend>()
        .unwrap_err()
        .to_string()
        .contains("backend"));
    assert_eq!(EnvSource::parse("SKY"), EnvSource::Sky);
    assert_eq!(EnvSource::parse("a.hdr"), EnvSource::Map("a.hdr".into()));
}
