//! The pictures of the `gradient_maps` example: a diverging colour map, the sheet (rows: motions;
//! columns: silhouette, analytic, finite difference, difference) with its tiny bitmap font, and
//! the PNG files.

use std::path::Path;

use diffsil::Image;

use super::{Agreement, AnalyticMaps, Motion};

/// One of the sheet's colour maps: blue `(59, 76, 192)` at `−scale`, white at 0, red
/// `(180, 4, 38)` at `+scale`, linear in between (clamped beyond). Zero is exactly white.
pub fn diverging(value: f64, scale: f64) -> image::Rgb<u8> {
    let t = if scale > 0.0 { (value / scale).clamp(-1.0, 1.0) } else { 0.0 };
    let end = if t < 0.0 { [59.0, 76.0, 192.0] } else { [180.0, 4.0, 38.0] };
    let a = t.abs();
    image::Rgb(end.map(|c: f64| (255.0 + (c - 255.0) * a).round() as u8))
}

/// A map as a picture on [`diverging`] colours, `zoom` screen pixels per image pixel.
fn map_picture(map: &[f64], n: u32, scale: f64, zoom: u32) -> image::RgbImage {
    image::RgbImage::from_fn(n * zoom, n * zoom, |x, y| diverging(map[(y / zoom * n + x / zoom) as usize], scale))
}

/// The silhouette as a grey picture (white inside), `zoom` screen pixels per image pixel.
fn silhouette_picture(image: &Image, zoom: u32) -> image::RgbImage {
    let n = image.width();
    image::RgbImage::from_fn(n * zoom, n * zoom, |x, y| {
        image::Rgb([(image.get(y / zoom, x / zoom).clamp(0.0, 1.0) * 255.0).round() as u8; 3])
    })
}

/// One row of the sheet.
pub struct SheetRow<'a> {
    /// The motion.
    pub motion: Motion,
    /// Analytic map.
    pub analytic: &'a [f64],
    /// Finite-difference map.
    pub finite_difference: &'a [f64],
    /// Their agreement (its `scale` colours the row).
    pub agreement: Agreement,
}

/// The sheet: a title, then per motion a caption and four pictures (silhouette, analytic, finite
/// difference, analytic − finite difference, all on the row's scale), then a colour bar.
pub fn sheet(silhouette: &Image, rows: &[SheetRow<'_>], title: &str) -> image::RgbImage {
    let n = silhouette.width();
    let zoom = (256 / n).max(1);
    let cell = n * zoom;
    let text = if cell >= 200 { 2 } else { 1 };
    let line = 9 * text;
    let (margin, gap) = (10, 8);
    let width = (2 * margin + 4 * cell + 3 * gap).max(2 * margin + font::width(title, text));
    let row_height = line + 4 + cell + gap;
    let height = margin + 2 * line + 24 + rows.len() as u32 * row_height + line + 16 + margin;
    let mut out = image::RgbImage::from_pixel(width, height, image::Rgb([255, 255, 255]));
    let ink = image::Rgb([20, 20, 20]);
    font::draw(&mut out, margin, margin, title, text, ink);
    let mut y = margin + line + 8;
    let headers = ["silhouette", "analytic (diffsil)", "finite difference", "analytic - fd"];
    for (k, h) in headers.iter().enumerate() {
        font::draw(&mut out, margin + k as u32 * (cell + gap), y, h, text, ink);
    }
    y += line + 4;
    for x in margin..width - margin {
        out.put_pixel(x, y, image::Rgb([160, 160, 160]));
    }
    y += 12;
    let sil = silhouette_picture(silhouette, zoom);
    for row in rows {
        let a = row.agreement;
        let caption = format!(
            "{}:  scale {:.2e}  cos {:.6}  rel err {:.1e}",
            row.motion.title(),
            a.scale,
            a.cosine,
            a.relative_error
        );
        font::draw(&mut out, margin, y, &caption, text, ink);
        y += line + 4;
        let difference: Vec<f64> = row.analytic.iter().zip(row.finite_difference).map(|(p, q)| p - q).collect();
        let pictures = [
            sil.clone(),
            map_picture(row.analytic, n, a.scale, zoom),
            map_picture(row.finite_difference, n, a.scale, zoom),
            map_picture(&difference, n, a.scale, zoom),
        ];
        for (k, p) in pictures.iter().enumerate() {
            image::imageops::replace(&mut out, p, (margin + k as u32 * (cell + gap)) as i64, y as i64);
        }
        y += cell + gap;
    }
    // Colour bar: −scale … 0 … +scale of each row.
    let bar_width = cell.clamp(64, 256);
    for x in 0..bar_width {
        let c = diverging(2.0 * x as f64 / (bar_width - 1) as f64 - 1.0, 1.0);
        for dy in 0..8 {
            out.put_pixel(margin + x, y + dy, c);
        }
    }
    font::draw(&mut out, margin + bar_width + 8, y, "-scale ... 0 ... +scale of the row", text, ink);
    out
}

/// A 5×7 pixel font for the sheet's captions: upper-case letters (lower case is drawn upper
/// case), digits and a little punctuation; other characters draw as `?`.
mod font {
    /// Rows top to bottom, bit 4 the leftmost column.
    fn glyph(c: char) -> [u8; 7] {
        match c.to_ascii_uppercase() {
            'A' => [14, 17, 17, 31, 17, 17, 17],
            'B' => [30, 17, 17, 30, 17, 17, 30],
            'C' => [14, 17, 16, 16, 16, 17, 14],
            'D' => [28, 18, 17, 17, 17, 18, 28],
            'E' => [31, 16, 16, 30, 16, 16, 31],
            'F' => [31, 16, 16, 30, 16, 16, 16],
            'G' => [14, 17, 16, 23, 17, 17, 15],
            'H' => [17, 17, 17, 31, 17, 17, 17],
            'I' => [14, 4, 4, 4, 4, 4, 14],
            'J' => [7, 2, 2, 2, 2, 18, 12],
            'K' => [17, 18, 20, 24, 20, 18, 17],
            'L' => [16, 16, 16, 16, 16, 16, 31],
            'M' => [17, 27, 21, 21, 17, 17, 17],
            'N' => [17, 17, 25, 21, 19, 17, 17],
            'O' => [14, 17, 17, 17, 17, 17, 14],
            'P' => [30, 17, 17, 30, 16, 16, 16],
            'Q' => [14, 17, 17, 17, 21, 18, 13],
            'R' => [30, 17, 17, 30, 20, 18, 17],
            'S' => [15, 16, 16, 14, 1, 1, 30],
            'T' => [31, 4, 4, 4, 4, 4, 4],
            'U' => [17, 17, 17, 17, 17, 17, 14],
            'V' => [17, 17, 17, 17, 17, 10, 4],
            'W' => [17, 17, 17, 21, 21, 21, 10],
            'X' => [17, 17, 10, 4, 10, 17, 17],
            'Y' => [17, 17, 17, 10, 4, 4, 4],
            'Z' => [31, 1, 2, 4, 8, 16, 31],
            '0' => [14, 17, 19, 21, 25, 17, 14],
            '1' => [4, 12, 4, 4, 4, 4, 14],
            '2' => [14, 17, 1, 2, 4, 8, 31],
            '3' => [31, 2, 4, 2, 1, 17, 14],
            '4' => [2, 6, 10, 18, 31, 2, 2],
            '5' => [31, 16, 30, 1, 1, 17, 14],
            '6' => [6, 8, 16, 30, 17, 17, 14],
            '7' => [31, 1, 2, 4, 8, 8, 8],
            '8' => [14, 17, 17, 14, 17, 17, 14],
            '9' => [14, 17, 17, 15, 1, 2, 12],
            '.' => [0, 0, 0, 0, 0, 12, 12],
            ',' => [0, 0, 0, 0, 12, 4, 8],
            ':' => [0, 12, 12, 0, 12, 12, 0],
            '-' => [0, 0, 0, 31, 0, 0, 0],
            '+' => [0, 4, 4, 31, 4, 4, 0],
            '=' => [0, 0, 31, 0, 31, 0, 0],
            '(' => [2, 4, 8, 8, 8, 4, 2],
            ')' => [8, 4, 2, 2, 2, 4, 8],
            '/' => [0, 1, 2, 4, 8, 16, 0],
            ' ' => [0; 7],
            _ => [14, 17, 1, 2, 4, 0, 4],
        }
    }

    /// Width in pixels of `s` at `scale`.
    pub fn width(s: &str, scale: u32) -> u32 {
        s.chars().count() as u32 * 6 * scale
    }

    /// Draws `s` with its top-left corner at `(x, y)`; what falls outside the image is dropped.
    pub fn draw(img: &mut image::RgbImage, x: u32, y: u32, s: &str, scale: u32, color: image::Rgb<u8>) {
        for (k, c) in s.chars().enumerate() {
            let rows = glyph(c);
            for (r, bits) in rows.iter().enumerate() {
                for col in 0..5u32 {
                    if bits & (16 >> col) == 0 {
                        continue;
                    }
                    for dy in 0..scale {
                        for dx in 0..scale {
                            let px = x + (k as u32 * 6 + col) * scale + dx;
                            let py = y + r as u32 * scale + dy;
                            if px < img.width() && py < img.height() {
                                img.put_pixel(px, py, color);
                            }
                        }
                    }
                }
            }
        }
    }
}

/// Writes the sheet and every map to `dir`.
pub fn write_pictures(
    dir: &Path,
    analytic: &AnalyticMaps,
    rows: &[SheetRow<'_>],
    title: &str,
) -> Result<(), Box<dyn std::error::Error>> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let n = analytic.silhouette.width();
    let save = |picture: &image::RgbImage, name: &str| -> Result<(), String> {
        let path = dir.join(name);
        picture.save(&path).map_err(|e| format!("{}: {e}", path.display()))
    };
    save(&sheet(&analytic.silhouette, rows, title), "gradient_maps.png")?;
    save(&silhouette_picture(&analytic.silhouette, 1), "silhouette.png")?;
    for row in rows {
        let scale = row.agreement.scale;
        let difference: Vec<f64> = row.analytic.iter().zip(row.finite_difference).map(|(p, q)| p - q).collect();
        let name = row.motion.name();
        save(&map_picture(row.analytic, n, scale, 1), &format!("{name}_analytic.png"))?;
        save(&map_picture(row.finite_difference, n, scale, 1), &format!("{name}_fd.png"))?;
        save(&map_picture(&difference, n, scale, 1), &format!("{name}_difference.png"))?;
    }
    Ok(())
}
