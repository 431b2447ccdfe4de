use super::*;
use crate::wrench::Axis;
use rand::SeedableRng;

#[test]
fn one_trial_per_set_writes_frames_and_labels_that_read_back() {
    let c = NailSimConfig::default().with_trials(1).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let mut w = NailWriter::create(dir.path()).unwrap();
    let mut peak = [0.0f64; 6];
    collect_nail(&c, Protocol::Sets, 1, 1, &mut |r| {
        for (p, a) in peak.iter_mut().zip(Axis::ALL) {
            *p = p.max(r.label.wrench().get(a).abs());
        }
        w.write(&r)
    })
    .unwrap();
    assert_eq!(w.finish().unwrap(), 4 * 600);
    assert!(is_nail_dir(dir.path()));
    let labels = read_labels(dir.path()).unwrap();
    assert_eq!(labels.len(), 2400);
    assert_eq!(labels[0].frame, "frames/000000.png");
    assert_eq!((labels[600].set, labels[600].trial), (2, 1));
    // Forces to ~10 N, tangential to ~4.5 N; torques of a few N·mm.
    assert!(peak[2] > 6.0 && peak[2] < 10.5, "{peak:?}");
    assert!(peak[0] > 1.0 && peak[1] > 1.0 && peak[0] < 5.0, "{peak:?}");
    assert!(peak[3] > 0.005 && peak[3] < 0.05, "{peak:?}");
    let f = read_frame(dir.path(), &labels[5]).unwrap();
    assert_eq!((f.width(), f.height()), (96, 104));
    // The first frames are out of contact: zero force up to the noise.
    assert!(labels[..30].iter().all(|l| l.fz.abs() < 0.1));
}

#[test]
fn the_radial_test_holds_one_direction_per_trial_after_a_rest() {
    let mut c = NailSimConfig::default();
    c.protocol.radial.directions = 4;
    c.protocol.radial.cycle_s = 4.0;
    c.protocol.radial.cycles = 3;
    let mut labels = Vec::new();
    collect_nail(&c, Protocol::Radial, 1, 1, &mut |r| {
        labels.push(r.label);
        Ok(())
    })
    .unwrap();
    // 4 trials of 1 s rest and 3 cycles of 4 s, at 30 fps.
    assert_eq!(labels.len(), 4 * 13 * 30);
    assert!(labels.iter().all(|l| l.set == RADIAL_SET));
    for trial in 1..=4u32 {
        let rows: Vec<&Label> = labels.iter().filter(|l| l.trial == trial).collect();
        assert!(rows[..30].iter().all(|l| l.wrench().force.norm() < 0.1));
        // Tops of the cycles (t = 3, 7, 11 s): Fz 10 N, Fr 0, 2.5, 5 N
        // along 0, 90, 180, 270 deg, up to the reference's noise.
        for (cycle, fr) in [0.0, 2.5, 5.0].into_iter().enumerate() {
            let l = rows[(3 + 4 * cycle) * 30];
            assert!((l.fz - 10.0).abs() < 0.1, "{l:?}");
            assert!((l.fx.hypot(l.fy) - fr).abs() < 0.1, "{l:?}");
        }
        // The slider's load cell reads along it only: every label lies
        // on its line, the pushes on the side it points to.
        let (s, c) = (std::f64::consts::FRAC_PI_2 * f64::from(trial - 1)).sin_cos();
        assert!(rows.iter().all(|l| (l.fx * s - l.fy * c).abs() < 1e-12));
        let l = rows[11 * 30];
        assert!(l.fx * c + l.fy * s > 4.9, "trial {trial}: {l:?}");
    }
}

#[test]
fn the_radial_peaks_press_at_10_n_with_every_tangential_step() {
    let c = NailSimConfig::default();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
    let peaks = radial_peaks(&c, &mut rng);
    // 12 directions, cycles 2 to 5: Fr 1.25, 2.5, 3.75, 5 N at Fz 10 N.
    assert_eq!(peaks.len(), 48);
    for (k, p) in peaks.iter().enumerate() {
        let [fx, fy, fz] = p.force;
        let fr = 1.25 * (k % 4 + 1) as f64;
        let direction = (30.0 * (k / 4) as f64).to_radians();
        assert!((fz - 10.0).abs() < 1e-9, "{p:?}");
        assert!((fx - fr * direction.cos()).abs() < 1e-9, "{k}: {p:?}");
        assert!((fy - fr * direction.sin()).abs() < 1e-9, "{k}: {p:?}");
        // Drawn within +-3 mm, rolled 1.5 mm at the peak; +-15 N·mm.
        assert!(p.centre_mm.iter().all(|x| x.abs() <= 4.5), "{p:?}");
        assert!(p.twist_nmm.abs() <= 15.0, "{p:?}");
    }
    let spread = peaks.iter().map(|p| p.centre_mm[0]).fold(0.0, f64::max);
    assert!(spread > 2.0, "the pads are drawn: largest x {spread} mm");
}

#[test]
fn bad_labels_are_named() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join(FRAMES_DIR)).unwrap();
    let path = dir.path().join(LABELS_FILE);
    std::fs::write(&path, "t,set,trial,frame,fx,fy,fz,tx,ty,tz\n").unwrap();
    let e = read_labels(dir.path()).unwrap_err().to_string();
    assert!(e.contains("no frames"), "{e}");
    std::fs::write(
        &path,
        "t,set,trial,frame,fx,fy,fz,tx,ty,tz\n0,1,1,frames/a.png,NaN,0,0,0,0,0\n",
    )
    .unwrap();
    let e = read_labels(dir.path()).unwrap_err().to_string();
    assert!(e.contains("line 2"), "{e}");
    std::fs::write(&path, "t,set\n0,1\n").unwrap();
    assert!(read_labels(dir.path()).is_err());
}
