//! Contact sheets: several renders tiled on one image, each under a text label drawn with a built-in
//! 5×7 pixel font (ASCII letters, digits and common punctuation; lower case is drawn as upper case,
//! anything else as '?'). Pixels; row 0 at the top. Invariant: panels keep their exact pixels.

use crate::{CheckError, Image};

/// Scale of the 5×7 font (each font pixel is `FONT_SCALE × FONT_SCALE` image pixels).
const FONT_SCALE: u32 = 2;
const GLYPH_W: u32 = 5;
const GLYPH_H: u32 = 7;
const PAD: u32 = 4;
const LABEL_H: u32 = GLYPH_H * FONT_SCALE + 2 * PAD;
const PAPER: [u8; 4] = [255, 255, 255, 255];
const INK: [u8; 4] = [20, 20, 20, 255];

/// Tiles `panels` row by row, `columns` per row (at least 1), each cell as large as the largest panel
/// plus a label strip above it. Labels longer than the cell are cut. Errors on an empty list.
pub fn contact_sheet(panels: &[(&str, &Image)], columns: usize) -> Result<Image, CheckError> {
    if panels.is_empty() {
        return Err(CheckError::Image(
            "a contact sheet needs at least one panel".into(),
        ));
    }
    let columns = columns.clamp(1, panels.len()) as u32;
    let rows = (panels.len() as u32).div_ceil(columns);
    let cell_w = panels.iter().map(|(_, p)| p.width).max().unwrap_or(0) + PAD;
    let cell_h = panels.iter().map(|(_, p)| p.height).max().unwrap_or(0) + LABEL_H;
    let mut sheet = Image::filled(columns * cell_w + PAD, rows * cell_h + PAD, PAPER);
    for (k, (label, panel)) in panels.iter().enumerate() {
        let (cx, cy) = (
            (k as u32 % columns) * cell_w + PAD,
            (k as u32 / columns) * cell_h,
        );
        draw_text(&mut sheet, label, cx, cy + PAD, cx + cell_w - PAD);
        for y in 0..panel.height {
            for x in 0..panel.width {
                if let Some(p) = panel.pixel(x, y) {
                    sheet.set_pixel(cx + x, cy + LABEL_H + y, p);
                }
            }
        }
    }
    Ok(sheet)
}

/// Draws `text` with its top-left corner at (`x0`, `y0`), stopping before column `x_end`.
fn draw_text(img: &mut Image, text: &str, x0: u32, y0: u32, x_end: u32) {
    let advance = (GLYPH_W + 1) * FONT_SCALE;
    for (i, ch) in text.chars().enumerate() {
        let gx = x0 + i as u32 * advance;
        if gx + GLYPH_W * FONT_SCALE > x_end {
            break;
        }
        for (row, bits) in glyph(ch).iter().enumerate() {
            for col in 0..GLYPH_W {
                if bits & (1 << (GLYPH_W - 1 - col)) != 0 {
                    for dy in 0..FONT_SCALE {
                        for dx in 0..FONT_SCALE {
                            img.set_pixel(
                                gx + col * FONT_SCALE + dx,
                                y0 + row as u32 * FONT_SCALE + dy,
                                INK,
                            );
                        }
                    }
                }
            }
        }
    }
}

/// The 7 rows (5 bits each, leftmost pixel in bit 4) of a character.
fn glyph(ch: char) -> [u8; 7] {
    let ch = ch.to_ascii_uppercase();
    GLYPHS
        .iter()
        .find(|(c, _)| *c == ch)
        .or_else(|| GLYPHS.iter().find(|(c, _)| *c == '?'))
        .map(|(_, g)| *g)
        .unwrap_or([0; 7])
}

#[rustfmt::skip]
const GLYPHS: &[(char, [u8; 7])] = &[
    (' ', [0, 0, 0, 0, 0, 0, 0]),
    ('0', [0b01110, 0b10001, 0b10011, 0b10101, 0b11001, 0b10001, 0b01110]),
    ('1', [0b00100, 0b01100, 0b00100, 0b00100, 0b00100, 0b00100, 0b01110]),
    ('2', [0b01110, 0b10001, 0b00001, 0b00010, 0b00100, 0b01000, 0b11111]),
    ('3', [0b11111, 0b00010, 0b00100, 0b00010, 0b00001, 0b10001, 0b01110]),
    ('4', [0b00010, 0b00110, 0b01010, 0b10010, 0b11111, 0b00010, 0b00010]),
    ('5', [0b11111, 0b10000, 0b11110, 0b00001, 0b00001, 0b10001, 0b01110]),
    ('6', [0b00110, 0b01000, 0b10000, 0b11110, 0b10001, 0b10001, 0b01110]),
    ('7', [0b11111, 0b00001, 0b00010, 0b00100, 0b01000, 0b01000, 0b01000]),
    ('8', [0b01110, 0b10001, 0b10001, 0b01110, 0b10001, 0b10001, 0b01110]),
    ('9', [0b01110, 0b10001, 0b10001, 0b01111, 0b00001, 0b00010, 0b01100]),
    ('A', [0b01110, 0b10001, 0b10001, 0b11111, 0b10001, 0b10001, 0b10001]),
    ('B', [0b11110, 0b10001, 0b10001, 0b11110, 0b10001, 0b10001, 0b11110]),
    ('C', [0b01110, 0b10001, 0b10000, 0b10000, 0b10000, 0b10001, 0b01110]),
    ('D', [0b11100, 0b10010, 0b10001, 0b10001, 0b10001, 0b10010, 0b11100]),
    ('E', [0b11111, 0b10000, 0b10000, 0b11110, 0b10000, 0b10000, 0b11111]),
    ('F', [0b11111, 0b10000, 0b10000, 0b11110, 0b10000, 0b10000, 0b10000]),
    ('G', [0b01110, 0b10001, 0b10000, 0b10111, 0b10001, 0b10001, 0b01111]),
    ('H', [0b10001, 0b10001, 0b10001, 0b11111, 0b10001, 0b10001, 0b10001]),
    ('I', [0b01110, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100, 0b01110]),
    ('J', [0b00111, 0b00010, 0b00010, 0b00010, 0b00010, 0b10010, 0b01100]),
    ('K', [0b10001, 0b10010, 0b10100, 0b11000, 0b10100, 0b10010, 0b10001]),
    ('L', [0b10000, 0b10000, 0b10000, 0b10000, 0b10000, 0b10000, 0b11111]),
    ('M', [0b10001, 0b11011, 0b10101, 0b10101, 0b10001, 0b10001, 0b10001]),
    ('N', [0b10001, 0b10001, 0b11001, 0b10101, 0b10011, 0b10001, 0b10001]),
    ('O', [0b01110, 0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b01110]),
    ('P', [0b11110, 0b10001, 0b10001, 0b11110, 0b10000, 0b10000, 0b10000]),
    ('Q', [0b01110, 0b10001, 0b10001, 0b10001, 0b10101, 0b10010, 0b01101]),
    ('R', [0b11110, 0b10001, 0b10001, 0b11110, 0b10100, 0b10010, 0b10001]),
    ('S', [0b01111, 0b10000, 0b10000, 0b01110, 0b00001, 0b00001, 0b11110]),
    ('T', [0b11111, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100]),
    ('U', [0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b01110]),
    ('V', [0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b01010, 0b00100]),
    ('W', [0b10001, 0b10001, 0b10001, 0b10101, 0b10101, 0b10101, 0b01010]),
    ('X', [0b10001, 0b10001, 0b01010, 0b00100, 0b01010, 0b10001, 0b10001]),
    ('Y', [0b10001, 0b10001, 0b10001, 0b01010, 0b00100, 0b00100, 0b00100]),
    ('Z', [0b11111, 0b00001, 0b00010, 0b00100, 0b01000, 0b10000, 0b11111]),
    ('.', [0b00000, 0b00000, 0b00000, 0b00000, 0b00000, 0b01100, 0b01100]),
    (',', [0b00000, 0b00000, 0b00000, 0b00000, 0b01100, 0b00100, 0b01000]),
    ('-', [0b00000, 0b00000, 0b00000, 0b11111, 0b00000, 0b00000, 0b00000]),
    ('_', [0b00000, 0b00000, 0b00000, 0b00000, 0b00000, 0b00000, 0b11111]),
    (':', [0b00000, 0b01100, 0b01100, 0b00000, 0b01100, 0b01100, 0b00000]),
    ('/', [0b00000, 0b00001, 0b00010, 0b00100, 0b01000, 0b10000, 0b00000]),
    ('(', [0b00010, 0b00100, 0b01000, 0b01000, 0b01000, 0b00100, 0b00010]),
    (')', [0b01000, 0b00100, 0b00010, 0b00010, 0b00010, 0b00100, 0b01000]),
    ('%', [0b11000, 0b11001, 0b00010, 0b00100, 0b01000, 0b10011, 0b00011]),
    ('=', [0b00000, 0b00000, 0b11111, 0b00000, 0b11111, 0b00000, 0b00000]),
    ('+', [0b00000, 0b00100, 0b00100, 0b11111, 0b00100, 0b00100, 0b00000]),
    ('#', [0b01010, 0b01010, 0b11111, 0b01010, 0b11111, 0b01010, 0b01010]),
    ('<', [0b00010, 0b00100, 0b01000, 0b10000, 0b01000, 0b00100, 0b00010]),
    ('>', [0b01000, 0b00100, 0b00010, 0b00001, 0b00010, 0b00100, 0b01000]),
    ('|', [0b00100, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100]),
    ('?', [0b01110, 0b10001, 0b00001, 0b00010, 0b00100, 0b00000, 0b00100]),
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sheet_places_panels_unchanged_in_a_grid() {
        let a = Image::filled(10, 6, [255, 0, 0, 255]);
        let b = Image::filled(8, 6, [0, 0, 255, 255]);
        let c = Image::filled(10, 6, [0, 255, 0, 255]);
        let s = contact_sheet(&[("cut", &a), ("full", &b), ("diff", &c)], 2).unwrap();
        let (cw, ch) = (10 + PAD, 6 + LABEL_H);
        assert_eq!((s.width, s.height), (2 * cw + PAD, 2 * ch + PAD));
        assert_eq!(s.pixel(PAD, LABEL_H), Some([255, 0, 0, 255]));
        assert_eq!(s.pixel(cw + PAD + 7, LABEL_H + 5), Some([0, 0, 255, 255]));
        assert_eq!(s.pixel(cw + PAD + 9, LABEL_H), Some(PAPER)); // b is narrower than its cell
        assert_eq!(s.pixel(PAD + 9, ch + LABEL_H + 5), Some([0, 255, 0, 255]));
    }

    #[test]
    fn labels_draw_ink_and_unknown_characters_fall_back() {
        let a = Image::filled(60, 4, [255, 0, 0, 255]);
        let s = contact_sheet(&[("V1", &a)], 1).unwrap();
        let ink = (0..s.width)
            .flat_map(|x| (0..LABEL_H).map(move |y| (x, y)))
            .filter(|&(x, y)| s.pixel(x, y) == Some(INK))
            .count() as u32;
        // 'V' has 13 lit font pixels and '1' has 10, each drawn FONT_SCALE² times.
        assert_eq!(ink, (13 + 10) * FONT_SCALE * FONT_SCALE);
        assert_eq!(glyph('é'), glyph('?'));
        assert_eq!(glyph('a'), glyph('A'));
    }

    #[test]
    fn empty_sheet_is_an_error() {
        assert!(contact_sheet(&[], 3).is_err());
    }
}
