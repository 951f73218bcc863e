//! How much memory a request may take, checked before allocating it.
//!
//! A request whose size is accepted (a 1600³ volume, an 8192² image, 10⁸ rays, a file header
//! declaring 2048³ samples) must fail with an error that names the limit, not abort in the
//! allocator or wake the kernel's OOM killer. Every large allocation is therefore compared first
//! with the memory the machine can give now:
//!
//! - `MemAvailable` of `/proc/meminfo` (the kernel's estimate of what can be allocated without
//!   swapping), lowered to the room left under the cgroup's memory limit (v2 `memory.max`, v1
//!   `memory.limit_in_bytes`) when the process runs in a limited cgroup (a container), and to the
//!   room left under the address-space limit (`ulimit -v`, `RLIMIT_AS`) when there is one;
//! - lowered again to `ISOGRID_MEMORY_LIMIT` (bytes, or with a K/M/G/T suffix, powers of 1024)
//!   when that is set, and to [`set_limit`] in-process: the way tests exercise the check without
//!   allocating gigabytes;
//! - off Linux, or when none of these can be read, no limit is known and only fallible
//!   allocation (`Vec::try_reserve_exact`) guards the request.
//!
//! Volumes larger than memory are not read by pieces yet; until then a clear error is the answer.

use crate::error::{Error, Result};
use std::sync::atomic::{AtomicU64, Ordering};

/// The in-process limit of [`set_limit`]; `u64::MAX` = none.
static LIMIT: AtomicU64 = AtomicU64::new(u64::MAX);

/// Lowers the memory a request may take to `bytes` for the rest of the process (`None` lifts it).
/// For tests and embedding programs that know their own budget.
pub fn set_limit(bytes: Option<u64>) {
    LIMIT.store(bytes.unwrap_or(u64::MAX), Ordering::Relaxed);
}

/// Bytes a request may allocate now, and where that figure comes from; `None` when unknown.
pub fn available() -> Option<(u64, &'static str)> {
    room(0)
}

/// Address space glibc's malloc reserves for each thread's arena (`HEAP_MAX_SIZE` on 64-bit: 64
/// MiB, mapped whole the first time a thread allocates, used or not).
const ARENA_RESERVE: u64 = 64 << 20;

/// [`available`] for a plan that fills the room over a run whose worker threads have not all
/// allocated yet (a streamed extraction's budget): under an address-space limit, less one malloc
/// arena reservation per thread of rayon's pool (the main thread's arena grows the heap instead).
/// A budget of the whole room aborted in the allocator once the threads' arenas were mapped (exit
/// 134, "memory allocation of N bytes failed").
pub fn available_to_plan() -> Option<(u64, &'static str)> {
    room(rayon::current_num_threads() as u64 * ARENA_RESERVE)
}

/// [`available`], with `arenas` bytes of address space kept back under an address-space limit.
fn room(arenas: u64) -> Option<(u64, &'static str)> {
    let mut best: Option<(u64, &'static str)> = None;
    let mut lower = |bytes: Option<u64>, source: &'static str| {
        if let Some(b) = bytes {
            if best.is_none_or(|(old, _)| b < old) {
                best = Some((b, source));
            }
        }
    };
    lower(mem_available(), "available memory");
    lower(cgroup_room(), "the cgroup's memory limit");
    lower(
        address_space_room().map(|room| room.saturating_sub(arenas)),
        "the room under the address-space limit (ulimit -v)",
    );
    lower(
        std::env::var("ISOGRID_MEMORY_LIMIT")
            .ok()
            .and_then(|s| parse_bytes(&s)),
        "ISOGRID_MEMORY_LIMIT",
    );
    let set = LIMIT.load(Ordering::Relaxed);
    lower((set != u64::MAX).then_some(set), "the memory limit set");
    best
}

/// The memory budget of a streamed pass over a volume (an extraction, a census): `asked`, by
/// default a quarter of the machine's memory (4 GiB where it cannot be read), lowered to what the
/// process may allocate now ([`available_to_plan`]: free memory, the cgroup's limit, `ulimit -v`
/// less the threads' malloc arenas), since a budget past that would abort in the allocator. With
/// the budget, where it was lowered, what lowered it.
pub fn streaming_budget(asked: Option<u64>) -> (u64, Option<&'static str>) {
    let wanted = asked.unwrap_or_else(|| {
        let total = std::fs::read_to_string("/proc/meminfo")
            .ok()
            .and_then(|text| {
                let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
                let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
                Some(kib * 1024)
            });
        total.map_or(4 << 30, |t| t / 4)
    });
    match available_to_plan() {
        Some((room, source)) if room < wanted => (room, Some(source)),
        _ => (wanted, None),
    }
}

/// Fails with a `TooLarge` error naming `what`, its size and the limit when `bytes` exceed what
/// [`available`] says may be allocated.
pub fn ensure_fits(what: &str, bytes: u64) -> Result<()> {
    match available() {
        Some((limit, source)) if bytes > limit => Err(Error::too_large(format!(
            "{what} needs {} of memory but {source} is {}",
            show_bytes(bytes),
            show_bytes(limit)
        ))),
        _ => Ok(()),
    }
}

/// An empty vector with room for exactly `len` elements, or a `TooLarge` error naming `what`:
/// [`ensure_fits`] first, then a fallible reservation for what no limit caught.
pub fn try_vec<T>(what: &str, len: usize) -> Result<Vec<T>> {
    let bytes = (len as u64).saturating_mul(std::mem::size_of::<T>() as u64);
    ensure_fits(what, bytes)?;
    let mut v = Vec::new();
    v.try_reserve_exact(len).map_err(|_| {
        Error::too_large(format!(
            "{what} needs {} of memory, which cannot be allocated",
            show_bytes(bytes)
        ))
    })?;
    Ok(v)
}

/// `1536` → "1.5 KiB"; bytes in powers of 1024 with one decimal.
pub fn show_bytes(bytes: u64) -> String {
    const UNITS: [&str; 5] = ["bytes", "KiB", "MiB", "GiB", "TiB"];
    let mut value = bytes as f64;
    let mut unit = 0;
    while value >= 1024.0 && unit + 1 < UNITS.len() {
        value /= 1024.0;
        unit += 1;
    }
    if unit == 0 {
        format!("{bytes} bytes")
    } else {
        format!("{value:.1} {}", UNITS[unit])
    }
}

/// "512M" → 536870912; plain bytes or a K/M/G/T suffix (powers of 1024), optionally followed by
/// "B" or "iB".
fn parse_bytes(text: &str) -> Option<u64> {
    let t = text.trim();
    let t = t
        .strip_suffix("iB")
        .or_else(|| t.strip_suffix('B'))
        .unwrap_or(t);
    let (digits, shift) = match t.chars().last()?.to_ascii_uppercase() {
        'K' => (&t[..t.len() - 1], 10),
        'M' => (&t[..t.len() - 1], 20),
        'G' => (&t[..t.len() - 1], 30),
        'T' => (&t[..t.len() - 1], 40),
        _ => (t, 0),
    };
    digits.trim().parse::<u64>().ok()?.checked_mul(1 << shift)
}

/// `MemAvailable` of `/proc/meminfo`, in bytes.
fn mem_available() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib.saturating_mul(1024))
}

/// Room left under this process's address-space limit (`RLIMIT_AS`, `ulimit -v`, `prlimit
/// --as`), when it has one: the limit of `/proc/self/limits` less the `VmSize` of
/// `/proc/self/status`. Past it every allocation fails, and Rust's allocator aborts.
fn address_space_room() -> Option<u64> {
    let limits = std::fs::read_to_string("/proc/self/limits").ok()?;
    let line = limits
        .lines()
        .find(|l| l.starts_with("Max address space"))?;
    // "Max address space  <soft>  <hard>  bytes"; "unlimited" does not parse.
    let soft: u64 = line["Max address space".len()..]
        .split_whitespace()
        .next()?
        .parse()
        .ok()?;
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let size = status.lines().find(|l| l.starts_with("VmSize:"))?;
    let kib: u64 = size.split_whitespace().nth(1)?.parse().ok()?;
    Some(soft.saturating_sub(kib.saturating_mul(1024)))
}

/// Room left under this process's cgroup memory limit, when it has one: cgroup v2 `memory.max`
/// less `memory.current`, or v1 `memory.limit_in_bytes` less `memory.usage_in_bytes`. In a
/// container the process's cgroup is often the mount's root, tried when its own path is absent.
fn cgroup_room() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/cgroup").ok()?;
    let read = |dir: &std::path::Path, name: &str| -> Option<u64> {
        // "max" (v2, no limit) does not parse; v1 states no limit as a huge number.
        std::fs::read_to_string(dir.join(name))
            .ok()?
            .trim()
            .parse()
            .ok()
    };
    let room = |mount: &str, path: &str, limit: &str, usage: &str| -> Option<u64> {
        let root = std::path::Path::new(mount);
        [root.join(path.trim_start_matches('/')), root.to_path_buf()]
            .iter()
            .find_map(|dir| Some(read(dir, limit)?.saturating_sub(read(dir, usage)?)))
    };
    let mut best: Option<u64> = None;
    for line in text.lines() {
        let mut parts = line.splitn(3, ':');
        let (_, controllers, path) = (parts.next()?, parts.next()?, parts.next()?);
        let found = if controllers.is_empty() {
            room("/sys/fs/cgroup", path, "memory.max", "memory.current")
        } else if controllers.split(',').any(|c| c == "memory") {
            room(
                "/sys/fs/cgroup/memory",
                path,
                "memory.limit_in_bytes",
                "memory.usage_in_bytes",
            )
        } else {
            None
        };
        if let Some(r) = found {
            best = Some(best.map_or(r, |b| b.min(r)));
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_with_suffixes() {
        assert_eq!(parse_bytes("4096"), Some(4096));
        assert_eq!(parse_bytes("64M"), Some(64 << 20));
        assert_eq!(parse_bytes("2GiB"), Some(2 << 30));
        assert_eq!(parse_bytes("1k"), Some(1024));
        assert_eq!(parse_bytes("lots"), None);
        assert_eq!(show_bytes(1536), "1.5 KiB");
        assert_eq!(show_bytes(12), "12 bytes");
    }

    #[test]
    fn a_request_over_the_limit_names_both_sizes() {
        // Linux test machines read /proc/meminfo; elsewhere the set limit is the only one.
        let over = available().map_or(u64::MAX, |(b, _)| b.saturating_add(1));
        if over != u64::MAX {
            let err = ensure_fits("a test buffer", over).unwrap_err();
            assert_eq!(err.kind(), crate::ErrorKind::TooLarge);
            assert!(err.message().starts_with("a test buffer needs "), "{err}");
        }
        assert!(ensure_fits("nothing", 0).is_ok());
    }
}
