//! Tests of [`bin`](super): tile ranges.

use super::*;

/// The tile range as first written: pixel range by Euclidean division, then tiles.
fn reference_tiles(params: &RasterParams, snapped: &[[i32; 2]], tri: [u32; 3]) -> Option<[u32; 4]> {
    let v = tri.map(|i| snapped[i as usize]);
    if v.contains(&INVALID_SNAPPED_VERTEX) {
        return None;
    }
    let units = params.units as i32;
    let span = |c: [i32; 3], size: u32| -> Option<(u32, u32)> {
        let lo = (c[0].min(c[1]).min(c[2]) - 1).div_euclid(units);
        let hi = (c[0].max(c[1]).max(c[2]) + 1).div_euclid(units);
        if hi < 0 || lo >= size as i32 {
            return None;
        }
        Some((lo.max(0) as u32 / params.tile_size, hi.min(size as i32 - 1) as u32 / params.tile_size))
    };
    let (tx0, tx1) = span(v.map(|p| p[0]), params.width)?;
    let (ty0, ty1) = span(v.map(|p| p[1]), params.height)?;
    Some([tx0, ty0, tx1, ty1])
}

fn random_scene(seed: u64, params: &RasterParams) -> (Vec<ScreenVertex>, Vec<[i32; 2]>, Vec<[u32; 3]>) {
    let mut state = seed;
    let mut rand = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f32 / (1u64 << 53) as f32
    };
    let (w, h) = (params.width as f32, params.height as f32);
    let screen: Vec<ScreenVertex> = (0..60)
        .map(|k| {
            let mut p = [rand() * 1.4 * w - 0.2 * w, rand() * 1.4 * h - 0.2 * h];
            if k % 7 == 0 {
                p = p.map(|c| c.round()); // on pixel borders
            }
            ScreenVertex { position: p, valid: (k % 23 != 5) as u32, pad: 0 }
        })
        .collect();
    let snapped = screen.iter().map(|v| params.snap_vertex(v)).collect();
    let triangles = (0..80)
        .map(|_| {
            let a = (rand() * 60.0) as u32 % 60;
            // Mostly small triangles (near vertices), some large ones.
            let near = |r: f32| ((a as f32 + (r - 0.5) * 6.0).rem_euclid(60.0)) as u32 % 60;
            if rand() < 0.7 {
                [a, near(rand()), near(rand())]
            } else {
                [a, (rand() * 60.0) as u32 % 60, (rand() * 60.0) as u32 % 60]
            }
        })
        .collect();
    (screen, snapped, triangles)
}

#[test]
fn tile_ranges_match_the_reference() {
    for f in [1, 3, 4, 5, 16] {
        for tile_size in [1, 2, 8, 64] {
            let mut params = RasterParams::new(37, 20, f, 1.0, 0.0).unwrap();
            params.set_tile_size(tile_size);
            let (_, snapped, triangles) = random_scene(0x9e37_79b9_7f4a_7c15 ^ (f * 131 + tile_size) as u64, &params);
            for &tri in &triangles {
                assert_eq!(
                    triangle_tiles(&params, &snapped, tri),
                    reference_tiles(&params, &snapped, tri),
                    "F={f} tile {tile_size} {tri:?}"
                );
            }
        }
    }
}
