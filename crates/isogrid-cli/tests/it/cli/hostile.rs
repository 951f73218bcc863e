//! Requests a hostile-input probe found mishandled: sizes the arguments accept but memory does
//! not, special files, misleading messages, silently ignored options, and outputs that would
//! destroy inputs or each other. Each fails with one clear line, quickly, allocating little.

use super::{fails, generated, isogrid, s, temp_dir};
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Runs the binary with `ISOGRID_MEMORY_LIMIT` set.
fn with_memory_limit(limit: &str, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_isogrid"))
        .args(args)
        .env("ISOGRID_MEMORY_LIMIT", limit)
        .output()
        .expect("runs the binary")
}

fn one_line_error(out: &Output, mention: &str) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "should fail: {stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains(mention),
        "{stderr} should mention {mention}"
    );
}

/// Runs the binary, killing it after `limit`: a hang fails the test instead of stalling it.
fn within(limit: Duration, args: &[&str]) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_isogrid"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > limit {
            child.kill().unwrap();
            panic!("{args:?} still running after {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

/// A generated sphere volume of `size`³ in `dir` and its grid `s.cgc`.
fn sphere_grid(dir: &std::path::Path, size: u32) -> (std::path::PathBuf, std::path::PathBuf) {
    let volume = generated(dir, "sphere", size);
    let cgc = dir.join("s.cgc");
    super::extracted_at_half(&volume, &cgc);
    (volume, cgc)
}

#[test]
fn sizes_the_arguments_accept_are_checked_against_memory() {
    let dir = temp_dir("memory");
    let (_, cgc) = sphere_grid(&dir, 16);
    // 512³ = 128 MiB against a 64 MiB limit (the probe's 1600³ against the machine's memory).
    let out = with_memory_limit(
        "64M",
        &[
            "generate",
            "sphere",
            "--size",
            "512",
            "-o",
            s(&dir.join("big.nrrd")),
        ],
    );
    one_line_error(
        &out,
        "a 512³ u8 volume needs 128.0 MiB of memory but ISOGRID_MEMORY_LIMIT is 64.0 MiB",
    );
    assert!(!dir.join("big.nrrd").exists());
    for backend in ["cpu", "auto"] {
        let out = with_memory_limit(
            "1G",
            &[
                "render",
                s(&cgc),
                "--backend",
                backend,
                "--size",
                "8192x8192",
                "-o",
                s(&dir.join("r.png")),
            ],
        );
        one_line_error(
            &out,
            "a 8192x8192 render needs 8.0 GiB of memory but ISOGRID_MEMORY_LIMIT is 1.0 GiB",
        );
    }
    let out = with_memory_limit("1G", &["bench", "rays", s(&cgc), "--rays", "100000000"]);
    one_line_error(&out, "100000000 rays needs");
    one_line_error(&out, "ISOGRID_MEMORY_LIMIT is 1.0 GiB");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn special_files_are_refused_not_waited_on() {
    let dir = temp_dir("special");
    // An empty folder is no volume (no DICOM series, no Zarr store, no TIFF slices).
    let out = within(Duration::from_secs(30), &["info", s(&dir)]);
    one_line_error(&out, &dir.display().to_string());
    // A URL is a Zarr store to describe; one that does not answer is an error naming it.
    let out = within(
        Duration::from_secs(30),
        &["info", "https://127.0.0.1:9/image.ome.zarr"],
    );
    one_line_error(&out, "https://127.0.0.1:9/image.ome.zarr");
    #[cfg(unix)]
    {
        let fifo = dir.join("fifo.cgc");
        assert!(Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap()
            .success());
        let out = within(Duration::from_secs(30), &["info", s(&fifo)]);
        one_line_error(&out, "is a pipe or FIFO");
        // A valid NRRD through a pipe: refused as a pipe, not misread.
        let volume = generated(&dir, "sphere", 8);
        let mut child = Command::new(env!("CARGO_BIN_EXE_isogrid"))
            .args(["extract", "/dev/stdin", "--iso", "100"])
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let bytes = std::fs::read(&volume).unwrap();
        let mut stdin = child.stdin.take().unwrap();
        // The writer may see a closed pipe once the reader refuses it.
        let _ = std::io::Write::write_all(&mut stdin, &bytes);
        drop(stdin);
        let out = child.wait_with_output().unwrap();
        one_line_error(&out, "is a pipe or FIFO");
    }
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn messages_say_what_is_wrong() {
    let dir = temp_dir("messages");
    let (volume, cgc) = sphere_grid(&dir, 12);

    let out = isogrid(&["extract", s(&volume), "--iso", "100", "--threads", "3000"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && stderr.contains("1..=1024"),
        "{stderr}"
    );

    // Negative isovalues parse, infinite ones parse and are then refused.
    assert!(isogrid(&["extract", s(&volume), "--iso", "-5"])
        .status
        .success());
    fails(
        &["extract", s(&volume), "--iso", "-inf"],
        "isovalue -inf is not a finite number",
    );
    fails(&["mc", s(&volume), "--iso", "-inf"], "sphere.nrrd");

    fails(
        &[
            "render",
            s(&cgc),
            "--backend",
            "cpu",
            "--camera",
            "1e200,0,0:0,0,0:0,1,0:40",
        ],
        "camera eye coordinate 1e200 is beyond",
    );
    let out = isogrid(&["render", s(&cgc), "--size", "20000x20000"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && stderr.contains("at most 268435456"),
        "{stderr}"
    );
    fails(
        &["render", s(&cgc), "--backend", "cpu", "--precision", "4"],
        "a .cgc file has its precision already",
    );

    // ±∞ samples: the normalised isovalue comes from the finite ones.
    let header =
        "NRRD0004\ntype: float\ndimension: 3\nsizes: 4 4 4\nencoding: raw\nendian: little\n\n";
    let mut data: Vec<f32> = (0..64).map(|i| (i % 4) as f32).collect();
    data[5] = f32::INFINITY;
    data[6] = f32::NEG_INFINITY;
    let inf = dir.join("inf.nrrd");
    let bytes: Vec<u8> = header
        .bytes()
        .chain(data.iter().flat_map(|v| v.to_le_bytes()))
        .collect();
    std::fs::write(&inf, bytes).unwrap();
    let out = isogrid(&["extract", s(&inf), "--iso-normalized", "0.5", "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(report["iso"].as_f64(), Some(1.5), "{report}");
    let all_inf: Vec<u8> = header
        .bytes()
        .chain((0..64).flat_map(|i| {
            if i % 2 == 0 {
                f32::INFINITY
            } else {
                f32::NEG_INFINITY
            }
            .to_le_bytes()
        }))
        .collect();
    std::fs::write(&inf, all_inf).unwrap();
    fails(
        &["extract", s(&inf), "--iso-normalized", "0.5"],
        "no finite sample (all are NaN or infinite)",
    );

    // Voxelisation errors name the mesh.
    let flat = dir.join("flat.obj");
    std::fs::write(&flat, "v 0 0 0\nv 0 0 0\nv 0 0 0\nf 1 2 3\n").unwrap();
    fails(
        &[
            "voxelize",
            s(&flat),
            "--resolution",
            "8",
            "-o",
            s(&dir.join("flat.nrrd")),
        ],
        "flat.obj",
    );
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn outputs_never_overwrite_inputs_or_each_other() {
    let dir = temp_dir("outputs");
    let volume = generated(&dir, "sphere", 12);
    let before = std::fs::read(&volume).unwrap();
    fails(
        &["extract", s(&volume), "--iso", "100", "-o", s(&volume)],
        "would overwrite the input",
    );
    // Another spelling of the same file.
    let dotted = dir.join(".").join("sphere.nrrd");
    fails(
        &["extract", s(&volume), "--iso", "100", "-o", s(&dotted)],
        "would overwrite the input",
    );
    assert_eq!(std::fs::read(&volume).unwrap(), before, "input changed");

    fails(
        &[
            "extract",
            s(&volume),
            "--iso",
            "100",
            "-o",
            s(&dir.join("out.png")),
        ],
        "must end in .cgc",
    );
    fails(
        &[
            "generate",
            "sphere",
            "--size",
            "8",
            "-o",
            s(&dir.join("out.npy")),
        ],
        "must end in .nrrd",
    );
    assert!(!dir.join("out.png").exists() && !dir.join("out.npy").exists());

    let cgc = dir.join("s.cgc");
    assert!(
        isogrid(&["extract", s(&volume), "--iso", "100", "-o", s(&cgc)])
            .status
            .success()
    );
    // A small CPU render of the grid with these outputs must fail naming `mention`.
    let render_fails = |outputs: &[&str], mention: &str| {
        let args = ["render", s(&cgc), "--backend", "cpu", "--size", "8x8"];
        fails(&[&args[..], outputs].concat(), mention);
    };
    let image = dir.join("rr.png");
    render_fails(
        &["--aov", &format!("depth={}", s(&image)), "-o", s(&image)],
        "must end in .npy",
    );
    let aov = dir.join("a.npy");
    render_fails(
        &["--aov", &format!("depth={0},normal={0}", s(&aov))],
        "named for both the depth AOV and the normal AOV",
    );
    render_fails(
        &[
            "-o",
            s(&dir.join("s.cgc.png")),
            "--aov",
            &format!("depth={}", s(&cgc)),
        ],
        "the depth AOV would overwrite the input",
    );
    assert!(!image.exists() && !aov.exists());
    // An input whose name fits the output's format: the rays file given as --t-out.
    let rays = dir.join("rays.npy");
    let ray: Vec<u8> = [0f32, 0., 0., 1., 0., 0.]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    std::fs::write(&rays, &ray).unwrap();
    fails(
        &[
            "bench",
            "rays",
            s(&cgc),
            "--rays-file",
            s(&rays),
            "--t-out",
            s(&rays),
        ],
        "the hit distances would overwrite the input",
    );
    assert_eq!(std::fs::read(&rays).unwrap(), ray);
    std::fs::remove_dir_all(dir).unwrap();
}

/// The names of the files in `dir`.
fn names_in(dir: &std::path::Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect()
}

/// A file-size limit makes the write fail with EFBIG: the error is reported and the temporary
/// file removed (the default action of SIGXFSZ would kill the process and leave it behind).
#[cfg(unix)]
#[test]
fn a_file_size_limit_leaves_no_temporary_file() {
    let dir = temp_dir("fsize");
    let out_path = dir.join("big.nrrd");
    // `ulimit -f 16`: 8 or 16 KiB depending on the shell's block size; the volume is 256 KiB.
    let out = Command::new("sh")
        .arg("-c")
        .arg(format!(
            "ulimit -f 16 && exec \"$0\" generate sphere --size 64 -o '{}'",
            s(&out_path)
        ))
        .arg(env!("CARGO_BIN_EXE_isogrid"))
        .output()
        .unwrap();
    one_line_error(&out, "big.nrrd");
    let left = names_in(&dir);
    assert!(left.is_empty(), "left behind: {left:?}");
    std::fs::remove_dir_all(dir).unwrap();
}

/// Ctrl-C during a write: the process ends by the signal, and its temporary file goes with it.
#[cfg(unix)]
#[test]
fn an_interrupt_during_a_write_leaves_no_temporary_file() {
    a_signal_during_a_write_leaves_no_temporary_file("interrupt", libc::SIGINT);
}

/// Whether `isogrid info` reads the grid file `path`.
#[cfg(unix)]
fn isogrid_info_reads(path: &std::path::Path) -> bool {
    isogrid(&["info", s(path)]).status.success()
}

/// SIGABRT (an allocation failure aborts) and SIGBUS (a memory-mapped input truncated under the
/// reader) end the process in the thread that failed, where no interrupt thread can help: its
/// handler still removes the temporary file of the write in progress, and the process ends by
/// the signal.
#[cfg(unix)]
#[test]
fn abort_and_bus_errors_during_a_write_leave_no_temporary_file() {
    a_signal_during_a_write_leaves_no_temporary_file("abort", libc::SIGABRT);
    a_signal_during_a_write_leaves_no_temporary_file("bus", libc::SIGBUS);
}

/// Sends `signal` to `generate` while it writes its output: the process ends by the signal, and
/// its temporary file goes with it.
#[cfg(unix)]
fn a_signal_during_a_write_leaves_no_temporary_file(name: &str, signal: i32) {
    let dir = temp_dir(name);
    let out_path = dir.join("v.nrrd");
    let is_tmp = |n: &str| n.starts_with(".v.nrrd.tmp");
    let listing = || names_in(&dir);
    // The write must be caught in progress: 128 MiB, written and synced, is tens of
    // milliseconds at the very least; a few tries cover an unlucky poll.
    let mut caught = false;
    for _ in 0..4 {
        let mut child = Command::new(env!("CARGO_BIN_EXE_isogrid"))
            .args(["generate", "sphere", "--size", "512", "-o", s(&out_path)])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let start = Instant::now();
        while child.try_wait().unwrap().is_none() && start.elapsed() < Duration::from_secs(120) {
            if listing().iter().any(|n| is_tmp(n)) {
                // SAFETY: sending a signal to our own child process.
                unsafe { libc::kill(child.id() as i32, signal) };
                caught = true;
                break;
            }
            std::thread::sleep(Duration::from_millis(1));
        }
        let status = child.wait().unwrap();
        let left = listing();
        assert!(!left.iter().any(|n| is_tmp(n)), "left behind: {left:?}");
        use std::os::unix::process::ExitStatusExt;
        if caught && status.signal() == Some(signal) {
            break;
        }
        // The signal came after the rename (the write had finished): try again.
        assert!(status.success(), "{status:?}");
        caught = false;
        let _ = std::fs::remove_file(&out_path);
    }
    assert!(caught, "never signalled ({signal}) a write in progress");
    std::fs::remove_dir_all(dir).unwrap();
}

/// Ctrl-C during a streamed extraction (`--max-memory`, slab by slab) stops it within a read, a
/// block row or a block: the command says so and exits 130, the old output stays as it was, and
/// no temporary file is left. A signal that comes before the extraction starts ends the process
/// by its default action, which leaves nothing either.
#[cfg(unix)]
#[test]
fn ctrl_c_stops_a_streamed_extract_and_leaves_no_output() {
    let dir = temp_dir("interrupt-stream");
    let volume = generated(&dir, "gyroid", 512);
    let out = dir.join("out.cgc");
    let args = [
        "extract",
        s(&volume),
        "--iso",
        "128",
        "--max-memory",
        "64M",
        "-o",
        s(&out),
    ];
    extraction_stops_on_ctrl_c(&args, &out, &[5, 15, 30, 45, 60, 90, 120]);
    std::fs::remove_dir_all(dir).unwrap();
}

/// Ctrl-C during a streamed label extraction (`--labels` within `--max-memory`, a raw volume read
/// by region) stops it within a read or a block: exit 130, the old output kept, and no temporary
/// or scratch file left.
#[cfg(unix)]
#[test]
fn ctrl_c_stops_a_streamed_label_extract_and_leaves_no_output() {
    let dir = temp_dir("interrupt-labels");
    let dims = [256, 256, 288];
    let raw = dir.join("sv.raw");
    std::fs::write(&raw, supervoxel_bytes(dims)).unwrap();
    let out = dir.join("out.cgc");
    let args = [
        "extract",
        s(&raw),
        "--raw-shape",
        "256,256,288",
        "--raw-type",
        "u32",
        "--labels",
        "all",
        "--max-memory",
        "64M",
        "-o",
        s(&out),
    ];
    extraction_stops_on_ctrl_c(&args, &out, &[20, 100, 300, 600, 1000]);
    std::fs::remove_dir_all(dir).unwrap();
}

/// [`super::labels::supervoxels`] as little-endian u32 bytes.
fn supervoxel_bytes(dims: [usize; 3]) -> Vec<u8> {
    super::labels::supervoxels(dims)
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect()
}

/// Ctrl-C during an in-memory label extraction (a `.npy`, read whole) stops it between blocks, as
/// the streamed one does: exit 130, the old output kept, nothing else left.
#[cfg(unix)]
#[test]
fn ctrl_c_stops_an_in_memory_label_extract_and_leaves_no_output() {
    let dir = temp_dir("interrupt-labels-memory");
    let dims = [256, 256, 288];
    let npy = dir.join("sv.npy");
    super::write_npy(&npy, "<u4", [288, 256, 256], &supervoxel_bytes(dims));
    let out = dir.join("out.cgc");
    let args = ["extract", s(&npy), "--labels", "all", "-o", s(&out)];
    extraction_stops_on_ctrl_c(&args, &out, &[100, 300, 600, 1000, 1500]);
    std::fs::remove_dir_all(dir).unwrap();
}

/// [`interrupt_at`] for `extract`: a finished run writes a `.cgc` that `isogrid info` reads, and
/// at least one run stops with the extraction's Ctrl-C message.
#[cfg(unix)]
fn extraction_stops_on_ctrl_c(args: &[&str], out: &Path, delays_ms: &[u64]) {
    let stopped = interrupt_at(args, out, delays_ms, isogrid_info_reads);
    assert!(stopped
        .iter()
        .any(|m| m.contains("extraction stopped by Ctrl-C, nothing written")));
}

/// Runs `isogrid args` and sends it SIGINT after each of `delays_ms`, and at a fifth, two, three
/// and four fifths of the time one uninterrupted run takes on the machine as it is now (a
/// loaded machine stretches the work past fixed delays), checking that `out` (which holds "old"
/// before each run) and its folder come out whole: either the command finished (a complete new
/// `out`, as `complete` says), or it stopped with exit 130 in one line, within 2 s, with `out`
/// kept and nothing else left, or the signal came before the work (its default action). Returns
/// the stop messages; fails when no run stopped that way.
#[cfg(unix)]
pub(super) fn interrupt_at(
    args: &[&str],
    out: &Path,
    delays_ms: &[u64],
    complete: impl Fn(&Path) -> bool,
) -> Vec<String> {
    use std::os::unix::process::ExitStatusExt;
    let dir = out.parent().unwrap();
    let started = Instant::now();
    let whole = isogrid(args);
    let took_ms = started.elapsed().as_millis() as u64;
    assert!(
        whole.status.success() && complete(out),
        "{args:?}: {}",
        String::from_utf8_lossy(&whole.stderr)
    );
    let before = {
        std::fs::write(out, b"old").unwrap();
        let mut names = names_in(dir);
        names.sort();
        names
    };
    let delays = delays_ms
        .iter()
        .copied()
        .chain([1, 2, 3, 4].map(|fifths| took_ms * fifths / 5));
    let mut stopped = Vec::new();
    for delay_ms in delays {
        let child = Command::new(env!("CARGO_BIN_EXE_isogrid"))
            .args(args)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        std::thread::sleep(Duration::from_millis(delay_ms));
        let sent = Instant::now();
        // SAFETY: sending SIGINT to our own child process.
        unsafe { libc::kill(child.id() as i32, libc::SIGINT) };
        let done = child.wait_with_output().unwrap();
        let latency = sent.elapsed();
        let stderr = String::from_utf8_lossy(&done.stderr).to_string();
        let mut left = names_in(dir);
        left.sort();
        assert_eq!(left, before, "after {delay_ms} ms: {stderr}");
        let kept = std::fs::read(out).unwrap() == b"old";
        // Killed by the signal's default action with the new output in place: the signal came
        // after the output was renamed into place and the Ctrl-C handler had gone.
        let after_the_write = !kept && done.status.signal() == Some(libc::SIGINT);
        if done.status.success() || after_the_write {
            // The signal came after the work had finished: a complete new output.
            assert!(!kept && complete(out), "after {delay_ms} ms");
            std::fs::write(out, b"old").unwrap();
            continue;
        }
        assert!(kept, "after {delay_ms} ms the old output changed: {stderr}");
        if done.status.code() == Some(130) {
            assert!(
                stderr.contains("stopped by Ctrl-C, nothing written"),
                "{stderr}"
            );
            assert_eq!(stderr.lines().count(), 1, "{stderr}");
            assert!(latency < Duration::from_secs(2), "took {latency:?} to stop");
            stopped.push(stderr);
        } else {
            // Interrupted before the work began: the default action.
            assert_eq!(done.status.signal(), Some(libc::SIGINT), "{stderr}");
        }
    }
    assert!(!stopped.is_empty(), "no interrupt reached the work");
    stopped
}

/// Ctrl-C during `mc` stops Marching Cubes at its next slab: exit 130, one line, the old output
/// kept and no temporary file (or, when the signal comes before the work, the default action).
#[cfg(unix)]
#[test]
fn ctrl_c_stops_marching_cubes_and_leaves_no_output() {
    let dir = temp_dir("interrupt-mc");
    let volume = generated(&dir, "gyroid", 512);
    let out = dir.join("out.ply");
    let args = ["mc", s(&volume), "--iso", "128", "-o", s(&out)];
    let stopped = interrupt_at(&args, &out, &[60, 120, 250, 400, 600, 900], |new| {
        std::fs::read(new).unwrap().starts_with(b"ply\n")
    });
    assert!(stopped
        .iter()
        .any(|m| m.contains("Marching Cubes stopped by Ctrl-C")));
    std::fs::remove_dir_all(dir).unwrap();
}

/// Under an address-space limit (`ulimit -v`, `prlimit --as`) a streamed extraction sizes its
/// budget and output buffer to the room left, or fails with one line; it never aborts with its
/// temporary file (the size of the output) left beside the output, over a range of limits that
/// covers failing reads, failing buffers and success.
#[cfg(target_os = "linux")]
#[test]
fn a_streamed_extract_under_an_address_space_limit_leaves_no_temporary_file() {
    use std::os::unix::process::CommandExt;
    let dir = temp_dir("rlimit-as");
    // 640³: a 250 MiB slab, and a 70 MB output whose buffer, before the fix, was allocated (and
    // failed, near 500 MiB) after the output's temporary file had been made at its full size.
    let volume = generated(&dir, "gyroid", 640);
    let out = dir.join("out.cgc");
    let mut outcomes = Vec::new();
    for mib in (250..=800).step_by(25) {
        let _ = std::fs::remove_file(&out);
        let limit = (mib as u64) << 20;
        let mut command = Command::new(env!("CARGO_BIN_EXE_isogrid"));
        command.args(["extract", s(&volume), "--iso", "128", "-o", s(&out)]);
        // SAFETY: setrlimit is async-signal-safe, called in the child between fork and exec.
        unsafe {
            command.pre_exec(move || {
                let rlimit = libc::rlimit {
                    rlim_cur: limit,
                    rlim_max: limit,
                };
                libc::setrlimit(libc::RLIMIT_AS, &rlimit);
                Ok(())
            });
        }
        let done = command.output().unwrap();
        let stderr = String::from_utf8_lossy(&done.stderr);
        let left: Vec<String> = names_in(&dir)
            .into_iter()
            .filter(|n| n.starts_with(".out.cgc"))
            .collect();
        assert!(left.is_empty(), "{mib} MiB: left {left:?}; {stderr}");
        assert_eq!(
            out.exists(),
            done.status.success(),
            "{mib} MiB: {:?} {stderr}",
            done.status
        );
        // Success, or one line naming the input: never an abort in the allocator (exit 134,
        // "memory allocation of N bytes failed", one run in three near 600 MiB on a 1024³ volume
        // when the slab was planned to the last byte of the room).
        if !done.status.success() {
            assert_eq!(done.status.code(), Some(1), "{mib} MiB: {stderr}");
            assert_eq!(stderr.trim_end().lines().count(), 1, "{mib} MiB: {stderr}");
            assert!(stderr.contains(s(&volume)), "{mib} MiB: {stderr}");
        }
        outcomes.push((mib, done.status.code()));
    }
    // The range reaches success: the budget and the output buffer fit the room left.
    assert!(outcomes.iter().any(|(_, c)| *c == Some(0)), "{outcomes:?}");
    std::fs::remove_dir_all(dir).unwrap();
}

/// Runs the binary with its stdout going to `stdout`.
fn with_stdout(stdout: impl Into<Stdio>, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_isogrid"))
        .args(args)
        .stdout(stdout)
        .stderr(Stdio::piped())
        .output()
        .expect("runs the binary")
}

#[test]
fn printing_to_a_closed_pipe_ends_quietly_and_to_a_full_disk_fails_in_one_line() {
    let dir = temp_dir("stdout");
    let (volume, grid) = sphere_grid(&dir, 24);
    let mesh = dir.join("m.obj");
    let every_printing_command: [Vec<&str>; 7] = [
        vec!["info", s(&grid)],
        // The server prints its URL first: without a reader it must end, not serve on.
        vec!["serve", s(&grid), "--port", "0"],
        vec!["info", s(&grid), "--json"],
        vec!["extract", s(&volume), "--iso", "0.5", "-o", s(&grid)],
        vec!["mc", s(&volume), "--iso", "0.5", "-o", s(&mesh)],
        vec!["generate", "sphere", "--size", "8", "-o", s(&volume)],
        vec!["--help"],
    ];
    for args in &every_printing_command {
        // A reader that went away before anything was printed (`| head -0`).
        let (reader, writer) = std::io::pipe().unwrap();
        drop(reader);
        let out = with_stdout(writer, args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{args:?} to a closed pipe: {stderr}");
        assert!(stderr.is_empty(), "{args:?} to a closed pipe: {stderr}");
        // A device that takes nothing.
        let full = std::fs::OpenOptions::new()
            .write(true)
            .open("/dev/full")
            .unwrap();
        let out = with_stdout(full, args);
        one_line_error(
            &out,
            "cannot write to standard output: No space left on device",
        );
        assert!(!String::from_utf8_lossy(&out.stderr).contains("panicked"));
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The output must never be a file the input reads, not only the path given: a detached header's
/// data file, a slice of a DICOM folder. A new file in the DICOM folder is not read, so it may be
/// written.
#[test]
fn outputs_never_overwrite_a_file_the_input_reads() {
    let fixtures =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../isogrid-io/tests/fixtures");
    let dir = temp_dir("reads");
    let unchanged = |path: &std::path::Path, bytes: &[u8]| {
        assert_eq!(
            std::fs::read(path).unwrap(),
            bytes,
            "{} changed",
            path.display()
        );
    };
    // A detached NRRD whose data file is named like a grid.
    let header = std::fs::read_to_string(fixtures.join("u8_detached.nhdr")).unwrap();
    let nhdr = dir.join("det.nhdr");
    std::fs::write(&nhdr, header.replace("u8_detached.raw", "data.cgc")).unwrap();
    let raw = std::fs::read(fixtures.join("u8_detached.raw")).unwrap();
    let data = dir.join("data.cgc");
    std::fs::write(&data, &raw).unwrap();
    fails(
        &["extract", s(&nhdr), "--iso", "100", "-o", s(&data)],
        "would overwrite",
    );
    unchanged(&data, &raw);
    // A MetaImage header's ElementDataFile.
    let header = std::fs::read_to_string(fixtures.join("i16_z.mhd")).unwrap();
    let mhd = dir.join("m.mhd");
    std::fs::write(&mhd, header.replace("i16_z.zraw", "m.cgc")).unwrap();
    let zraw = std::fs::read(fixtures.join("i16_z.zraw")).unwrap();
    let mdata = dir.join("m.cgc");
    std::fs::write(&mdata, &zraw).unwrap();
    fails(
        &["extract", s(&mhd), "--iso", "100", "-o", s(&mdata)],
        &format!("which the input {} reads", s(&mhd)),
    );
    unchanged(&mdata, &zraw);
    // DICOM slices named like the outputs (names do not matter to DICOM).
    let dcm = dir.join("dcm");
    std::fs::create_dir_all(&dcm).unwrap();
    for (from, to) in [("a.dcm", "s001"), ("b.dcm", "s003.cgc"), ("c.dcm", "x.obj")] {
        std::fs::copy(fixtures.join("dicom_ct").join(from), dcm.join(to)).unwrap();
    }
    let slice = std::fs::read(dcm.join("s003.cgc")).unwrap();
    fails(
        &[
            "extract",
            s(&dcm),
            "--iso",
            "0",
            "-o",
            s(&dcm.join("s003.cgc")),
        ],
        "which the input",
    );
    unchanged(&dcm.join("s003.cgc"), &slice);
    let obj = std::fs::read(dcm.join("x.obj")).unwrap();
    fails(
        &["mc", s(&dcm), "--iso", "0", "-o", s(&dcm.join("x.obj"))],
        "which the input",
    );
    unchanged(&dcm.join("x.obj"), &obj);
    // A new file in the folder is not read: written.
    let fresh = dcm.join("new.cgc");
    let out = isogrid(&["extract", s(&dcm), "--iso", "0", "-o", s(&fresh)]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(fresh.is_file());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `render -o r.png --aov depth=d.npy`: every output is checked before any is written (a folder
/// named `d.npy`), and none is replaced unless all are written (a write that fails part way).
#[test]
fn render_writes_all_its_outputs_or_none() {
    let dir = temp_dir("render-all-or-none");
    let (_, grid) = sphere_grid(&dir, 16);
    let png = dir.join("r.png");
    std::fs::write(&png, b"old picture").unwrap();
    let folder = dir.join("d.npy");
    std::fs::create_dir_all(&folder).unwrap();
    let args = |depth: &std::path::Path| {
        vec![
            "render".to_string(),
            s(&grid).to_string(),
            "--backend".into(),
            "cpu".into(),
            "--size".into(),
            "64x64".into(),
            "-o".into(),
            s(&png).to_string(),
            "--aov".into(),
            format!("depth={}", s(depth)),
        ]
    };
    let folder_args = args(&folder);
    let folder_args: Vec<&str> = folder_args.iter().map(String::as_str).collect();
    fails(&folder_args, "it is a folder");
    assert_eq!(std::fs::read(&png).unwrap(), b"old picture");
    // An AOV into a folder that is not there, or is a file, is found before the render too.
    for (missing, message) in [
        (dir.join("none").join("d.npy"), "the folder"),
        (png.join("d.npy"), "is not a folder"),
    ] {
        let missing_args = args(&missing);
        let missing_args: Vec<&str> = missing_args.iter().map(String::as_str).collect();
        fails(&missing_args, message);
        assert_eq!(std::fs::read(&png).unwrap(), b"old picture");
    }
    // A file-size limit that the PNG fits (64x64 RGB, compressed, under 8 KiB) and the depth AOV
    // does not (64 x 64 x 4 bytes = 16 KiB).
    let depth = dir.join("d2.npy");
    let out = Command::new("sh")
        .arg("-c")
        .arg("ulimit -f 16 && exec \"$0\" \"$@\"")
        .arg(env!("CARGO_BIN_EXE_isogrid"))
        .args(args(&depth))
        .output()
        .unwrap();
    one_line_error(&out, "d2.npy");
    assert_eq!(
        std::fs::read(&png).unwrap(),
        b"old picture",
        "r.png replaced"
    );
    assert!(!depth.exists());
    let left: Vec<String> = names_in(&dir)
        .into_iter()
        .filter(|n| n.contains(".tmp"))
        .collect();
    assert!(left.is_empty(), "left behind: {left:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A finite but huge spacing or origin put `mc`'s vertices at `inf`, written with exit 0.
#[test]
fn mc_vertices_beyond_f32_are_an_error() {
    let dir = temp_dir("mc-huge");
    for (name, directions, origin) in [
        ("spacing", "(1e39,0,0) (0,1,0) (0,0,1)", "(0,0,0)"),
        ("origin", "(1,0,0) (0,1,0) (0,0,1)", "(1e200,0,0)"),
        // The issue's 1e200 as a spacing: its square overflows, and it was refused as "spacing
        // inf", a value the file does not hold.
        (
            "spacing-1e200",
            "(1e200,0,0) (0,1e200,0) (0,0,1e200)",
            "(0,0,0)",
        ),
    ] {
        let mut bytes = format!(
            "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 4 4 4\nspace: left-posterior-superior\n\
             space directions: {directions}\nspace origin: {origin}\nencoding: raw\n\n"
        )
        .into_bytes();
        // One bright sample in the middle: a small closed surface.
        bytes.extend((0..64).map(|n| if n == 21 { 200u8 } else { 0 }));
        let volume = dir.join(format!("{name}.nrrd"));
        std::fs::write(&volume, bytes).unwrap();
        let mesh = dir.join(format!("{name}.obj"));
        let err = fails(
            &["mc", s(&volume), "--iso", "100.5", "-o", s(&mesh)],
            "beyond the range of 32-bit floats",
        );
        assert!(err.contains(s(&volume)), "{err}");
        assert!(!mesh.exists());
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Under an address-space limit (`ulimit -v`, `prlimit --as`) a volume larger than the room left
/// aborted in the allocator ("memory allocation ... failed", exit 134): the memory check now
/// counts that limit and refuses in one line.
#[cfg(unix)]
#[test]
fn an_address_space_limit_is_a_one_line_error_not_an_abort() {
    let dir = temp_dir("ulimit-v");
    let out_path = dir.join("big.nrrd");
    // 1300³ bytes = 2.0 GiB under a 1.9 GiB address space (ulimit -v counts KiB).
    let out = Command::new("sh")
        .arg("-c")
        .arg(format!(
            "ulimit -v 2000000 && exec \"$0\" generate sphere --size 1300 -o '{}'",
            s(&out_path)
        ))
        .arg(env!("CARGO_BIN_EXE_isogrid"))
        .output()
        .unwrap();
    one_line_error(&out, "needs 2.");
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("memory"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(out.status.code(), Some(1));
    assert!(names_in(&dir).is_empty());
    std::fs::remove_dir_all(dir).unwrap();
}

/// A FIFO inside a Zarr store, as a chunk or as `.zarray`, blocked the read forever.
#[cfg(unix)]
#[test]
fn a_fifo_inside_a_zarr_store_is_refused_not_waited_on() {
    let fixtures =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../isogrid-io/tests/fixtures/zarr");
    let dir = temp_dir("zarr-fifo");
    for key in ["0.1.0", ".zarray"] {
        let store = dir.join(format!("v{}.zarr", key.replace('.', "_")));
        let copied = Command::new("cp")
            .arg("-r")
            .arg(fixtures.join("v2_blosc.zarr"))
            .arg(&store)
            .status()
            .unwrap();
        assert!(copied.success());
        std::fs::remove_file(store.join(key)).unwrap();
        let made = Command::new("mkfifo")
            .arg(store.join(key))
            .status()
            .unwrap();
        assert!(made.success());
        for command in ["extract", "mc"] {
            let out = within(
                Duration::from_secs(60),
                &[command, s(&store), "--iso", "100"],
            );
            one_line_error(&out, "is not a regular file");
            let stderr = String::from_utf8_lossy(&out.stderr);
            assert!(stderr.contains(key), "{command} {key}: {stderr}");
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A volume with a huge spacing failed to render with "camera eye coordinate NaN is beyond
/// ±1e15": no file name, and a value that is not the volume's.
#[test]
fn render_of_a_volume_too_large_to_trace_names_the_file_and_its_extent() {
    let dir = temp_dir("render-huge");
    let mut bytes = b"ObjectType = Image\nNDims = 3\nDimSize = 4 4 4\nElementSpacing = 1e200 1 1\n\
                      ElementType = MET_UCHAR\nElementDataFile = LOCAL\n"
        .to_vec();
    bytes.extend((0..64).map(|n| if n == 21 { 200u8 } else { 0 }));
    let volume = dir.join("huge.mha");
    std::fs::write(&volume, bytes).unwrap();
    let err = fails(
        &[
            "render",
            s(&volume),
            "--iso",
            "100.5",
            "--backend",
            "cpu",
            "--size",
            "16x16",
        ],
        "the grid's box reaches 3e200, beyond ±1e15",
    );
    assert!(err.contains(s(&volume)) && !err.contains("NaN"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// An HTTP server that accepts the connection and never answers stalled a read for minutes; the
/// deadline is configurable (`ISOGRID_HTTP_TIMEOUT`), and past it the read fails naming the URL.
#[test]
fn a_silent_http_server_times_out_as_configured() {
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    // Accepts every connection and keeps it open without a word.
    std::thread::spawn(move || {
        let mut held = Vec::new();
        for stream in listener.incoming() {
            held.push(stream);
        }
    });
    let url = format!("http://127.0.0.1:{port}/silent.zarr");
    let start = Instant::now();
    let mut child = Command::new(env!("CARGO_BIN_EXE_isogrid"))
        .args(["extract", &url, "--iso", "1"])
        .env("ISOGRID_HTTP_TIMEOUT", "1")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > Duration::from_secs(30) {
            child.kill().unwrap();
            panic!("still waiting on a silent server after 30 s");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let out = child.wait_with_output().unwrap();
    one_line_error(&out, &url);
    // A deadline that is not a number of seconds is refused, not ignored.
    let out = Command::new(env!("CARGO_BIN_EXE_isogrid"))
        .args(["extract", &url, "--iso", "1"])
        .env("ISOGRID_HTTP_TIMEOUT", "soon")
        .output()
        .unwrap();
    one_line_error(
        &out,
        "ISOGRID_HTTP_TIMEOUT=soon: not a positive number of seconds",
    );
}

/// `--index` applies to Zarr arrays and TIFF hyperstacks only; on any other input it would be
/// ignored, so it is refused in one line naming the input, in memory and streamed, and an axis
/// given twice is named as such.
#[test]
fn an_index_for_an_input_without_extra_axes_is_refused() {
    let dir = temp_dir("index-unused");
    let volume = generated(&dir, "sphere", 24);
    for extra in [&[][..], &["--max-memory", "64M"][..]] {
        let mut args = vec!["extract", s(&volume), "--iso", "1", "--index", "t=0"];
        args.extend_from_slice(extra);
        fails(&args, "--index picks a channel or time point");
        let mut args = vec![
            "extract",
            s(&volume),
            "--iso",
            "1",
            "--index",
            "t=0,t=1,c=0",
        ];
        args.extend_from_slice(extra);
        fails(&args, "gives axis t twice");
    }
    fails(
        &["mc", s(&volume), "--iso", "1", "--index", "c=1"],
        "sphere.nrrd",
    );
    std::fs::remove_dir_all(dir).unwrap();
}
