//! One grey frame of the nail camera, and its PNG file.

use std::path::Path;

use crate::exit::{Classify, ExitClass};

/// Why a frame cannot be made or read.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FrameError {
    /// The pixel count does not match the size.
    #[error("a {width} x {height} frame needs {expected} pixels, got {found}")]
    Size {
        /// Width (px).
        width: usize,
        /// Height (px).
        height: usize,
        /// width * height.
        expected: usize,
        /// Pixels given.
        found: usize,
    },
    /// The image file cannot be read or written.
    #[error("{path}: {source}")]
    Image {
        /// File path.
        path: String,
        /// Underlying error.
        source: image::ImageError,
    },
}

/// A frame not read or written: the work failed.
impl Classify for FrameError {
    fn class(&self) -> ExitClass {
        ExitClass::Failure
    }
}

/// A grey frame (0..255), row-major, row 0 at the top.
#[derive(Debug, Clone, PartialEq)]
pub struct NailFrame {
    /// Time of the frame (s).
    pub stamp_s: f64,
    /// Sequence number.
    pub seq: u16,
    width: usize,
    height: usize,
    pixels: Vec<u8>,
}

impl NailFrame {
    /// A frame of `width` x `height` pixels, row-major.
    pub fn new(width: usize, height: usize, pixels: Vec<u8>) -> Result<Self, FrameError> {
        if pixels.len() != width * height || width == 0 || height == 0 {
            return Err(FrameError::Size {
                width,
                height,
                expected: width * height,
                found: pixels.len(),
            });
        }
        Ok(NailFrame {
            stamp_s: 0.0,
            seq: 0,
            width,
            height,
            pixels,
        })
    }

    /// Width (px).
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height (px).
    pub fn height(&self) -> usize {
        self.height
    }

    /// The pixels, row-major.
    pub fn pixels(&self) -> &[u8] {
        &self.pixels
    }

    /// The grey at column `u`, row `v`.
    pub fn at(&self, u: usize, v: usize) -> u8 {
        self.pixels[v * self.width + u]
    }

    /// The grey at (`x`, `y`) (column, row; pixel centres at integers),
    /// interpolated bilinearly; outside the frame, the nearest edge pixel.
    pub fn sample(&self, x: f64, y: f64) -> f64 {
        let x = x.clamp(0.0, (self.width - 1) as f64);
        let y = y.clamp(0.0, (self.height - 1) as f64);
        let (u0, v0) = (x.floor() as usize, y.floor() as usize);
        let (u1, v1) = ((u0 + 1).min(self.width - 1), (v0 + 1).min(self.height - 1));
        let (fx, fy) = (x - u0 as f64, y - v0 as f64);
        let g = |u, v| f64::from(self.at(u, v));
        let top = g(u0, v0) * (1.0 - fx) + g(u1, v0) * fx;
        let bottom = g(u0, v1) * (1.0 - fx) + g(u1, v1) * fx;
        top * (1.0 - fy) + bottom * fy
    }

    /// Writes the frame as an 8-bit grey PNG.
    pub fn write_png(&self, path: &Path) -> Result<(), FrameError> {
        image::save_buffer(
            path,
            &self.pixels,
            self.width as u32,
            self.height as u32,
            image::ExtendedColorType::L8,
        )
        .map_err(|source| FrameError::Image {
            path: path.display().to_string(),
            source,
        })
    }

    /// Reads an image file: a grey image as it is, a colour one by its
    /// green channel (Watanabe et al. 2023 keep the green component: "a 500
    /// \[nm\] peak light length is absorbed by hemoglobin").
    pub fn read_png(path: &Path) -> Result<Self, FrameError> {
        let err = |source| FrameError::Image {
            path: path.display().to_string(),
            source,
        };
        let img = image::open(path).map_err(err)?;
        let (width, height) = (img.width() as usize, img.height() as usize);
        let pixels = if img.color().has_color() {
            img.to_rgb8().pixels().map(|p| p.0[1]).collect()
        } else {
            img.to_luma8().into_raw()
        };
        NailFrame::new(width, height, pixels)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_frame_round_trips_through_png_and_samples_bilinearly() {
        let f = NailFrame::new(3, 2, vec![0, 10, 20, 30, 40, 50]).unwrap();
        assert_eq!(f.sample(0.5, 0.5), 20.0);
        assert_eq!(f.sample(-4.0, 9.0), 30.0, "clamped to the edge");
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f.png");
        f.write_png(&path).unwrap();
        assert_eq!(NailFrame::read_png(&path).unwrap().pixels(), f.pixels());
        let e = NailFrame::new(3, 2, vec![0; 5]).unwrap_err().to_string();
        assert!(e.contains("needs 6 pixels, got 5"), "{e}");
        std::fs::write(&path, b"not a png").unwrap();
        let e = NailFrame::read_png(&path).unwrap_err().to_string();
        assert!(e.contains("f.png"), "{e}");
    }
}
