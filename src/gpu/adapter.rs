//! Adapter selection: which adapter a [`GpuContext`](super::GpuContext) opens ([`GpuOptions`],
//! [`AdapterChoice`], `DIFFSIL_ADAPTER`, `WGPU_BACKEND`) and what it reports ([`AdapterReport`]).

use std::fmt;

use crate::{Error, Result};

/// Which adapter [`GpuContext::new`](super::GpuContext::new) picks.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum AdapterChoice {
    /// The best compute-capable adapter: discrete GPU, then integrated, then virtual, then any
    /// other hardware, then a CPU (software) implementation such as lavapipe.
    #[default]
    Best,
    /// The best adapter whose name contains this string, compared case-insensitively
    /// (e.g. `"llvmpipe"`, `"nvidia"`).
    Name(String),
    /// The best adapter of these backends (e.g. `wgpu::Backends::VULKAN`).
    Backend(wgpu::Backends),
}

impl fmt::Display for AdapterChoice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            AdapterChoice::Best => f.write_str("the best adapter"),
            AdapterChoice::Name(name) => write!(f, "an adapter whose name contains {name:?}"),
            AdapterChoice::Backend(backends) => write!(f, "an adapter on backend(s) {backends:?}"),
        }
    }
}

/// How to set up the GPU.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct GpuOptions {
    /// Which adapter to use.
    pub adapter: AdapterChoice,
    /// Time every stage on the GPU with timestamp queries (when the adapter supports them; see
    /// [`crate::Renderer::gpu_stage_timings`]). Costs an extra wait per submission.
    pub profile: bool,
}

impl GpuOptions {
    /// Options from the environment.
    ///
    /// `DIFFSIL_ADAPTER` selects the adapter: `vulkan` (or `vk`), `gl` (`gles`, `opengl`),
    /// `metal` (`mtl`) or `dx12` (`d3d12`) pick a backend; any other non-empty value is a
    /// case-insensitive substring of the adapter name; unset or empty means
    /// [`AdapterChoice::Best`]. Independently, wgpu's own `WGPU_BACKEND` (a comma list such as
    /// `vulkan,gl`) restricts the backends that are looked at in the first place: it is read by
    /// [`GpuContext::new`](super::GpuContext::new) and [`hardware_gpu_available`], whatever these options say.
    /// `DIFFSIL_GPU_PROFILE=1` turns on [`GpuOptions::profile`].
    pub fn from_env() -> Self {
        let adapter = match std::env::var("DIFFSIL_ADAPTER") {
            Ok(value) => parse_adapter_choice(&value),
            Err(_) => AdapterChoice::Best,
        };
        let profile = std::env::var("DIFFSIL_GPU_PROFILE").is_ok_and(|v| !v.is_empty() && v != "0");
        GpuOptions { adapter, profile }
    }
}

pub(super) fn parse_adapter_choice(value: &str) -> AdapterChoice {
    let value = value.trim();
    match value.to_ascii_lowercase().as_str() {
        "" => AdapterChoice::Best,
        "vulkan" | "vk" => AdapterChoice::Backend(wgpu::Backends::VULKAN),
        "gl" | "gles" | "opengl" => AdapterChoice::Backend(wgpu::Backends::GL),
        "metal" | "mtl" => AdapterChoice::Backend(wgpu::Backends::METAL),
        "dx12" | "d3d12" => AdapterChoice::Backend(wgpu::Backends::DX12),
        _ => AdapterChoice::Name(value.to_owned()),
    }
}

/// What adapter a [`GpuContext`](super::GpuContext) runs on.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AdapterReport {
    /// The adapter's name, e.g. `llvmpipe (LLVM 15.0.6, 256 bits)`.
    pub name: String,
    /// The graphics API wgpu drives it through.
    pub backend: wgpu::Backend,
    /// Discrete, integrated, virtual, CPU or other.
    pub device_type: wgpu::DeviceType,
    /// The driver's name and version information, as reported.
    pub driver: String,
}

impl AdapterReport {
    pub(super) fn from_info(info: &wgpu::AdapterInfo) -> Self {
        let driver = match (info.driver.trim(), info.driver_info.trim()) {
            (d, "") => d.to_owned(),
            ("", i) => i.to_owned(),
            (d, i) => format!("{d} {i}"),
        };
        AdapterReport { name: info.name.clone(), backend: info.backend, device_type: info.device_type, driver }
    }
}

impl fmt::Display for AdapterReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} ({}, {:?}", self.name, self.backend, self.device_type)?;
        if !self.driver.is_empty() {
            write!(f, ", driver {}", self.driver)?;
        }
        f.write_str(")")
    }
}

/// The backends searched first, and the one searched only when they offer no hardware adapter
/// (or when GL is asked for by backend).
///
/// GL (EGL on Linux) is left out of the first search: on a machine with a Vulkan driver it
/// adds nothing the Vulkan adapter does not have, and initialising EGL in a process whose other
/// threads use NVIDIA's Vulkan driver hung them (seen on an H200 with driver 580: eight test
/// threads, one of them searching for an adapter name that did not exist, never returned;
/// with Vulkan alone they ran).
const SEARCH_ORDER: [wgpu::Backends; 2] = [wgpu::Backends::all().difference(wgpu::Backends::GL), wgpu::Backends::GL];

/// Serialises the GL search and the life of the GL adapters it finds ([`with_adapters`]):
/// EGL's initialisation is not safe to run from several threads at once on every driver, and a
/// GL adapter's EGL context is made current on whichever thread searches or drops one.
static GL_SEARCH: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// The instances made so far, by the backends and flags they were made with, kept for the
/// process's life (a `wgpu::Instance` is a shared handle: a clone is the same instance).
///
/// Why: when the last instance of a backend goes, its driver may be unloaded, and the next
/// context loads it again. On an NVIDIA H100 with driver 580 that cycle broke the process: after
/// about thirty contexts had come and gone in one test process, Vulkan found no adapter at all,
/// and a context dropped after one render crashed the process (a driver thread ran on at a code
/// address no longer mapped). Each of those tests passed in a process of its own.
static INSTANCES: std::sync::Mutex<Vec<(wgpu::Backends, wgpu::InstanceFlags, wgpu::Instance)>> =
    std::sync::Mutex::new(Vec::new());

/// The description of an instance of those of `backends` that `WGPU_BACKEND` (and wgpu's other
/// `WGPU_*` instance variables) allow, or `None` when none is left.
fn descriptor_from_env(backends: wgpu::Backends) -> Option<wgpu::InstanceDescriptor> {
    let mut descriptor = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
    descriptor.backends &= backends;
    (!descriptor.backends.is_empty()).then_some(descriptor)
}

/// An instance of those of `backends` that `WGPU_BACKEND` (and wgpu's other `WGPU_*` instance
/// variables) allow, or `None` when none is left: the one made earlier for the same backends
/// and flags when there is one ([`INSTANCES`]; its other options are those of the variables
/// when it was made), else a new one, kept.
fn instance_from_env(backends: wgpu::Backends) -> Option<wgpu::Instance> {
    let descriptor = descriptor_from_env(backends)?;
    let mut kept = INSTANCES.lock().unwrap_or_else(|e| e.into_inner());
    let key = (descriptor.backends, descriptor.flags);
    if let Some((_, _, instance)) = kept.iter().find(|(b, f, _)| (*b, *f) == key) {
        return Some(instance.clone());
    }
    let instance = wgpu::Instance::new(descriptor);
    kept.push((key.0, key.1, instance.clone()));
    Some(instance)
}

/// `inspect` run on the adapters of `backends` (allowed by `WGPU_BACKEND`); what it returns.
///
/// With GL among `backends` all of it holds [`GL_SEARCH`]: the search, `inspect`, and the drop
/// of every adapter `inspect` does not return. wgpu-hal makes a GL adapter's EGL context current
/// on the thread that searches and on the one that drops an adapter, and panics (EGL's
/// `BadAccess`) where that context is current on another thread at the time: with the lock
/// around the search alone, about one `cargo test --lib` in ten failed so on a machine whose
/// only adapters are lavapipe and llvmpipe (its GL adapters found, compared and dropped by
/// tests on several threads). A GL adapter that `inspect` keeps must not be one of the searched
/// instance's: [`select_adapter`] swaps the one it picks for the same adapter from an instance
/// of its own ([`own_gl_adapter`]) before the lock is let go.
async fn with_adapters<T>(backends: wgpu::Backends, inspect: impl FnOnce(Vec<wgpu::Adapter>) -> T) -> T {
    let _guard = backends.contains(wgpu::Backends::GL).then(|| GL_SEARCH.lock().unwrap_or_else(|e| e.into_inner()));
    let adapters = match instance_from_env(backends) {
        Some(instance) => instance.enumerate_adapters(backends).await,
        None => Vec::new(),
    };
    inspect(adapters)
}

/// The GL adapter `searched`, found again on a GL instance made for it alone (not kept
/// in [`INSTANCES`]; the adapter and the devices opened on it keep that instance alive). Call
/// with [`GL_SEARCH`] held.
///
/// Why: wgpu-hal gives all the GL adapters of one instance that instance's one EGL context,
/// each adapter with a lock of its own. Two contexts opened on adapters of one instance would
/// make that EGL context current on two threads at once when rendering from both, which EGL
/// refuses and wgpu-hal turns into a panic (`BadAccess`): the GPU tests on GL (several test
/// threads, each with a context) failed so in each of three runs. With an instance (and so an
/// EGL context) per context, each context's calls are serialised by its own adapter's lock and
/// contexts on different threads use different EGL contexts. The instance kept in
/// [`INSTANCES`], made by the search before this, keeps the EGL display initialised meanwhile.
/// When the new instance offers no adapter like `searched` (it should: same display, same
/// driver), `searched` is returned, which is safe on one thread only.
fn own_gl_adapter(searched: wgpu::Adapter) -> wgpu::Adapter {
    // GL is allowed: the searched adapter came from an instance of the same description.
    let Some(descriptor) = descriptor_from_env(wgpu::Backends::GL) else { return searched };
    let info = searched.get_info();
    let instance = wgpu::Instance::new(descriptor);
    let found = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::GL));
    found.into_iter().find(|a| a.get_info() == info).unwrap_or(searched)
}

fn supports_compute(adapter: &wgpu::Adapter) -> bool {
    adapter.get_downlevel_capabilities().flags.contains(wgpu::DownlevelFlags::COMPUTE_SHADERS)
        && adapter.limits().max_compute_workgroups_per_dimension > 0
}

fn is_hardware(adapter: &wgpu::Adapter) -> bool {
    adapter.get_info().device_type != wgpu::DeviceType::Cpu
}

/// Lower is better.
fn device_type_rank(device_type: wgpu::DeviceType) -> u8 {
    match device_type {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Other => 3,
        wgpu::DeviceType::Cpu => 4,
    }
}

/// Whether a compute-capable adapter that is not a CPU implementation (lavapipe, llvmpipe,
/// SwiftShader) exists, among the backends `WGPU_BACKEND` allows. Use it to choose between the
/// GPU and the CPU backend automatically: on a machine with only a software rasterizer the CPU
/// backend is faster. GL is only looked at when the other backends have no such adapter.
pub fn hardware_gpu_available() -> bool {
    SEARCH_ORDER.iter().any(|&backends| {
        pollster::block_on(with_adapters(backends, |adapters| {
            adapters.iter().any(|a| supports_compute(a) && is_hardware(a))
        }))
    })
}

/// The adapter `choice` asks for, preferring discrete GPUs (see [`AdapterChoice::Best`]), or
/// [`Error::NoAdapter`] listing the adapters seen.
///
/// Vulkan, Metal and DX12 are searched first; GL only when they offer no compute-capable
/// hardware adapter at all, or when `choice` names the GL backend (see `SEARCH_ORDER`). So a
/// software Vulkan adapter still loses to a hardware GL one, and on a machine with a hardware
/// Vulkan adapter a name that only a GL adapter has is not found.
pub(super) async fn select_adapter(choice: &AdapterChoice) -> Result<wgpu::Adapter> {
    let mut seen: Vec<String> = Vec::new();
    let mut best: Option<wgpu::Adapter> = None;
    let mut hardware_seen = false;
    let wants_gl = matches!(choice, AdapterChoice::Backend(b) if b.contains(wgpu::Backends::GL));
    for backends in SEARCH_ORDER {
        if backends == wgpu::Backends::GL && hardware_seen && !wants_gl {
            break;
        }
        // The adapters not kept as the best are dropped inside, under the GL lock where GL.
        with_adapters(backends, |adapters| {
            hardware_seen |= adapters.iter().any(|a| supports_compute(a) && is_hardware(a));
            seen.extend(adapters.iter().map(|a| {
                let report = AdapterReport::from_info(&a.get_info());
                if supports_compute(a) {
                    report.to_string()
                } else {
                    format!("{report} [no compute shaders]")
                }
            }));
            let matches = |a: &wgpu::Adapter| {
                let info = a.get_info();
                match choice {
                    AdapterChoice::Best => true,
                    AdapterChoice::Name(name) => info.name.to_lowercase().contains(&name.to_lowercase()),
                    AdapterChoice::Backend(backends) => backends.contains(wgpu::Backends::from(info.backend)),
                }
            };
            // The first of the best rank wins: earlier searches, then wgpu's order within one.
            let mut gl_won = false;
            for adapter in adapters.into_iter().filter(|a| supports_compute(a) && matches(a)) {
                let rank = |a: &wgpu::Adapter| device_type_rank(a.get_info().device_type);
                if best.as_ref().is_none_or(|b| rank(&adapter) < rank(b)) {
                    gl_won = adapter.get_info().backend == wgpu::Backend::Gl;
                    best = Some(adapter);
                }
            }
            // Still under the GL lock: the searched instance's adapter goes, and the same
            // adapter from an instance of its own takes its place.
            if gl_won {
                best = best.take().map(own_gl_adapter);
            }
        })
        .await;
    }
    best.ok_or_else(|| {
        let backends = match std::env::var("WGPU_BACKEND") {
            Ok(value) => format!(" with WGPU_BACKEND={value:?}"),
            Err(_) => String::new(),
        };
        let seen = if seen.is_empty() { "none".to_owned() } else { seen.join("; ") };
        Error::NoAdapter(format!("wanted {choice}; adapters seen{backends}: {seen}"))
    })
}

/// Samples (pixels × F², summed over the views) from which a call on a software adapter
/// ([`wgpu::DeviceType::Cpu`]: lavapipe, llvmpipe, SwiftShader) is refused: 2048² pixels at
/// F = 4. Such an adapter emulates the GPU on the CPU, far slower than the CPU engine: 2048² at
/// F = 4 takes about a minute on lavapipe and 4096² many minutes, which looks like a hang. Calls
/// of this many samples or more are refused at once ([`Error::GpuLimit`]) unless
/// `DIFFSIL_SOFTWARE_GPU_ANY_SIZE=1` is set.
pub const SOFTWARE_ADAPTER_MAX_SAMPLES: u64 = 2048 * 2048 * 16;

/// [`Error::GpuLimit`] for a call of [`SOFTWARE_ADAPTER_MAX_SAMPLES`] or more on a software adapter.
pub(crate) fn check_software_size(
    adapter: &AdapterReport,
    params: &[crate::mirror::RasterParams],
) -> crate::Result<()> {
    if adapter.device_type != wgpu::DeviceType::Cpu {
        return Ok(());
    }
    let samples: u64 =
        params.iter().map(|p| u64::from(p.width) * u64::from(p.height) * u64::from(p.supersample).pow(2)).sum();
    if samples < SOFTWARE_ADAPTER_MAX_SAMPLES || std::env::var("DIFFSIL_SOFTWARE_GPU_ANY_SIZE").is_ok_and(|v| v == "1")
    {
        return Ok(());
    }
    Err(crate::Error::GpuLimit {
        limit: "samples per call on a software GPU adapter (it would take minutes; the CPU engine is faster, \
                or set DIFFSIL_SOFTWARE_GPU_ANY_SIZE=1)",
        needed: samples,
        max: SOFTWARE_ADAPTER_MAX_SAMPLES - 1,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A second instance of the same backends is the first one again: no new instance is made.
    #[test]
    fn instances_are_made_once_per_backends() {
        let backends =
            wgpu::InstanceDescriptor::new_without_display_handle_from_env().backends & wgpu::Backends::VULKAN;
        // Counted by backends: other tests may make instances of other backends meanwhile.
        let kept = || INSTANCES.lock().unwrap_or_else(|e| e.into_inner()).iter().filter(|k| k.0 == backends).count();
        for _ in 0..3 {
            assert_eq!(instance_from_env(wgpu::Backends::VULKAN).is_some(), !backends.is_empty());
            assert_eq!(kept(), usize::from(!backends.is_empty()));
        }
    }

    #[test]
    fn adapter_choice_from_strings() {
        assert_eq!(parse_adapter_choice(""), AdapterChoice::Best);
        assert_eq!(parse_adapter_choice(" Vulkan "), AdapterChoice::Backend(wgpu::Backends::VULKAN));
        assert_eq!(parse_adapter_choice("GL"), AdapterChoice::Backend(wgpu::Backends::GL));
        assert_eq!(parse_adapter_choice("metal"), AdapterChoice::Backend(wgpu::Backends::METAL));
        assert_eq!(parse_adapter_choice("dx12"), AdapterChoice::Backend(wgpu::Backends::DX12));
        assert_eq!(parse_adapter_choice("LLVMpipe"), AdapterChoice::Name("LLVMpipe".into()));
    }

    #[test]
    fn gl_is_searched_last_and_alone() {
        assert!(!SEARCH_ORDER[0].contains(wgpu::Backends::GL));
        assert!(SEARCH_ORDER[0].contains(wgpu::Backends::VULKAN | wgpu::Backends::METAL | wgpu::Backends::DX12));
        assert_eq!(SEARCH_ORDER[1], wgpu::Backends::GL);
    }

    #[test]
    fn device_type_order() {
        use wgpu::DeviceType::*;
        let mut types = [Cpu, Other, VirtualGpu, IntegratedGpu, DiscreteGpu];
        types.sort_by_key(|t| device_type_rank(*t));
        assert_eq!(types, [DiscreteGpu, IntegratedGpu, VirtualGpu, Other, Cpu]);
    }
}
