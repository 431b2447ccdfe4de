//! Nail-camera data directories (`frames/NNNNNN.png`, `labels.csv`) as
//! data sets: per frame the nail pixels projected on the principal
//! components of a [`NailSpec`] (the GP's features) and the registered
//! region in blocks of [`CNN_BLOCK`] pixels (the CNN's image).

use std::path::{Path, PathBuf};

use rayon::prelude::*;

use super::Dataset;
use crate::nail::collect::{read_frame, read_labels, Label, NailDataError};
use crate::nail::preprocess::NailPreprocess;
use crate::sensor::nail::{NailSpec, PixelProjection, CNN_BLOCK, PCA_FRAMES};
use crate::wrench::AxisSet;

/// Nail data directories as data sets (one per directory), and the spec
/// they were projected with: `spec`, or one made from them (the mask from
/// the first directory's first frame, the components from up to
/// [`PCA_FRAMES`] of their frames; no labels are used).
pub fn read_nail_dirs(
    dirs: &[PathBuf],
    axes: &AxisSet,
    spec: Option<&NailSpec>,
) -> Result<(Vec<Dataset>, NailSpec), NailDataError> {
    let labels: Vec<Vec<Label>> = dirs
        .iter()
        .map(|d| read_labels(d))
        .collect::<Result<_, _>>()?;
    let spec = match spec {
        Some(s) => s.clone(),
        None => fit_spec(dirs, &labels)?,
    };
    let features = spec.feature_names();
    let sets = dirs
        .iter()
        .zip(&labels)
        .map(|(dir, labels)| {
            let (w, h) = spec.preprocess.out_size();
            let (iw, ih) = (w / CNN_BLOCK, h / CNN_BLOCK);
            let rows: Vec<(Vec<f64>, Vec<f32>)> = labels
                .par_iter()
                .map(|l| {
                    let region = spec.preprocess.region(&read_frame(dir, l)?)?;
                    let pixels: Vec<f64> = region
                        .iter()
                        .zip(spec.preprocess.mask())
                        .filter_map(|(v, &m)| m.then_some(*v))
                        .collect();
                    let mut x = vec![0.0; features.len()];
                    spec.projection.project(&pixels, &mut x);
                    Ok((x, blocks(&region, w, CNN_BLOCK, (iw, ih))))
                })
                .collect::<Result<_, NailDataError>>()?;
            let images = ndarray::Array3::from_shape_fn((rows.len(), ih, iw), |(n, i, j)| {
                rows[n].1[i * iw + j]
            });
            Ok(Dataset {
                features: features.clone(),
                x: ndarray::Array2::from_shape_fn((rows.len(), features.len()), |(i, j)| {
                    rows[i].0[j]
                }),
                axes: axes.clone(),
                y: ndarray::Array2::from_shape_fn((labels.len(), axes.len()), |(i, j)| {
                    labels[i].wrench().get(axes.axes()[j])
                }),
                set: labels.iter().map(|l| l.set).collect(),
                trial: labels.iter().map(|l| l.trial).collect(),
                images: Some(images),
            })
        })
        .collect::<Result<_, NailDataError>>()?;
    Ok((sets, spec))
}

/// Means of `block` x `block` pixels of a row-major image `width` wide,
/// `size` (width, height) blocks.
fn blocks(image: &[f64], width: usize, block: usize, size: (usize, usize)) -> Vec<f32> {
    let (bw, bh) = size;
    let mut out = Vec::with_capacity(bw * bh);
    for i in 0..bh {
        for j in 0..bw {
            let sum: f64 = (0..block)
                .flat_map(|di| (0..block).map(move |dj| (i * block + di) * width + j * block + dj))
                .map(|k| image[k])
                .sum();
            out.push((sum / (block * block) as f64) as f32);
        }
    }
    out
}

/// The spec of frames like those of `dirs`.
fn fit_spec(dirs: &[PathBuf], labels: &[Vec<Label>]) -> Result<NailSpec, NailDataError> {
    let reference = read_frame(&dirs[0], &labels[0][0])?;
    let preprocess = NailPreprocess::from_reference(&reference)?;
    let all: Vec<(&Path, &Label)> = dirs
        .iter()
        .zip(labels)
        .flat_map(|(d, ls)| ls.iter().map(move |l| (d.as_path(), l)))
        .collect();
    let stride = all.len().div_ceil(PCA_FRAMES).max(1);
    let rows: Vec<Vec<f64>> = all
        .par_iter()
        .step_by(stride)
        .map(|(dir, l)| {
            let mut pixels = Vec::new();
            preprocess.pixels(&read_frame(dir, l)?, &mut pixels)?;
            Ok(pixels)
        })
        .collect::<Result<_, NailDataError>>()?;
    let projection = PixelProjection::fit(&rows)?;
    // The step of the first trial's times; 1 s when it has one frame.
    let first = &labels[0];
    let frame_period_s = first
        .windows(2)
        .find(|w| (w[0].set, w[0].trial) == (w[1].set, w[1].trial) && w[1].t > w[0].t)
        .map_or(1.0, |w| w[1].t - w[0].t);
    Ok(NailSpec {
        frame_period_s,
        preprocess,
        projection,
    })
}
