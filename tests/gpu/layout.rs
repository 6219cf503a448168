//! The Rust buffer structs and their WGSL twins in `shaders/shared/layout.wgsl` agree on every
//! field's offset and on the array stride: each struct is uploaded with distinct values in every
//! field (two elements, so the stride matters), a shader reads each field and writes its bits in
//! declaration order, and the result must be the Rust struct's own words.
//!
//! Run on lavapipe with `WGPU_BACKEND=vulkan DIFFSIL_REQUIRE_GPU=1 cargo test --test gpu layout::`.

use crate::common::gpu::gpu_or_skip;
use bytemuck::Pod;
use diffsil::gpu::{GpuContext, Readback};
use diffsil::mirror::{EdgeGrad, RasterParams, ScreenVertex};
use diffsil::mirror::{FrameParams, FrameUniform, GpuView, MAX_VIEWS};
use diffsil::ViewParams;

/// Distinct words `0x4000_0000 + start + k` (normal f32 values when read as floats), so every
/// field holds a distinct value.
fn distinct<T: Pod>(start: u32) -> T {
    let mut value = T::zeroed();
    let words: &mut [u32] = bytemuck::cast_slice_mut(bytemuck::bytes_of_mut(&mut value));
    for (k, w) in words.iter_mut().enumerate() {
        *w = 0x4000_0000 + start + k as u32;
    }
    value
}

/// Uploads two `T`s as `array<T>` (storage) and runs `body`, which writes `out[k]` for each field
/// of element `i` (`words` words per element) as `bitcast<u32>(...)`.
fn round_trip<T: Pod>(ctx: &GpuContext, wgsl_type: &str, body: &str) {
    let words = std::mem::size_of::<T>() / 4;
    let data = [distinct::<T>(1), distinct::<T>(1001)];
    let source = format!(
        "//!include shared/layout.wgsl\n\
         @group(0) @binding(0) var<storage, read> input: array<{wgsl_type}>;\n\
         @group(0) @binding(1) var<storage, read_write> out: array<u32>;\n\
         @compute @workgroup_size(1) fn main() {{\n\
           for (var i = 0u; i < 2u; i++) {{\n\
             let v = input[i];\n\
             var k = i * {words}u;\n\
             {body}\n\
           }}\n\
         }}\n"
    );
    let pipeline = ctx.compute_pipeline_from_wgsl(wgsl_type, &source, "main").unwrap();
    let input = ctx.storage_buffer_init("layout input", &data).unwrap();
    let output = ctx.storage_buffer("layout output", (2 * words * 4) as u64).unwrap();
    let bind = ctx.bind_buffers("layout", &pipeline, 0, &[&input, &output]).unwrap();
    let mut encoder = ctx.encoder("layout");
    {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: None, timestamp_writes: None });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups(1, 1, 1);
    }
    let got: Vec<u32> = Readback::new("layout").submit_and_read(ctx, encoder, &output, 2 * words).unwrap();
    let expected: Vec<u32> = bytemuck::cast_slice(&data).to_vec();
    assert_eq!(got, expected, "{wgsl_type}: fields (in declaration order) vs the Rust struct's words");
}

/// WGSL statements writing `v.<field>` (scalar or vector) for every listed field.
fn fields(prefix: &str, list: &[(&str, u32)]) -> String {
    let mut body = String::new();
    for (name, lanes) in list {
        if *lanes == 1 {
            body += &format!("out[k] = bitcast<u32>({prefix}{name}); k++;\n");
        } else {
            for lane in ["x", "y", "z", "w"].iter().take(*lanes as usize) {
                body += &format!("out[k] = bitcast<u32>({prefix}{name}.{lane}); k++;\n");
            }
        }
    }
    body
}

const RASTER: &[(&str, u32)] = &[
    ("width", 1),
    ("height", 1),
    ("supersample", 1),
    ("units", 1),
    ("half_step", 1),
    ("words_per_pixel", 1),
    ("tile_size", 1),
    ("tiles_x", 1),
    ("tiles_y", 1),
    ("inside", 1),
    ("outside", 1),
    ("inv_samples", 1),
];

#[test]
fn shared_structs_match_their_wgsl_twins() {
    let Some(ctx) = gpu_or_skip("shared_structs_match_their_wgsl_twins") else { return };
    round_trip::<ScreenVertex>(&ctx, "ScreenVertex", &fields("v.", &[("position", 2), ("valid", 1), ("pad", 1)]));
    round_trip::<RasterParams>(&ctx, "RasterParams", &fields("v.", RASTER));
    round_trip::<EdgeGrad>(&ctx, "EdgeGrad", &fields("v.", &[("a", 2), ("b", 2)]));
    round_trip::<ViewParams>(
        &ctx,
        "ViewParams",
        &fields(
            "v.",
            &[
                ("row0", 4),
                ("row1", 4),
                ("row2", 4),
                ("centre", 2),
                ("scale", 2),
                ("perspective", 1),
                ("near", 1),
                ("far", 1),
                ("width", 1),
                ("height", 1),
                ("pad0", 1),
                ("pad1", 1),
                ("pad2", 1),
            ],
        ),
    );
    let gpu_view = fields("v.raster.", RASTER)
        + &fields("v.", &[("pixel_offset", 1), ("tile_offset", 1), ("vertex_offset", 1), ("pad1", 1)]);
    round_trip::<GpuView>(&ctx, "GpuView", &gpu_view);
    round_trip::<FrameParams>(
        &ctx,
        "FrameParams",
        &fields(
            "v.",
            &[
                ("view_count", 1),
                ("vertex_count", 1),
                ("triangle_count", 1),
                ("edge_count", 1),
                ("total_tiles", 1),
                ("total_pixels", 1),
                ("bin_capacity", 1),
                ("bin_list_offset", 1),
                ("orient_offset", 1),
                ("zero", 1),
                ("large_offset", 1),
                ("parts", 1),
                ("loop_budget", 1),
                ("partial_capacity", 1),
                ("max_workgroups", 1),
                ("pad2", 1),
            ],
        ),
    );
}

/// The frame uniform as a *uniform* buffer (stricter layout rules than storage): the params and
/// the last view's offsets must read back as written.
#[test]
fn frame_uniform_layout() {
    let Some(ctx) = gpu_or_skip("frame_uniform_layout") else { return };
    let mut frame: Box<FrameUniform> = bytemuck::zeroed_box();
    frame.params = distinct(7);
    frame.views[MAX_VIEWS - 1] = distinct(5000);
    let source = "//!include shared/layout.wgsl\n\
        @group(0) @binding(0) var<uniform> frame: FrameUniform;\n\
        @group(0) @binding(1) var<storage, read_write> out: array<u32>;\n\
        @compute @workgroup_size(1) fn main() {\n\
          out[0] = frame.params.view_count; out[1] = frame.params.pad2;\n\
          out[2] = frame.views[MAX_VIEWS - 1u].raster.width;\n\
          out[3] = bitcast<u32>(frame.views[MAX_VIEWS - 1u].raster.inv_samples);\n\
          out[4] = frame.views[MAX_VIEWS - 1u].tile_offset;\n\
        }\n";
    let pipeline = ctx.compute_pipeline_from_wgsl("frame uniform", source, "main").unwrap();
    let uniform = ctx.uniform_buffer_init("frame", &*frame).unwrap();
    let output = ctx.storage_buffer("out", 20).unwrap();
    let bind = ctx.bind_buffers("frame", &pipeline, 0, &[&uniform, &output]).unwrap();
    let mut encoder = ctx.encoder("frame");
    {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: None, timestamp_writes: None });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups(1, 1, 1);
    }
    let got: Vec<u32> = Readback::new("frame").submit_and_read(&ctx, encoder, &output, 5).unwrap();
    let last = &frame.views[MAX_VIEWS - 1];
    assert_eq!(
        got,
        vec![
            frame.params.view_count,
            frame.params.pad2,
            last.raster.width,
            last.raster.inv_samples.to_bits(),
            last.tile_offset
        ]
    );
}
