//! The before/after pictures of a fit.

use std::path::Path;

use diffsil::Image;

/// Writes one [`comparison_sheet`] per view to `out` (`view0.png`, `view1.png`, …), creating the
/// folder, and says so.
pub fn save_comparison_sheets(
    out: &Path,
    targets: &[Image],
    before: &[Image],
    after: &[Image],
) -> Result<(), Box<dyn std::error::Error>> {
    std::fs::create_dir_all(out)?;
    for (view, target) in targets.iter().enumerate() {
        comparison_sheet(target, &before[view], &after[view]).save(out.join(format!("view{view}.png")))?;
    }
    println!(
        "wrote {} pictures to {} (rows: before, after; columns: target, fitted, difference)",
        targets.len(),
        out.display()
    );
    Ok(())
}

/// A picture a person can read: rows before/after, columns target | fitted | difference
/// (red: target only, cyan: fitted only, white: both), each pixel drawn 4×4 for images up to 64
/// pixels, fewer times for larger ones (once from 256).
pub fn comparison_sheet(target: &Image, before: &Image, after: &Image) -> image::RgbImage {
    let (w, h) = (target.width(), target.height());
    let zoom = (256 / w.max(h)).clamp(1, 4);
    let gap = 4;
    let mut sheet = image::RgbImage::from_pixel(3 * w * zoom + 2 * gap, 2 * h * zoom + gap, image::Rgb([60, 60, 60]));
    for (row, fitted) in [before, after].into_iter().enumerate() {
        for i in 0..h {
            for j in 0..w {
                let t = target.get(i, j).clamp(0.0, 1.0);
                let f = fitted.get(i, j).clamp(0.0, 1.0);
                let gray = |v: f32| image::Rgb([(v * 255.0) as u8; 3]);
                let diff = image::Rgb([(t * 255.0) as u8, (f * 255.0) as u8, (f * 255.0) as u8]);
                for (col, color) in [gray(t), gray(f), diff].into_iter().enumerate() {
                    for di in 0..zoom {
                        for dj in 0..zoom {
                            let x = col as u32 * (w * zoom + gap) + j * zoom + dj;
                            let y = row as u32 * (h * zoom + gap) + i * zoom + di;
                            sheet.put_pixel(x, y, color);
                        }
                    }
                }
            }
        }
    }
    sheet
}
