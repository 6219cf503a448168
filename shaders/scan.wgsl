// `scan` — middle of the GPU twin of `cpu::bin::bin`: exclusive prefix sum of the per-tile counts
// into the CSR offsets of the bin lists (the CPU does it in a serial loop).
//
// Reads:  `frame`, `counts[0 .. total_tiles)`.
// Writes: `bins[0 ..= total_tiles]` (CSR offsets; `bins[total_tiles]` = entries needed),
//         `status[STATUS_NEEDED]` (entries needed, which the host compares with the capacity),
//         `status[STATUS_OVERFLOW]` (1 if the total does not fit in u32).
// Dispatch: exactly one workgroup of 256 invocations; each sums a contiguous chunk, the
// workgroup scans the 256 sums, then each writes its chunk's offsets. Deterministic.

//!include shared/frame.wgsl

@group(0) @binding(1) var<storage, read> counts: array<u32>;
@group(0) @binding(2) var<storage, read_write> bins: array<u32>;
@group(0) @binding(3) var<storage, read_write> status: array<u32>;

var<workgroup> sums: array<u32, 256>;
var<workgroup> overflow: atomic<u32>;

// Entry point (one workgroup for the frame): reads `counts`; writes the CSR offsets to `bins` and the
// entries needed to `status`.
@compute @workgroup_size(256)
fn main(@builtin(local_invocation_index) lid: u32) {
    let n = frame.params.total_tiles;
    let chunk = (n + 255u) / 256u;
    let start = min(lid * chunk, n);
    let end = min(start + chunk, n);
    var sum = 0u;
    for (var k = start; k < end; k++) {
        let next = sum + counts[k];
        if next < sum {
            atomicStore(&overflow, 1u);
        }
        sum = next;
    }
    sums[lid] = sum;
    workgroupBarrier();
    // Hillis–Steele inclusive scan of the 256 chunk sums.
    for (var step = 1u; step < 256u; step *= 2u) {
        var add = 0u;
        if lid >= step {
            add = sums[lid - step];
        }
        workgroupBarrier();
        let next = sums[lid] + add;
        if next < add {
            atomicStore(&overflow, 1u);
        }
        sums[lid] = next;
        workgroupBarrier();
    }
    var running = 0u;
    if lid > 0u {
        running = sums[lid - 1u];
    }
    for (var k = start; k < end; k++) {
        bins[k] = running;
        running += counts[k];
    }
    if lid == 255u {
        bins[n] = sums[255];
        status[STATUS_NEEDED] = sums[255];
        status[STATUS_OVERFLOW] = atomicLoad(&overflow);
    }
}
