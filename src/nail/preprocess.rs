//! Urban et al. 2013's preprocessing of a nail frame: register it on the
//! nail's four markers, cut the nail out with a mask made once from a
//! reference frame, scale it to 72 px wide and divide every pixel by the
//! mean grey (their section II.B).
//!
//! - **Markers.** Urban finds "four black markers on the nail" by template
//!   matching; here the darkest blobs: pixels below `min + 0.3 (median -
//!   min)`, 4-connected, the four largest of 4..=400 px, ordered tip-left,
//!   tip-right, base-left, base-right by their centroids.
//! - **Registration.** The affine map that takes the reference's marker
//!   centroids to the frame's (least squares on the four points); Urban
//!   tracks corner points frame to frame to the same end.
//! - **Region and size.** The markers' box, widened by [`ROI_MARGIN`] about
//!   its centre (the markers sit inside the nail near its corners), sampled
//!   at 72 px across (Urban: "scaled to a width of 72 pixels while
//!   preserving the aspect ratio"), each output pixel the mean of 2 x 2
//!   bilinear samples.
//! - **Mask.** From the reference frame only ("the nail is stationary in the
//!   video stream \[so\] we can apply the same mask for every frame"): the
//!   pixels brighter than Otsu's threshold connected to the centre (the
//!   nail, without the dark markers and the skin around it), eroded by one
//!   pixel so that the edge does not follow registration errors. Urban uses
//!   Canny edges and a closing for the same cut.
//! - **Normalisation.** "dividing every pixel by the grayscale mean of all
//!   pixels": this undoes the light's gain.

use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

use super::frame::NailFrame;

use crate::exit::{Classify, ExitClass};

/// Output width (px), Urban's.
pub const OUT_WIDTH: usize = 72;
/// How far the nail region reaches beyond the markers' box, as a factor of
/// its size about its centre.
pub const ROI_MARGIN: f64 = 1.7;
/// Marker blob sizes accepted (px).
const MARKER_AREA: (usize, usize) = (4, 400);

/// Why a frame cannot be preprocessed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum PreprocessError {
    /// Fewer than four marker blobs.
    #[error("frame {seq}: {found} dark markers found, expected 4 (is the nail in view?)")]
    Markers {
        /// Sequence number of the frame.
        seq: u16,
        /// Blobs found.
        found: usize,
    },
    /// The frame's size differs from the reference's.
    #[error("frame {seq}: {found:?} px, the reference frame was {expected:?}")]
    Size {
        /// Sequence number of the frame.
        seq: u16,
        /// Its width and height.
        found: (usize, usize),
        /// The reference's.
        expected: (usize, usize),
    },
    /// The mask holds no pixel, or a stored preprocessing is inconsistent.
    #[error("nail preprocessing: {0}")]
    Inconsistent(String),
    /// The frame's nail is black (mean grey 0).
    #[error("frame {seq}: the nail is black")]
    Dark {
        /// Sequence number of the frame.
        seq: u16,
    },
}

/// Frames the preprocessing cannot register: refused input.
impl Classify for PreprocessError {
    fn class(&self) -> ExitClass {
        ExitClass::Refused
    }
}

/// The preprocessing made from a reference frame: the markers, the nail
/// region and its mask. Serialised into nail models.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NailPreprocess {
    /// Camera frame size (px).
    frame_size: (usize, usize),
    /// Marker centroids in the reference frame (column, row).
    reference: [[f64; 2]; 4],
    /// Top-left corner of the region in the reference frame (px).
    origin: [f64; 2],
    /// Reference pixels per output pixel.
    step: f64,
    /// Output size (px).
    out_size: (usize, usize),
    /// Nail pixels of the output, row-major.
    mask: Vec<bool>,
}

impl NailPreprocess {
    /// The preprocessing of frames like `reference` (its markers, region
    /// and mask).
    pub fn from_reference(reference: &NailFrame) -> Result<Self, PreprocessError> {
        let markers = find_markers(reference)?;
        let (lo, hi) = bounds(&markers);
        let centre = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
        let size = [(hi[0] - lo[0]) * ROI_MARGIN, (hi[1] - lo[1]) * ROI_MARGIN];
        let step = size[0] / OUT_WIDTH as f64;
        let out_size = (OUT_WIDTH, (size[1] / step).round().max(1.0) as usize);
        let mut p = NailPreprocess {
            frame_size: (reference.width(), reference.height()),
            reference: markers,
            origin: [centre[0] - size[0] / 2.0, centre[1] - size[1] / 2.0],
            step,
            out_size,
            mask: vec![true; out_size.0 * out_size.1],
        };
        let image = p.sample(reference, &IDENTITY);
        p.mask = nail_mask(&image, out_size);
        p.check()?;
        Ok(p)
    }

    /// Checks a stored preprocessing (sizes, finite numbers, a mask).
    pub fn check(&self) -> Result<(), PreprocessError> {
        let (w, h) = self.out_size;
        let finite = self
            .reference
            .iter()
            .flatten()
            .chain(&self.origin)
            .all(|v| v.is_finite())
            && self.step.is_finite()
            && self.step > 0.0;
        if !finite || self.mask.len() != w * h || !self.mask.iter().any(|&m| m) {
            return Err(PreprocessError::Inconsistent(format!(
                "a {w} x {h} region needs {} mask values with at least one nail pixel and \
                 finite markers (got {} values)",
                w * h,
                self.mask.len()
            )));
        }
        Ok(())
    }

    /// The camera's frame size (px, width and height): every frame's.
    pub fn frame_size(&self) -> (usize, usize) {
        self.frame_size
    }

    /// Number of values a frame becomes (the nail pixels).
    pub fn n_pixels(&self) -> usize {
        self.mask.iter().filter(|&&m| m).count()
    }

    /// Output size (px).
    pub fn out_size(&self) -> (usize, usize) {
        self.out_size
    }

    /// The mask, row-major over [`NailPreprocess::out_size`].
    pub fn mask(&self) -> &[bool] {
        &self.mask
    }

    /// The nail pixels of `frame`, registered, divided by their mean, into
    /// `out` (cleared first).
    pub fn pixels(&self, frame: &NailFrame, out: &mut Vec<f64>) -> Result<(), PreprocessError> {
        let region = self.region(frame)?;
        out.clear();
        out.extend(
            region
                .iter()
                .zip(&self.mask)
                .filter_map(|(v, &m)| m.then_some(*v)),
        );
        Ok(())
    }

    /// The whole registered region of `frame` (row-major over
    /// [`NailPreprocess::out_size`]), divided by the mean of its nail
    /// pixels; 1 outside the nail.
    pub fn region(&self, frame: &NailFrame) -> Result<Vec<f64>, PreprocessError> {
        let found = (frame.width(), frame.height());
        if found != self.frame_size {
            return Err(PreprocessError::Size {
                seq: frame.seq,
                found,
                expected: self.frame_size,
            });
        }
        let markers = find_markers(frame)?;
        let mut image = self.sample(frame, &affine(&self.reference, &markers));
        let (sum, n) = image
            .iter()
            .zip(&self.mask)
            .filter(|(_, &m)| m)
            .fold((0.0, 0usize), |(s, n), (v, _)| (s + v, n + 1));
        let mean = sum / n as f64;
        if mean.is_nan() || mean <= 0.0 {
            return Err(PreprocessError::Dark { seq: frame.seq });
        }
        for (v, &m) in image.iter_mut().zip(&self.mask) {
            *v = if m { *v / mean } else { 1.0 };
        }
        Ok(image)
    }

    /// The region of `frame` through `map` (reference -> frame), every
    /// output pixel the mean of 2 x 2 bilinear samples.
    fn sample(&self, frame: &NailFrame, map: &Affine) -> Vec<f64> {
        let (w, h) = self.out_size;
        let mut out = Vec::with_capacity(w * h);
        let quarter = self.step / 4.0;
        for i in 0..h {
            for j in 0..w {
                let x = self.origin[0] + (j as f64 + 0.5) * self.step;
                let y = self.origin[1] + (i as f64 + 0.5) * self.step;
                let mut sum = 0.0;
                for (dx, dy) in [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)] {
                    let (u, v) = map.apply(x + dx * quarter, y + dy * quarter);
                    sum += frame.sample(u, v);
                }
                out.push(sum / 4.0);
            }
        }
        out
    }
}

/// An affine map of the plane: `(u, v) = A (x, y, 1)`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Affine([[f64; 3]; 2]);

const IDENTITY: Affine = Affine([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);

impl Affine {
    fn apply(&self, x: f64, y: f64) -> (f64, f64) {
        let [a, b] = self.0;
        (a[0] * x + a[1] * y + a[2], b[0] * x + b[1] * y + b[2])
    }
}

/// The least-squares affine map taking `from` to `to`.
fn affine(from: &[[f64; 2]; 4], to: &[[f64; 2]; 4]) -> Affine {
    let mut ata = Matrix3::zeros();
    let (mut atu, mut atv) = (Vector3::zeros(), Vector3::zeros());
    for (f, t) in from.iter().zip(to) {
        let r = Vector3::new(f[0], f[1], 1.0);
        ata += r * r.transpose();
        atu += r * t[0];
        atv += r * t[1];
    }
    // Four markers at the corners of a box span the plane: invertible.
    match ata.try_inverse() {
        Some(inv) => {
            let (a, b) = (inv * atu, inv * atv);
            Affine([[a[0], a[1], a[2]], [b[0], b[1], b[2]]])
        }
        None => IDENTITY,
    }
}

/// Lowest and highest column and row of the markers.
fn bounds(m: &[[f64; 2]; 4]) -> ([f64; 2], [f64; 2]) {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for p in m {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo, hi)
}

/// The centroids of the four dark marker blobs: tip-left, tip-right,
/// base-left, base-right.
pub fn find_markers(frame: &NailFrame) -> Result<[[f64; 2]; 4], PreprocessError> {
    let (w, h) = (frame.width(), frame.height());
    let mut sorted = frame.pixels().to_vec();
    sorted.sort_unstable();
    let (min, median) = (f64::from(sorted[0]), f64::from(sorted[sorted.len() / 2]));
    let threshold = min + 0.3 * (median - min);
    let dark: Vec<bool> = frame
        .pixels()
        .iter()
        .map(|&g| f64::from(g) <= threshold)
        .collect();
    let mut seen = vec![false; w * h];
    let mut blobs: Vec<(usize, [f64; 2])> = Vec::new();
    let mut stack = Vec::new();
    for start in 0..w * h {
        if !dark[start] || seen[start] {
            continue;
        }
        seen[start] = true;
        stack.push(start);
        let (mut n, mut sx, mut sy) = (0usize, 0.0, 0.0);
        while let Some(i) = stack.pop() {
            n += 1;
            sx += (i % w) as f64;
            sy += (i / w) as f64;
            for j in neighbours(i, w, h).into_iter().flatten() {
                if dark[j] && !seen[j] {
                    seen[j] = true;
                    stack.push(j);
                }
            }
        }
        if (MARKER_AREA.0..=MARKER_AREA.1).contains(&n) {
            blobs.push((n, [sx / n as f64, sy / n as f64]));
        }
    }
    if blobs.len() < 4 {
        return Err(PreprocessError::Markers {
            seq: frame.seq,
            found: blobs.len(),
        });
    }
    blobs.sort_by_key(|b| std::cmp::Reverse(b.0));
    let mut m: Vec<[f64; 2]> = blobs[..4].iter().map(|b| b.1).collect();
    m.sort_by(|a, b| a[1].total_cmp(&b[1]));
    let (tip, base) = m.split_at_mut(2);
    tip.sort_by(|a, b| a[0].total_cmp(&b[0]));
    base.sort_by(|a, b| a[0].total_cmp(&b[0]));
    Ok([tip[0], tip[1], base[0], base[1]])
}

/// The nail's pixels of a region image: brighter than Otsu's threshold,
/// connected to the centre, eroded by one pixel.
fn nail_mask(image: &[f64], (w, h): (usize, usize)) -> Vec<bool> {
    let threshold = otsu(image);
    let bright: Vec<bool> = image.iter().map(|&v| v > threshold).collect();
    let mut region = vec![false; w * h];
    let start = (h / 2) * w + w / 2;
    let mut stack = vec![start];
    if bright[start] {
        region[start] = true;
    }
    while let Some(i) = stack.pop() {
        if !region[i] {
            continue;
        }
        for j in neighbours(i, w, h).into_iter().flatten() {
            if bright[j] && !region[j] {
                region[j] = true;
                stack.push(j);
            }
        }
    }
    (0..w * h)
        .map(|i| {
            region[i]
                && neighbours(i, w, h)
                    .iter()
                    .all(|j| j.is_some_and(|j| region[j]))
        })
        .collect()
}

/// The 4-neighbours of pixel `i` of a `w` x `h` row-major image (None
/// past an edge).
fn neighbours(i: usize, w: usize, h: usize) -> [Option<usize>; 4] {
    let (u, v) = (i % w, i / w);
    [
        (u > 0).then(|| i - 1),
        (u + 1 < w).then(|| i + 1),
        (v > 0).then(|| i - w),
        (v + 1 < h).then(|| i + w),
    ]
}

/// Otsu's threshold of `values` (the split that maximises the
/// between-class variance), over 256 bins of their range.
fn otsu(values: &[f64]) -> f64 {
    let (lo, hi) = values
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    if hi <= lo {
        return lo;
    }
    let bin = |v: f64| (((v - lo) / (hi - lo)) * 255.0).round() as usize;
    let mut hist = [0usize; 256];
    for &v in values {
        hist[bin(v)] += 1;
    }
    let total = values.len() as f64;
    let sum: f64 = hist
        .iter()
        .enumerate()
        .map(|(i, &c)| i as f64 * c as f64)
        .sum();
    let (mut w0, mut sum0, mut best, mut best_t) = (0.0, 0.0, -1.0, 0usize);
    for (t, &c) in hist.iter().enumerate() {
        w0 += c as f64;
        sum0 += t as f64 * c as f64;
        let w1 = total - w0;
        if w0 == 0.0 || w1 == 0.0 {
            continue;
        }
        let (m0, m1) = (sum0 / w0, (sum - sum0) / w1);
        let between = w0 * w1 * (m0 - m1).powi(2);
        if between > best {
            best = between;
            best_t = t;
        }
    }
    lo + (best_t as f64 + 0.5) / 255.0 * (hi - lo)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nail::sim::{NailSimConfig, Person, Pressing, Session};

    fn frame(person: u64, session: u64, fz: f64) -> NailFrame {
        let c = NailSimConfig::default();
        let pressing = Pressing {
            force: [0.0, 0.0, fz],
            ..Default::default()
        };
        Session::new(&c, session).render(&c, &Person::new(&c, person), &pressing)
    }

    #[test]
    fn markers_are_found_in_order_and_the_region_is_72_px_wide() {
        let f = frame(1, 1, 0.0);
        let m = find_markers(&f).unwrap();
        assert!(
            m[0][1] < m[2][1] && m[0][0] < m[1][0] && m[2][0] < m[3][0],
            "{m:?}"
        );
        let p = NailPreprocess::from_reference(&f).unwrap();
        let (w, h) = p.out_size();
        assert_eq!(w, 72);
        assert!((60..=95).contains(&h), "{h}");
        // Most of the region is nail, none of the markers.
        let share = p.n_pixels() as f64 / (w * h) as f64;
        assert!(share > 0.4 && share < 0.9, "{share}");
    }

    #[test]
    fn registration_undoes_the_mount_and_the_mean_undoes_the_light() {
        // Two sessions: a different camera mount and light, the same nail at rest.
        let (a, b) = (frame(1, 1, 0.0), frame(1, 7, 0.0));
        let p = NailPreprocess::from_reference(&a).unwrap();
        let (mut xa, mut xb) = (Vec::new(), Vec::new());
        p.pixels(&a, &mut xa).unwrap();
        p.pixels(&b, &mut xb).unwrap();
        let rms = |x: &[f64], y: &[f64]| {
            (x.iter().zip(y).map(|(u, v)| (u - v).powi(2)).sum::<f64>() / x.len() as f64).sqrt()
        };
        // A frame pressed at 6 N differs far more than the two sessions do.
        let mut xp = Vec::new();
        p.pixels(&frame(1, 1, 6.0), &mut xp).unwrap();
        let (between_sessions, pressed) = (rms(&xa, &xb), rms(&xa, &xp));
        assert!(
            between_sessions < 0.35 * pressed,
            "sessions {between_sessions}, pressed {pressed}"
        );
        let mean = xa.iter().sum::<f64>() / xa.len() as f64;
        assert!((mean - 1.0).abs() < 1e-12);
    }

    #[test]
    fn a_frame_without_markers_or_of_another_size_is_refused() {
        let blank = NailFrame::new(96, 104, vec![120; 96 * 104]).unwrap();
        let e = find_markers(&blank).unwrap_err().to_string();
        assert!(e.contains("0 dark markers"), "{e}");
        let p = NailPreprocess::from_reference(&frame(1, 1, 0.0)).unwrap();
        let small = NailFrame::new(10, 10, vec![0; 100]).unwrap();
        let e = p.pixels(&small, &mut Vec::new()).unwrap_err().to_string();
        assert!(e.contains("(10, 10)"), "{e}");
        let mut broken = p.clone();
        broken.mask.pop();
        assert!(broken.check().is_err());
    }
}
