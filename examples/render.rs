//! Renders a mesh's silhouette to PNG and reports what it cost: the backend, the time of the
//! forward and of a backward, the contour candidates and visible silhouette segments, and with
//! `--memory` the peak heap (CPU backend) and the GPU buffer bytes (GPU backend).
//!
//! ```text
//! cargo run --release --example render -- path/to/mesh.obj --resolution 1024 --backend cpu
//! DIFFSIL_ASSETS=../shared/assets cargo run --release --example render -- --memory
//! cargo run --release --example render -- --help
//! ```
//!
//! The backward is that of `L = Σ (I − T)²` against the silhouette itself shifted right by 2% of
//! the image width, so the gradient image is non-zero on both sides of the silhouette.
//!
//! Peak heap comes from a counting `#[global_allocator]` in this example (every Rust heap
//! allocation of every thread; not thread stacks, not memory a C driver allocates itself). GPU
//! buffer bytes come from wgpu's allocator report (`wgpu::Device::generate_allocator_report`,
//! available on Vulkan and DX12): the memory behind every live buffer of the device, by label.
//!
//! This file is also compiled into `tests/examples/render.rs`, which checks its options and its run.

use std::path::PathBuf;
use std::time::Instant;

use clap::Parser;
use diffsil::gpu::{GpuContext, GpuOptions};
use diffsil::{loss, shapes, Backend, BackwardStats, Camera, Image, Mesh, Orbit, RenderSettings, Renderer};

mod common;
pub use common::BackendName;
use common::{elevation, finite, median, positive, size};

/// Command-line options (`render --help`).
#[derive(Clone, Debug, PartialEq, Parser)]
#[command(
    name = "render",
    about = "Render a mesh's silhouette to PNG; time its forward and backward",
    after_help = "\
Prints: the backend and adapter; the time of the first forward and backward (which include
one-time set-up such as GPU pipelines and buffers) and the median of --repeat more; the
triangles clipped and culled, the contour candidates (edges that may lie on the silhouette) and the
(edge, pixel) segments the backward visited and found visible. The backward is that of
L = Σ (I − T)² against the silhouette shifted right by 2% of the image width."
)]
pub struct Options {
    /// .obj, .gltf or .glb (a skinned glTF in its rest pose), normalised: bounding-box centre at
    /// the origin, farthest vertex at distance 1. Default: the built-in lumpy blob; with
    /// --memory, the Stanford bunny from $DIFFSIL_ASSETS/stanford-bunny.obj
    #[arg(value_name = "MESH")]
    pub mesh: Option<PathBuf>,
    /// The same as MESH, as an option
    #[arg(long = "mesh", value_name = "PATH", conflicts_with = "mesh")]
    pub mesh_option: Option<PathBuf>,
    /// Camera azimuth about +y, degrees; 0 looks along -z from +z
    #[arg(long, value_name = "DEG", default_value_t = 0.0, value_parser = finite, allow_negative_numbers = true)]
    pub azimuth: f32,
    /// Camera elevation, degrees, strictly between -90 and 90; positive looks down
    #[arg(long, value_name = "DEG", default_value_t = 0.0, value_parser = elevation, allow_negative_numbers = true)]
    pub elevation: f32,
    /// Camera distance from the origin, > 0
    #[arg(long, value_name = "D", default_value_t = 2.7, value_parser = positive, allow_negative_numbers = true)]
    pub distance: f32,
    /// Vertical field of view of the perspective camera, degrees, strictly between 0 and 180
    #[arg(long, value_name = "DEG", default_value_t = 50.0, value_parser = fov, allow_negative_numbers = true)]
    pub fov: f32,
    /// Parallel projection instead of perspective
    #[arg(long)]
    pub orthographic: bool,
    /// World units the image height spans, orthographic only, > 0
    #[arg(long, value_name = "H", default_value_t = 2.4, value_parser = positive, allow_negative_numbers = true)]
    pub view_height: f32,
    /// Image size in pixels, N (square) or WxH [default: 512; 1024 with --memory]
    #[arg(long = "resolution", value_name = "N|WxH", value_parser = size)]
    pub size: Option<(u32, u32)>,
    /// Samples per pixel side, 1 (no anti-aliasing) to 16
    #[arg(long, value_name = "F", default_value_t = 4)]
    pub supersample: u32,
    /// Which engine renders
    #[arg(long, value_name = "NAME", value_enum, default_value_t = BackendName::Auto)]
    pub backend: BackendName,
    /// Timed runs after the first, for the median
    #[arg(long, value_name = "N", default_value_t = 5)]
    pub repeat: u32,
    /// Where the silhouette goes
    #[arg(long, value_name = "FILE.png", default_value = "render.png")]
    pub out: PathBuf,
    /// Measure memory instead: peak heap of a forward + backward on the CPU backend, then the
    /// GPU buffer bytes on the GPU backend (if an adapter opens), next to the theoretical
    /// minimum of one 16-bit sample mask per pixel at F = 4; --backend is ignored
    #[arg(long)]
    pub memory: bool,
}

impl Options {
    /// The mesh file, given as MESH or as --mesh; `None` for the default.
    pub fn mesh_path(&self) -> Option<&PathBuf> {
        self.mesh.as_ref().or(self.mesh_option.as_ref())
    }

    /// Image width and height.
    pub fn size(&self) -> (u32, u32) {
        self.size.unwrap_or(if self.memory { (1024, 1024) } else { (512, 512) })
    }

    /// The camera these options describe.
    pub fn camera(&self) -> Camera {
        let (width, height) = self.size();
        let orbit = Orbit {
            azimuth: self.azimuth.to_radians(),
            elevation: self.elevation.to_radians(),
            distance: self.distance,
            fov_y: self.fov.to_radians(),
            ..Orbit::default()
        };
        if self.orthographic {
            Camera::orthographic(orbit.eye(), orbit.target, self.view_height, width, height)
        } else {
            orbit.camera(width, height)
        }
    }
}

/// A vertical field of view, degrees, strictly between 0 and 180.
fn fov(value: &str) -> Result<f32, String> {
    let x = finite(value)?;
    if x > 0.0 && x < 180.0 {
        Ok(x)
    } else {
        Err("use a value strictly between 0 and 180 degrees".into())
    }
}

/// The mesh the options name (normalised to radius 1) and a name for it.
pub fn load(o: &Options) -> Result<(Mesh, String), Box<dyn std::error::Error>> {
    let path = match (o.mesh_path(), o.memory) {
        (Some(path), _) => path.clone(),
        (None, false) => return Ok((shapes::blob(24, 48).normalized(1.0), "built-in blob".into())),
        (None, true) => match std::env::var_os("DIFFSIL_ASSETS") {
            Some(dir) => PathBuf::from(dir).join("stanford-bunny.obj"),
            None => {
                return Err("--memory measures the Stanford bunny: set DIFFSIL_ASSETS to the folder holding \
                            stanford-bunny.obj (e.g. DIFFSIL_ASSETS=../shared/assets), or give a mesh path"
                    .into())
            }
        },
    };
    let (mesh, name) = common::load_mesh(&path)?;
    Ok((mesh.normalized(1.0), name))
}

/// The loss target: `image` shifted right by `shift` pixels (uncovered columns enter on the left).
pub fn shifted(image: &Image, shift: u32) -> Image {
    let (w, h) = (image.width(), image.height());
    let mut out = Image::filled(w, h, 0.0);
    for i in 0..h {
        for j in shift.min(w)..w {
            out.data_mut()[(i * w + j) as usize] = image.get(i, j - shift);
        }
    }
    out
}

/// Bytes as MiB.
fn mib(bytes: u64) -> String {
    format!("{:.2} MiB", bytes as f64 / (1024.0 * 1024.0))
}

/// A counting global allocator: current and peak bytes of live Rust heap allocations.
mod heap {
    use std::alloc::{GlobalAlloc, Layout, System};
    use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};

    static CURRENT: AtomicUsize = AtomicUsize::new(0);
    static PEAK: AtomicUsize = AtomicUsize::new(0);

    /// [`System`], counting.
    pub struct Counting;

    fn grow(bytes: usize) {
        let now = CURRENT.fetch_add(bytes, Relaxed) + bytes;
        PEAK.fetch_max(now, Relaxed);
    }

    // SAFETY: every call is forwarded to `System` unchanged; only counters are updated.
    unsafe impl GlobalAlloc for Counting {
        unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
            let p = unsafe { System.alloc(layout) };
            if !p.is_null() {
                grow(layout.size());
            }
            p
        }

        unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
            let p = unsafe { System.alloc_zeroed(layout) };
            if !p.is_null() {
                grow(layout.size());
            }
            p
        }

        unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
            unsafe { System.dealloc(ptr, layout) };
            CURRENT.fetch_sub(layout.size(), Relaxed);
        }

        unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
            let p = unsafe { System.realloc(ptr, layout, new_size) };
            if !p.is_null() {
                if new_size >= layout.size() {
                    grow(new_size - layout.size());
                } else {
                    CURRENT.fetch_sub(layout.size() - new_size, Relaxed);
                }
            }
            p
        }
    }

    /// Bytes allocated now.
    pub fn current() -> u64 {
        CURRENT.load(Relaxed) as u64
    }

    /// Most bytes allocated at once since the last [`reset_peak`].
    pub fn peak() -> u64 {
        PEAK.load(Relaxed) as u64
    }

    /// Starts a new peak measurement from the current level.
    pub fn reset_peak() {
        PEAK.store(CURRENT.load(Relaxed), Relaxed);
    }
}

// Not in the tests that include this file: they keep the default allocator.
#[cfg(not(test))]
#[global_allocator]
static ALLOCATOR: heap::Counting = heap::Counting;

/// What one forward + loss + backward measured.
pub struct Run {
    /// The rendered silhouette.
    pub image: Image,
    /// Seconds of the forward (`Renderer::render`).
    pub forward_s: f64,
    /// Seconds of the backward (`Renderer::backward`, to 3D vertices).
    pub backward_s: f64,
    /// The loss value.
    pub loss: f64,
    /// Triangles culled: wholly behind the near plane or beyond the far plane, or with a vertex
    /// too far off-screen (triangles crossing a plane are clipped, not culled).
    pub culled: u32,
    /// Triangles clipped to the part between the near and far planes.
    pub clipped: u32,
    /// Contour candidates: edges that may lie on the silhouette in this view.
    pub candidates: u32,
    /// (edge, pixel) segments of candidates in pixels with a non-zero `∂L/∂I`.
    pub segments: u64,
    /// Those with a visible (unoccluded) part.
    pub visible: u64,
}

/// Renders `mesh` with `camera`, takes `L = Σ (I − T)²` against the image shifted right by
/// `shift` pixels, and runs the backward, timing both passes.
pub fn run_once(renderer: &mut Renderer, mesh: &Mesh, camera: &Camera, shift: u32) -> diffsil::Result<Run> {
    let start = Instant::now();
    let frame = renderer.render(mesh, &[*camera])?;
    let forward_s = start.elapsed().as_secs_f64();
    let image = &frame.images()[0];
    let l2 = loss::squared_error(image, &shifted(image, shift))?;
    let start = Instant::now();
    renderer.backward(&frame, &[l2.grad])?;
    let backward_s = start.elapsed().as_secs_f64();
    let stats = frame.stats()[0];
    let segments = renderer.last_backward_stats().iter().fold(BackwardStats::default(), |a, b| a + *b);
    Ok(Run {
        image: image.clone(),
        forward_s,
        backward_s,
        loss: l2.value,
        culled: stats.culled_triangles,
        clipped: stats.clipped_triangles,
        candidates: stats.candidate_edges,
        segments: segments.segments,
        visible: segments.visible_segments,
    })
}

/// The default run: render, save, time, print.
fn render(o: &Options, mesh: &Mesh, name: &str) -> Result<(), Box<dyn std::error::Error>> {
    let camera = o.camera();
    camera.validate()?;
    let settings = RenderSettings { supersample: o.supersample, ..RenderSettings::default() };
    let mut renderer = Renderer::with_backend(settings, o.backend.backend())?;
    println!(
        "{name}: {} vertices, {} triangles, {} edges; {}x{}, F = {}, {} camera",
        mesh.positions().len(),
        mesh.triangles().len(),
        mesh.topology().edges().len(),
        camera.width,
        camera.height,
        o.supersample,
        if o.orthographic { "orthographic" } else { "perspective" }
    );
    println!("backend: {}", renderer.backend_name());
    let shift = (camera.width / 50).max(1);
    let first = run_once(&mut renderer, mesh, &camera, shift)?;
    diffsil::io::save_png(&first.image, &o.out)?;
    let (mut forward, mut backward) = (Vec::new(), Vec::new());
    for _ in 0..o.repeat {
        let run = run_once(&mut renderer, mesh, &camera, shift)?;
        forward.push(run.forward_s);
        backward.push(run.backward_s);
    }
    let ms = |s: f64| format!("{:.2} ms", s * 1e3);
    println!(
        "forward:  first {}, median of {} more {}",
        ms(first.forward_s),
        o.repeat,
        if o.repeat > 0 { ms(median(forward)) } else { "-".into() }
    );
    println!(
        "backward: first {}, median of {} more {}   (L = Σ (I − T)², T = the image shifted {shift} px right; L = {:.1})",
        ms(first.backward_s),
        o.repeat,
        if o.repeat > 0 { ms(median(backward)) } else { "-".into() },
        first.loss
    );
    println!(
        "triangles clipped: {}, culled: {}; contour candidates: {} edges; backward segments (edge, pixel): {} visited, \
         {} visible",
        first.clipped, first.culled, first.candidates, first.segments, first.visible
    );
    let covered = first.image.data().iter().filter(|&&v| v > 0.0).count();
    println!("wrote {} ({covered} pixels touched)", o.out.display());
    Ok(())
}

/// `--memory`: peak heap on the CPU backend, GPU buffer bytes on the GPU backend.
fn memory(o: &Options, mesh: &Mesh, name: &str) -> Result<(), Box<dyn std::error::Error>> {
    let camera = o.camera();
    camera.validate()?;
    let settings = RenderSettings { supersample: o.supersample, ..RenderSettings::default() };
    let (w, h) = (camera.width as u64, camera.height as u64);
    let shift = (camera.width / 50).max(1);
    println!(
        "{name}: {} vertices, {} triangles; {w}x{h}, F = {}; forward + L2 loss + backward to 3D vertices",
        mesh.positions().len(),
        mesh.triangles().len(),
        o.supersample
    );
    let words = (o.supersample * o.supersample).div_ceil(16) as u64;
    println!(
        "theoretical minimum: one {}-bit sample mask per pixel = {} (the f32 image itself is {})",
        words * 16,
        mib(w * h * words * 2),
        mib(w * h * 4)
    );

    // CPU backend.
    let mut renderer = Renderer::with_backend(settings, Backend::Cpu)?;
    let baseline = heap::current();
    heap::reset_peak();
    let frame = renderer.render(mesh, &[camera])?;
    let forward_peak = heap::peak() - baseline;
    let frame_bytes = heap::current().saturating_sub(baseline);
    let image = &frame.images()[0];
    let l2 = loss::squared_error(image, &shifted(image, shift))?;
    let peak_so_far = heap::peak(); // forward, then the loss (its target is a temporary)
    heap::reset_peak();
    let before_backward = heap::current();
    let grads = renderer.backward(&frame, &[l2.grad])?;
    let backward_peak = heap::peak() - before_backward;
    let total_peak = peak_so_far.max(heap::peak()) - baseline;
    println!("CPU backend (Rust heap, counting global allocator; {baseline} bytes held before, mesh included):");
    println!("  peak during the forward:                    {}", mib(forward_peak));
    println!("  kept by the Frame for the backward:         {}", mib(frame_bytes));
    println!(
        "  peak during the backward, above its inputs: {}  (inputs: the Frame, the loss's target and ∂L/∂I images)",
        mib(backward_peak)
    );
    println!("  peak of forward + loss + backward:          {}", mib(total_peak));
    drop((frame, grads));

    // GPU backend.
    let context = match GpuContext::new(&GpuOptions::from_env()) {
        Ok(context) => context,
        Err(e) => {
            println!("GPU backend: not measured ({e})");
            return Ok(());
        }
    };
    let device = context.device().clone();
    println!("GPU backend on {}:", context.adapter());
    let mut renderer = Renderer::with_gpu_context(settings, context)?;
    let report = |when: &str| -> Option<u64> {
        let report = device.generate_allocator_report()?;
        let mut by_label: Vec<(String, u64)> = Vec::new();
        for a in &report.allocations {
            match by_label.iter_mut().find(|(name, _)| *name == a.name) {
                Some((_, bytes)) => *bytes += a.size,
                None => by_label.push((a.name.clone(), a.size)),
            }
        }
        by_label.sort_by(|a, b| b.1.cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
        let ours: u64 = by_label.iter().filter(|(n, _)| n.starts_with("diffsil")).map(|(_, b)| b).sum();
        let list: Vec<String> = by_label.iter().map(|(n, b)| format!("{n} {}", mib(*b))).collect();
        println!(
            "  {when}: {} live in {} allocations ({} of them in diffsil's buffers, the rest wgpu's own), \
             {} reserved in {} memory blocks",
            mib(report.total_allocated_bytes),
            report.allocations.len(),
            mib(ours),
            mib(report.total_reserved_bytes),
            report.blocks.len(),
        );
        println!("    by label: {}", list.join(", "));
        Some(report.total_allocated_bytes)
    };
    let frame = renderer.render(mesh, &[camera])?;
    let after_forward = report("after the forward");
    let image = &frame.images()[0];
    let l2 = loss::squared_error(image, &shifted(image, shift))?;
    renderer.backward(&frame, &[l2.grad])?;
    let after_backward = report("after the backward");
    match after_forward.zip(after_backward) {
        Some((f, b)) => println!(
            "  GPU buffer bytes: {} (the larger of the two samples; taken between calls, so a \
             transient buffer freed within a call would not be seen)",
            mib(f.max(b))
        ),
        None => println!(
            "  GPU buffer bytes: not available: this wgpu backend ({:?}) gives no allocator report \
             (Vulkan and DX12 do)",
            renderer.adapter().map(|a| a.backend)
        ),
    }
    Ok(())
}

fn main() {
    let o = Options::parse();
    if let Err(e) = run(&o) {
        eprintln!("render: {e}");
        std::process::exit(1);
    }
}

fn run(o: &Options) -> Result<(), Box<dyn std::error::Error>> {
    let (mesh, name) = load(o)?;
    if o.memory {
        memory(o, &mesh, &name)
    } else {
        render(o, &mesh, &name)
    }
}
