//! The outline nuisance parameter of a [`PoseFit`](super::PoseFit): one scalar `a` in [−1, 1]
//! that grows (`a > 0`) or shrinks (`a < 0`) every rendered silhouette by up to one pixel before
//! it is compared with its target, in image space:
//!
//! `R'_p = R_p + a·(D_p − R_p)` for `a ≥ 0`, `R'_p = R_p + |a|·(E_p − R_p)` for `a < 0`,
//!
//! with `D_p` and `E_p` the largest and smallest coverage in the 3×3 neighbourhood of pixel `p`
//! (outside the image counts as background): a grey-scale dilation and erosion by one pixel.
//! `a = ±1` is the whole dilation or erosion. A mask one pixel too thin has lost whatever of the
//! body was thinner than two pixels (forearms at 64²); moving the surface inward cannot make a
//! limb vanish, but eroding the render does, so the fit need not hide the limb to match.
//! `R'` is increasing in `a` on both sides (`D ≥ R ≥ E`), continuous at 0, and linear in `R`
//! once the neighbourhood's extreme pixel is fixed, which is how the backward treats it
//! (the max and min pass their gradient to the pixel that attains them).

use crate::Image;

/// The outlined image `R'` and, per pixel, the index of the neighbourhood pixel whose value was
/// blended in (`u32::MAX`: the background outside the image).
pub(crate) struct Outlined {
    pub(crate) image: Image,
    source: Vec<u32>,
}

/// Applies the outline nuisance `a` (clamped to [−1, 1]) to `image`.
pub(crate) fn apply(image: &Image, a: f32) -> Outlined {
    let (w, h) = (image.width() as i64, image.height() as i64);
    let a = a.clamp(-1.0, 1.0);
    let grow = a >= 0.0;
    let t = a.abs();
    let data = image.data();
    let mut out = image.clone();
    let mut source = vec![u32::MAX; data.len()];
    if t == 0.0 {
        return Outlined { image: out, source };
    }
    let wu = w as usize;
    for r in 0..h {
        for c in 0..w {
            let p = (r * w + c) as usize;
            // Most pixels (background, interior) have a 3×3 neighbourhood of one value: then its
            // extreme is that value, and the search below keeps the first pixel it visits (it
            // replaces only on a strict improvement, `extreme_of`). Same result, without the search.
            if r > 0 && c > 0 && r + 1 < h && c + 1 < w {
                let v = data[p];
                let uniform = [p - wu, p, p + wu].iter().all(|&m| data[m - 1..=m + 1].iter().all(|&x| x == v));
                if uniform {
                    let k = p - wu - 1;
                    out.data_mut()[p] = data[p] + t * (data[k] - data[p]);
                    source[p] = k as u32;
                    continue;
                }
            }
            let (extreme, k) = extreme_of((data, w, h), r, c, grow);
            out.data_mut()[p] = data[p] + t * (extreme - data[p]);
            source[p] = k;
        }
    }
    Outlined { image: out, source }
}

/// The largest (`grow`) or smallest coverage in the 3×3 neighbourhood of pixel `(r, c)` of
/// `data` (`w` × `h`), and the index of the first pixel in row-major order that holds it;
/// `(0, u32::MAX)` where the background outside the image wins an erosion.
fn extreme_of((data, w, h): (&[f32], i64, i64), r: i64, c: i64, grow: bool) -> (f32, u32) {
    let mut best = None::<(f32, u32)>;
    let mut outside = false;
    for dr in -1..=1 {
        for dc in -1..=1 {
            let (rr, cc) = (r + dr, c + dc);
            if rr < 0 || cc < 0 || rr >= h || cc >= w {
                outside = true;
                continue;
            }
            let k = (rr * w + cc) as usize;
            let v = data[k];
            let better = match best {
                None => true,
                Some((b, _)) => (grow && v > b) || (!grow && v < b),
            };
            if better {
                best = Some((v, k as u32));
            }
        }
    }
    // The background outside the image is 0: it wins an erosion, never a dilation.
    match best {
        Some((v, k)) if grow || !(outside && v > 0.0) => (v, k),
        _ => (0.0, u32::MAX),
    }
}

/// Back-propagates `grad` (`∂E/∂R'`) through [`apply`] at `a`: returns `∂E/∂R` and `∂E/∂a`
/// (one-sided at `a = 0`: the dilation side's, `Σ_p g_p (D_p − R_p)`).
pub(crate) fn backward(image: &Image, outlined: &Outlined, a: f32, grad: &Image) -> (Image, f64) {
    let a = a.clamp(-1.0, 1.0);
    let t = a.abs();
    let data = image.data();
    let mut d_image = grad.clone();
    let mut d_a = 0.0f64;
    let sign = if a >= 0.0 { 1.0 } else { -1.0 };
    for (p, &g) in grad.data().iter().enumerate() {
        let k = outlined.source[p];
        let extreme = if k == u32::MAX { 0.0 } else { data[k as usize] };
        if t == 0.0 && a >= 0.0 {
            // The dilation side at a = 0: its extreme is the 3×3 maximum, which `apply` did not
            // need; recompute it here.
            let d = dilated(image, p);
            d_a += f64::from(g) * f64::from(d - data[p]);
            continue;
        }
        d_a += f64::from(g) * sign * f64::from(extreme - data[p]);
        d_image.data_mut()[p] -= t * g;
        if k != u32::MAX {
            d_image.data_mut()[k as usize] += t * g;
        }
    }
    (d_image, d_a)
}

/// The 3×3 maximum around pixel `p` of `image`.
fn dilated(image: &Image, p: usize) -> f32 {
    let (w, h) = (image.width() as i64, image.height() as i64);
    let (r, c) = (p as i64 / w, p as i64 % w);
    let mut best = 0.0f32;
    for rr in (r - 1).max(0)..=(r + 1).min(h - 1) {
        for cc in (c - 1).max(0)..=(c + 1).min(w - 1) {
            best = best.max(image.data()[(rr * w + cc) as usize]);
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::random::SplitMix64;

    /// A 5×4 image of distinct coverages in [0, 1).
    fn image() -> Image {
        let mut rng = SplitMix64::new(11);
        Image::from_vec(5, 4, (0..20).map(|_| rng.range(0.0, 1.0)).collect()).unwrap()
    }

    /// `Σ_p w_p R'_p`: a linear loss, whose gradient with respect to `R'` is `w`.
    fn loss(image: &Image, a: f32, w: &[f32]) -> f64 {
        apply(image, a).image.data().iter().zip(w).map(|(r, w)| f64::from(*r) * f64::from(*w)).sum()
    }

    #[test]
    fn whole_outlines_are_the_3x3_max_and_min_and_zero_is_the_identity() {
        let r = image();
        assert_eq!(apply(&r, 0.0).image, r);
        for (a, pick) in [(1.0f32, f32::max as fn(f32, f32) -> f32), (-1.0, f32::min)] {
            let out = apply(&r, a).image;
            for row in 0..4i64 {
                for col in 0..5i64 {
                    let mut v = if a > 0.0 { 0.0f32 } else { 1.0 };
                    for (dr, dc) in (-1..=1).flat_map(|dr| (-1..=1).map(move |dc| (dr, dc))) {
                        let (rr, cc) = (row + dr, col + dc);
                        let x = if rr < 0 || cc < 0 || rr >= 4 || cc >= 5 { 0.0 } else { r.get(rr as u32, cc as u32) };
                        v = pick(v, x);
                    }
                    assert_eq!(out.get(row as u32, col as u32), v, "a = {a} at ({row}, {col})");
                }
            }
        }
    }

    #[test]
    fn uniform_neighbourhoods_take_the_searched_extreme_and_source() {
        // Background, a solid block, a grey rim and a lone pixel: most neighbourhoods uniform.
        let (w, h) = (12u32, 10u32);
        let mut image = Image::filled(w, h, 0.0);
        for r in 2..8u32 {
            for c in 3..9u32 {
                let rim = r == 2 || r == 7 || c == 3 || c == 8;
                image.data_mut()[(r * w + c) as usize] = if rim { 0.25 } else { 1.0 };
            }
        }
        image.data_mut()[11] = 0.5;
        image.data_mut()[(9 * w) as usize] = -0.0;
        let data = image.data();
        for a in [0.7f32, -0.4, 1.0, -1.0] {
            let outlined = apply(&image, a);
            for r in 0..h as i64 {
                for c in 0..w as i64 {
                    let p = (r * w as i64 + c) as usize;
                    let (extreme, k) = extreme_of((data, w as i64, h as i64), r, c, a >= 0.0);
                    let expected = data[p] + a.abs() * (extreme - data[p]);
                    assert_eq!(outlined.source[p], k, "a = {a}, pixel ({r}, {c})");
                    assert_eq!(outlined.image.data()[p].to_bits(), expected.to_bits(), "a = {a}, pixel ({r}, {c})");
                }
            }
        }
    }

    #[test]
    fn the_backward_matches_finite_differences() {
        let r = image();
        let mut rng = SplitMix64::new(5);
        let w: Vec<f32> = (0..20).map(|_| rng.range(-1.0, 1.0)).collect();
        let grad = Image::from_vec(5, 4, w.clone()).unwrap();
        for a in [0.6f32, -0.4, 0.0] {
            let outlined = apply(&r, a);
            let (d_image, d_a) = backward(&r, &outlined, a, &grad);
            // Piecewise linear: a small step that changes no 3×3 extreme is exact up to rounding.
            let h = 1e-3;
            for p in 0..20 {
                let (mut plus, mut minus) = (r.clone(), r.clone());
                plus.data_mut()[p] += h;
                minus.data_mut()[p] -= h;
                let numeric = (loss(&plus, a, &w) - loss(&minus, a, &w)) / (2.0 * f64::from(h));
                assert!((f64::from(d_image.data()[p]) - numeric).abs() < 1e-3, "a = {a}, pixel {p}");
            }
            // At a = 0 the derivative is the growing side's (one-sided).
            let numeric = if a == 0.0 {
                (loss(&r, h, &w) - loss(&r, 0.0, &w)) / f64::from(h)
            } else {
                (loss(&r, a + h, &w) - loss(&r, a - h, &w)) / (2.0 * f64::from(h))
            };
            assert!((d_a - numeric).abs() < 1e-3, "a = {a}: ∂/∂a {d_a} vs {numeric}");
        }
    }
}
