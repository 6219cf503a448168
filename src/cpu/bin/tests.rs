//! Tests of [`bin`](super) and [`bin_tiles`](super::bin_tiles): tile ranges, wanted cells, patches passed over.

use super::*;
use crate::cpu::edges;

/// Whether a triangle's on-screen vertices run with positive area (`cross(b − a, c − a) > 0`),
/// as first written.
fn positive_area(v: [[f32; 2]; 3]) -> bool {
    let p = v.map(|p| [p[0] as f64, p[1] as f64]);
    (p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) > (p[1][1] - p[0][1]) * (p[2][0] - p[0][0])
}

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

/// `bin_tiles` over small cells of a projected sphere of small triangles with a few cells
/// wanted (most patches passed over): each wanted cell lists exactly the triangles whose
/// grown snapped box overlaps the cell's part of the image, in patch order (positive first).
#[test]
fn patches_passed_over_lose_no_triangle() {
    let sphere = crate::scene::shapes::icosphere(3);
    let mut rng = crate::random::SplitMix64::new(0x853c_49e6_748f_ea9b);
    let mut rand = move || (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
    let mut lists = CellBins::default();
    let mut skipped = 0;
    for case in 0..24 {
        let params = RasterParams::new(40, 24, [1, 3, 4][case % 3], 1.0, 0.0).unwrap();
        // A random rotation about z then x, scaled to about the image's height; a third of
        // the vertices on whole pixels (boxes on cell borders), a few clipped.
        let (a, b) = (rand() * 6.3, rand() * 6.3);
        let screen: Vec<ScreenVertex> = sphere
            .positions()
            .iter()
            .enumerate()
            .map(|(k, p)| {
                let (x, y) = (p.x as f64 * a.cos() - p.y as f64 * a.sin(), p.x as f64 * a.sin() + p.y as f64 * a.cos());
                let y = y * b.cos() - p.z as f64 * b.sin();
                let mut q = [(20.0 + 13.0 * x) as f32, (12.0 + 13.0 * y) as f32];
                if k % 3 == 0 {
                    q = q.map(f32::round);
                }
                ScreenVertex { position: q, valid: (k % 97 != 5) as u32, pad: 0 }
            })
            .collect();
        let snapped: Vec<[i32; 2]> = screen.iter().map(|v| params.snap_vertex(v)).collect();
        let topology = sphere.topology();
        let triangles = topology.triangles();
        let boxes = snapped_boxes(&snapped, triangles);
        let mut orientation = vec![0; triangles.len()];
        edges::face_orientations(&screen, triangles, &mut orientation);
        let grid = CellGrid::new(&params, [4, 8, 16, 64][case % 4]);
        // Wanted: a few cells at or just beyond a random triangle's left or top side, where
        // a patch's box decides alone whether the cell's triangles are found; half of them the
        // cell that holds the first unit of a grown box whose side lies in the last three units
        // of a cell (a patch box a few units too small misses it).
        let mut slots = vec![u32::MAX; grid.count()];
        let mut wanted = Vec::new();
        let u = grid.cell_units as f64;
        while wanted.len() < 8 {
            let b = boxes[(rand() * triangles.len() as f64) as usize];
            if b == CULLED_BOX {
                continue;
            }
            let (mut x, mut y) =
                (b[0] as f64 + rand() * (b[2] - b[0]) as f64, b[1] as f64 + rand() * (b[3] - b[1]) as f64);
            let (left, border) = (wanted.len() % 2 == 0, wanted.len() % 4 < 2);
            let side = if left { b[0] } else { b[1] } as i64 - 1;
            if border && side.rem_euclid(grid.cell_units as i64) < grid.cell_units as i64 - 3 {
                continue;
            }
            let beyond = if border { 0.0 } else { rand() * 2.0 * u };
            if left {
                x = side as f64 - beyond;
            } else {
                y = side as f64 - beyond;
            }
            let (cx, cy) = ((x / u).floor(), (y / u).floor());
            if cx < 0.0 || cy < 0.0 || cx >= grid.cells_x as f64 || cy >= grid.cells_y as f64 {
                continue;
            }
            let c = cy as usize * grid.cells_x as usize + cx as usize;
            if slots[c] == u32::MAX {
                slots[c] = wanted.len() as u32;
                wanted.push(c);
            }
        }
        let faces = (&boxes[..], &orientation[..]);
        bin_tiles(&params, grid, &screen, topology, faces, None, &slots, wanted.len(), &mut lists);
        let (u, limit) = (grid.cell_units as i64, [40 * params.units as i64, 24 * params.units as i64]);
        let overlaps = |b: [i32; 4], c: usize| {
            let cell = [(c % grid.cells_x as usize) as i64, (c / grid.cells_x as usize) as i64];
            b != CULLED_BOX
                && (0..2).all(|k| {
                    (b[k] as i64 - 1).max(cell[k] * u)
                        <= (b[k + 2] as i64 + 1).min((cell[k] + 1) * u - 1).min(limit[k] - 1)
                })
        };
        let order = topology.face_patches().faces();
        for (slot, &c) in wanted.iter().enumerate() {
            let listed: Vec<u32> = order.iter().copied().filter(|&t| overlaps(boxes[t as usize], c)).collect();
            let (mut expected, mut other): (Vec<u32>, Vec<u32>) = listed
                .iter()
                .partition(|&&t| positive_area(triangles[t as usize].map(|v| screen[v as usize].position)));
            other.reverse();
            expected.extend(other);
            let got: Vec<u32> = lists.bins.tile(slot).map(|(t, _, _)| t).collect();
            assert_eq!(got, expected, "case {case} cell {c}");
            for (t, b, v) in lists.bins.tile(slot) {
                assert_eq!((*b, *v), float_box(&screen, triangles[t as usize]));
            }
        }
        // The test is about the patches that are passed over: count those that overlap no
        // wanted cell although some of their triangles' boxes come within a cell of one.
        skipped += topology
            .face_patches()
            .iter()
            .filter(|patch| !patch.iter().any(|&t| wanted.iter().any(|&c| overlaps(boxes[t as usize], c))))
            .count();
    }
    eprintln!("patches passed over: {skipped}");
    assert!(skipped > 100, "{skipped}");
}

/// `bin_tiles` lists, for each wanted tile, what `bin` lists for it.
#[test]
fn wanted_tiles_get_the_full_lists() {
    // One set of buffers for every case: each call refills what the one before left.
    let mut lists = CellBins::default();
    for (f, tile_size) in [(4, 1), (3, 2), (4, 8)] {
        let mut params = RasterParams::new(40, 24, f, 1.0, 0.0).unwrap();
        params.set_tile_size(tile_size);
        let (screen, snapped, triangles) = random_scene(0x2545_f491_4f6c_dd1d ^ f as u64, &params);
        let mut full = Bins::default();
        bin(&params, &screen, &snapped, &triangles, &mut full);
        let mut slots = vec![u32::MAX; params.tile_count()];
        let mut wanted = Vec::new();
        for t in (0..params.tile_count()).rev().step_by(3) {
            slots[t] = wanted.len() as u32;
            wanted.push(t);
        }
        let boxes = snapped_boxes(&snapped, &triangles);
        let topology = Topology::new(screen.len(), triangles.clone()).unwrap();
        let mut orientation = vec![0; triangles.len()];
        edges::face_orientations(&screen, &triangles, &mut orientation);
        let faces = (&boxes[..], &orientation[..]);
        bin_tiles(&params, CellGrid::tiles(&params), &screen, &topology, faces, None, &slots, wanted.len(), &mut lists);
        // Each face's place in patch order.
        let mut place = vec![0; triangles.len()];
        for (k, &f) in topology.face_patches().faces().iter().enumerate() {
            place[f as usize] = k;
        }
        for (slot, &t) in wanted.iter().enumerate() {
            // The same entries; the positive triangles first in patch order, then the
            // others in reverse patch order.
            let mut a: Vec<_> = full.tile(t).map(|(i, b, v)| (i, *b, *v)).collect();
            a.sort_by_key(|e| place[e.0 as usize]);
            let (mut positive, mut other): (Vec<_>, Vec<_>) = a.into_iter().partition(|e| positive_area(e.2));
            other.reverse();
            positive.extend(other);
            let b: Vec<_> = lists.bins.tile(slot).map(|(i, b, v)| (i, *b, *v)).collect();
            assert_eq!(positive, b, "tile {t}");
        }
    }
}

/// The boundary boxes of [`back_face_boundary`]: none for a closed mesh, one per hole of an open
/// one, and no boundary at all (back faces kept) with a culled triangle or a boundary at ±2²²
/// units or beyond.
#[test]
fn back_face_boundary_only_where_snapping_is_within_a_unit() {
    let sphere = crate::scene::shapes::icosphere(1);
    let n = sphere.positions().len();
    let snapped: Vec<[i32; 2]> = (0..n as i32).map(|k| [k * 7 % 50, k * 11 % 40]).collect();
    let closed = back_face_boundary(sphere.topology(), &snapped, 0).unwrap();
    assert!(closed.boxes.is_empty());
    assert!(back_face_boundary(sphere.topology(), &snapped, 1).is_none(), "a culled triangle");
    let mut holed = sphere.triangles().to_vec();
    holed.remove(0);
    let holed = Topology::new(n, holed).unwrap();
    let hole = sphere.triangles()[0];
    let boundary = back_face_boundary(&holed, &snapped, 0).unwrap();
    let v = hole.map(|i| snapped[i as usize]);
    let expected = [
        v.iter().map(|p| p[0]).min().unwrap(),
        v.iter().map(|p| p[1]).min().unwrap(),
        v.iter().map(|p| p[0]).max().unwrap(),
        v.iter().map(|p| p[1]).max().unwrap(),
    ];
    assert_eq!(boundary.boxes, vec![expected]);
    for far in [1 << 22, -(1 << 22), i32::MAX - 1] {
        let mut moved = snapped.clone();
        moved[hole[1] as usize][0] = far;
        assert!(back_face_boundary(&holed, &moved, 0).is_none(), "boundary at {far}");
        // The same vertex far away does not matter to a closed mesh, which has no boundary.
        assert!(back_face_boundary(sphere.topology(), &moved, 0).is_some());
    }
    let mut near = snapped.clone();
    near[hole[1] as usize][0] = (1 << 22) - 1;
    assert!(back_face_boundary(&holed, &near, 0).is_some());
}
