use super::*;
use crate::biotac::{Electrodes, N_PAC};

fn reading(electrodes: Electrodes) -> BioTacReading {
    BioTacReading {
        seq: 0,
        stamp_s: 0.0,
        electrodes,
        pdc: 2000,
        pac: [2048; N_PAC].into(),
        tdc: 2500,
        tac: 2000,
    }
}

fn input(layout: ElectrodeLayout, features: &[&str]) -> Result<BioTacInput, SensorError> {
    let features: Vec<String> = features.iter().map(|f| f.to_string()).collect();
    BioTacInput::for_model(ModelInput {
        features: &features,
        sensor: &SensorSpec::biotac(layout),
        tare_samples: 1,
    })
}

#[test]
fn a_biotac_sp_model_reads_e24_and_refuses_a_biotacs_readings_by_name() {
    let mut sp = input(ElectrodeLayout::BiotacSp, &["e1", "e24", "pdc"]).unwrap();
    let mut values = [3000; 24];
    values[23] = 2900;
    let base = reading(values.into());
    let mut out = [0.0; 3];
    assert_eq!(sp.features(&base, &mut out), Ok(None), "the tare");
    values[23] = 2800;
    let pressed = reading(values.into());
    assert_eq!(sp.features(&pressed, &mut out), Ok(Some(0.0)));
    assert_eq!(out, [0.0, -100.0, 0.0]);

    let err = sp
        .features(&reading([3000; 19].into()), &mut out)
        .unwrap_err();
    assert_eq!(
        err.to_string(),
        "model trained on 24 electrodes, readings have 19 electrodes"
    );
    let mut bt = input(ElectrodeLayout::Biotac, &["e1", "pdc"]).unwrap();
    let err = bt.features(&pressed, &mut out).unwrap_err();
    assert_eq!(
        err.to_string(),
        "model trained on 19 electrodes, readings have 24 electrodes"
    );
}

#[test]
fn a_biotac_model_cannot_take_an_electrode_the_biotac_lacks() {
    let err = input(ElectrodeLayout::Biotac, &["e1", "e20"]).unwrap_err();
    assert!(err.to_string().contains("e1..e19"), "{err}");
    assert!(input(ElectrodeLayout::BiotacSp, &["e1", "e20"]).is_ok());
}

/// Restarted with a tare of this sensor too old to take up: no new tare
/// while PDC stands above it (the finger pressed), one once released; the
/// first start, with nothing to compare, tares on what it reads.
#[test]
fn against_an_earlier_tare_a_pressed_finger_is_not_tared() {
    let rest = reading([3000; 19].into());
    let pressed = BioTacReading {
        pdc: rest.pdc + 100,
        ..rest
    };
    let mut out = [0.0; 2];
    let mut bt = input(ElectrodeLayout::Biotac, &["e1", "pdc"]).unwrap();
    bt.set_reference(Tare::from_readings(&[rest]).unwrap());
    for _ in 0..3 {
        assert_eq!(bt.features(&pressed, &mut out), Ok(None));
        assert!(!bt.is_ready(), "tared on a press");
    }
    let released = BioTacReading {
        pdc: rest.pdc + 20,
        ..rest
    };
    assert_eq!(bt.features(&released, &mut out), Ok(None), "the tare");
    assert_eq!(bt.tare().map(Tare::pdc), Some(f64::from(released.pdc)));

    let mut first = input(ElectrodeLayout::Biotac, &["e1", "pdc"]).unwrap();
    assert_eq!(first.features(&pressed, &mut out), Ok(None));
    assert!(first.is_ready());
}
