//! Compares the render of a cut with the render of full detail from the same camera (DESIGN.md §6):
//! changed pixels, skyline shift per column, the largest region merging added, and a diff picture.
//! Pixels: row 0 is the top; "building" means any pixel that is not exactly the background colour.
//! Invariant: every count is over the same `width × height` grid; the diff image has that size.

use crate::{CheckError, Image};

/// Largest per-channel difference (0–255) under which two pixels count as unchanged.
pub const COLOUR_TOLERANCE: u8 = 8;

/// Diff colours: pixels that are building in the cut only (added by merging) …
pub const DIFF_ADDED: [u8; 4] = [220, 30, 30, 255];
/// … building in the full render only (removed by the cut) …
pub const DIFF_REMOVED: [u8; 4] = [30, 70, 220, 255];
/// … building in both but with a colour change beyond the tolerance.
pub const DIFF_RECOLOURED: [u8; 4] = [240, 180, 0, 255];

/// What differs between a cut render and a full-detail render.
#[derive(Debug, Clone, PartialEq)]
pub struct ImageMetrics {
    pub width: u32,
    pub height: u32,
    /// Pixels whose colour differs by more than [`COLOUR_TOLERANCE`] in some channel.
    pub changed_px: u64,
    /// `changed_px` over all pixels.
    pub changed_fraction: f64,
    /// Pixels that are building in the cut but background in the full render.
    pub added_px: u64,
    /// Pixels that are background in the cut but building in the full render.
    pub removed_px: u64,
    /// Largest 4-connected region of added pixels.
    pub largest_added_region_px: u64,
    /// Largest 4-connected region of removed pixels.
    pub largest_removed_region_px: u64,
    /// Columns where either image has a building (the skyline statistics run over these).
    pub skyline_columns: u32,
    /// Largest |top building row in cut − top building row in full| over those columns; a column
    /// with no building in one image counts its skyline at the image bottom (row = height).
    pub skyline_max_shift_px: u32,
    /// Mean of the same absolute differences; 0 when no column has a building.
    pub skyline_mean_shift_px: f64,
    /// Unchanged pixels dimmed to grey, added red, removed blue, recoloured amber.
    pub diff: Image,
}

/// Compares `cut` with `full`; `background` is the exact clear colour of both renders. Errors when
/// the sizes differ or a buffer has the wrong length.
pub fn compare(cut: &Image, full: &Image, background: [u8; 4]) -> Result<ImageMetrics, CheckError> {
    if (cut.width, cut.height) != (full.width, full.height) {
        return Err(CheckError::Image(format!(
            "cut is {}×{} but full is {}×{}",
            cut.width, cut.height, full.width, full.height
        )));
    }
    let (w, h) = (cut.width as usize, cut.height as usize);
    for img in [cut, full] {
        if img.rgba.len() != w * h * 4 {
            return Err(CheckError::Image(format!(
                "{w}×{h} image holds {} bytes",
                img.rgba.len()
            )));
        }
    }
    let px = |img: &Image, i: usize| -> [u8; 4] {
        let p = &img.rgba[i * 4..i * 4 + 4];
        [p[0], p[1], p[2], p[3]]
    };
    let is_building = |p: [u8; 4]| p != background;

    let mut diff = Image::filled(cut.width, cut.height, [0, 0, 0, 255]);
    let mut added = vec![false; w * h];
    let mut removed = vec![false; w * h];
    let (mut changed_px, mut added_px, mut removed_px) = (0u64, 0u64, 0u64);
    for i in 0..w * h {
        let (a, b) = (px(cut, i), px(full, i));
        let changed = (0..4).any(|c| a[c].abs_diff(b[c]) > COLOUR_TOLERANCE);
        let (ba, bb) = (is_building(a), is_building(b));
        added[i] = ba && !bb;
        removed[i] = bb && !ba;
        changed_px += u64::from(changed);
        added_px += u64::from(added[i]);
        removed_px += u64::from(removed[i]);
        let colour = if added[i] {
            DIFF_ADDED
        } else if removed[i] {
            DIFF_REMOVED
        } else if changed {
            DIFF_RECOLOURED
        } else {
            let luma =
                (u32::from(b[0]) * 299 + u32::from(b[1]) * 587 + u32::from(b[2]) * 114) / 1000;
            let g = (100 + luma / 2) as u8;
            [g, g, g, 255]
        };
        diff.rgba[i * 4..i * 4 + 4].copy_from_slice(&colour);
    }

    let top_row = |img: &Image, x: usize| (0..h).find(|&y| is_building(px(img, y * w + x)));
    let mut shifts = Vec::new();
    for x in 0..w {
        match (top_row(cut, x), top_row(full, x)) {
            (None, None) => {}
            (a, b) => shifts.push(a.unwrap_or(h).abs_diff(b.unwrap_or(h)) as u32),
        }
    }
    let skyline_max_shift_px = shifts.iter().copied().max().unwrap_or(0);
    let skyline_mean_shift_px = if shifts.is_empty() {
        0.0
    } else {
        shifts.iter().map(|&s| f64::from(s)).sum::<f64>() / shifts.len() as f64
    };

    let total = (w * h).max(1) as f64;
    Ok(ImageMetrics {
        width: cut.width,
        height: cut.height,
        changed_px,
        changed_fraction: changed_px as f64 / total,
        added_px,
        removed_px,
        largest_added_region_px: largest_region(&added, w, h),
        largest_removed_region_px: largest_region(&removed, w, h),
        skyline_columns: shifts.len() as u32,
        skyline_max_shift_px,
        skyline_mean_shift_px,
        diff,
    })
}

/// Size of the largest 4-connected region of `true` cells in a `w × h` row-major mask.
fn largest_region(mask: &[bool], w: usize, h: usize) -> u64 {
    debug_assert_eq!(mask.len(), w * h);
    let mut seen = vec![false; mask.len()];
    let mut stack = Vec::new();
    let mut best = 0u64;
    for start in 0..mask.len() {
        if !mask[start] || seen[start] {
            continue;
        }
        seen[start] = true;
        stack.push(start);
        let mut size = 0u64;
        while let Some(i) = stack.pop() {
            size += 1;
            let (x, y) = (i % w, i / w);
            let mut visit = |j: usize| {
                if mask[j] && !seen[j] {
                    seen[j] = true;
                    stack.push(j);
                }
            };
            if x > 0 {
                visit(i - 1);
            }
            if x + 1 < w {
                visit(i + 1);
            }
            if y > 0 {
                visit(i - w);
            }
            if y + 1 < h {
                visit(i + w);
            }
        }
        best = best.max(size);
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    const SKY: [u8; 4] = [200, 220, 240, 255];
    const WALL: [u8; 4] = [120, 100, 90, 255];

    /// Fills columns `x0..x1` from row `top` down to the bottom.
    fn building(img: &mut Image, x0: u32, x1: u32, top: u32) {
        for x in x0..x1 {
            for y in top..img.height {
                img.set_pixel(x, y, WALL);
            }
        }
    }

    #[test]
    fn identical_images_have_no_differences() {
        let mut a = Image::filled(20, 10, SKY);
        building(&mut a, 2, 8, 4);
        let m = compare(&a, &a.clone(), SKY).unwrap();
        assert_eq!((m.changed_px, m.added_px, m.removed_px), (0, 0, 0));
        assert_eq!(m.skyline_columns, 6);
        assert_eq!(m.skyline_max_shift_px, 0);
        assert_eq!(
            m.diff.pixel(0, 0).unwrap()[0],
            m.diff.pixel(0, 0).unwrap()[1]
        ); // grey
    }

    #[test]
    fn raised_roof_gives_known_skyline_shift_and_region() {
        // Full: one building over columns 2..8 with top row 6. Cut: the same columns topped at row 3,
        // i.e. merging added a 6 × 3 block: 18 px, skyline shift 3 on 6 columns.
        let mut full = Image::filled(20, 10, SKY);
        building(&mut full, 2, 8, 6);
        let mut cut = Image::filled(20, 10, SKY);
        building(&mut cut, 2, 8, 3);
        let m = compare(&cut, &full, SKY).unwrap();
        assert_eq!(m.added_px, 18);
        assert_eq!(m.largest_added_region_px, 18);
        assert_eq!(m.removed_px, 0);
        assert_eq!(m.changed_px, 18);
        assert_eq!(m.skyline_columns, 6);
        assert_eq!(m.skyline_max_shift_px, 3);
        assert!((m.skyline_mean_shift_px - 3.0).abs() < 1e-12);
        assert_eq!(m.diff.pixel(2, 3), Some(DIFF_ADDED));
        assert!((m.changed_fraction - 18.0 / 200.0).abs() < 1e-12);
    }

    #[test]
    fn gap_filled_between_buildings_counts_as_one_region_and_vanished_column_as_full_height() {
        // Full: buildings at columns 0..3 and 5..8 (top row 2) and a one-column tower at 15 (top row 0).
        // Cut: one block 0..8 (top row 2) with the gap 3..5 filled, and the tower gone.
        let mut full = Image::filled(20, 10, SKY);
        building(&mut full, 0, 3, 2);
        building(&mut full, 5, 8, 2);
        building(&mut full, 15, 16, 0);
        let mut cut = Image::filled(20, 10, SKY);
        building(&mut cut, 0, 8, 2);
        let m = compare(&cut, &full, SKY).unwrap();
        assert_eq!(m.largest_added_region_px, 2 * 8);
        assert_eq!(m.largest_removed_region_px, 10);
        // Gap columns shift by 10 − 2 = 8 (full has no building there), the tower by 10 − 0.
        assert_eq!(m.skyline_columns, 9);
        assert_eq!(m.skyline_max_shift_px, 10);
        assert!((m.skyline_mean_shift_px - (8.0 + 8.0 + 10.0) / 9.0).abs() < 1e-12);
        assert_eq!(m.diff.pixel(15, 5), Some(DIFF_REMOVED));
    }

    #[test]
    fn small_colour_noise_is_within_tolerance() {
        let mut full = Image::filled(4, 4, SKY);
        building(&mut full, 0, 4, 2);
        let mut cut = full.clone();
        cut.set_pixel(1, 3, [125, 104, 90, 255]);
        cut.set_pixel(2, 3, [140, 100, 90, 255]);
        let m = compare(&cut, &full, SKY).unwrap();
        assert_eq!(m.changed_px, 1);
        assert_eq!(m.diff.pixel(2, 3), Some(DIFF_RECOLOURED));
    }

    #[test]
    fn size_mismatch_is_an_error() {
        let a = Image::filled(4, 4, SKY);
        let b = Image::filled(4, 5, SKY);
        assert!(compare(&a, &b, SKY).is_err());
    }
}
