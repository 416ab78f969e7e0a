//! An 8-bit RGBA image in row-major order, top row first, and its PNG encoding.
//! Invariant: `rgba.len() == width · height · 4`.

use std::path::Path;

use crate::CheckError;

/// An RGBA8 image, row-major, top row first.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub rgba: Vec<u8>,
}

impl Image {
    /// An image of one colour.
    pub fn filled(width: u32, height: u32, colour: [u8; 4]) -> Image {
        let n = width as usize * height as usize;
        Image {
            width,
            height,
            rgba: colour.repeat(n),
        }
    }

    /// An image from raw RGBA bytes; errors when the length is not `width · height · 4`.
    pub fn from_rgba(width: u32, height: u32, rgba: Vec<u8>) -> Result<Image, CheckError> {
        let want = width as usize * height as usize * 4;
        if rgba.len() != want {
            return Err(CheckError::Image(format!(
                "{width}×{height} needs {want} bytes, got {}",
                rgba.len()
            )));
        }
        Ok(Image {
            width,
            height,
            rgba,
        })
    }

    /// The pixel at column `x`, row `y` (row 0 at the top); `None` outside the image.
    pub fn pixel(&self, x: u32, y: u32) -> Option<[u8; 4]> {
        if x >= self.width || y >= self.height {
            return None;
        }
        let i = (y as usize * self.width as usize + x as usize) * 4;
        self.rgba.get(i..i + 4).map(|p| [p[0], p[1], p[2], p[3]])
    }

    /// Sets the pixel at (`x`, `y`); does nothing outside the image.
    pub fn set_pixel(&mut self, x: u32, y: u32, colour: [u8; 4]) {
        if x < self.width && y < self.height {
            let i = (y as usize * self.width as usize + x as usize) * 4;
            self.rgba[i..i + 4].copy_from_slice(&colour);
        }
    }

    /// PNG bytes (RGBA, 8 bits per channel); deterministic for equal images.
    pub fn to_png(&self) -> Result<Vec<u8>, CheckError> {
        let err = |e: png::EncodingError| CheckError::Png {
            path: "<memory>".into(),
            detail: e.to_string(),
        };
        let mut out = Vec::new();
        let mut enc = png::Encoder::new(&mut out, self.width, self.height);
        enc.set_color(png::ColorType::Rgba);
        enc.set_depth(png::BitDepth::Eight);
        let mut writer = enc.write_header().map_err(err)?;
        writer.write_image_data(&self.rgba).map_err(err)?;
        writer.finish().map_err(err)?;
        Ok(out)
    }

    /// Writes the image as a PNG file.
    pub fn save_png(&self, path: &Path) -> Result<(), CheckError> {
        let bytes = self.to_png().map_err(|e| CheckError::Png {
            path: path.display().to_string(),
            detail: e.to_string(),
        })?;
        std::fs::write(path, bytes).map_err(|e| CheckError::Png {
            path: path.display().to_string(),
            detail: e.to_string(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn png_encoding_is_deterministic_and_has_signature() {
        let mut img = Image::filled(5, 3, [10, 20, 30, 255]);
        img.set_pixel(4, 2, [255, 0, 0, 255]);
        let a = img.to_png().unwrap();
        assert_eq!(&a[..8], b"\x89PNG\r\n\x1a\n");
        assert_eq!(a, img.to_png().unwrap());
        assert_eq!(img.pixel(4, 2), Some([255, 0, 0, 255]));
        assert_eq!(img.pixel(5, 0), None);
    }

    #[test]
    fn from_rgba_rejects_wrong_length() {
        assert!(Image::from_rgba(2, 2, vec![0; 15]).is_err());
        assert!(Image::from_rgba(2, 2, vec![0; 16]).is_ok());
    }
}
