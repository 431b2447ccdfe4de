use super::*;

#[test]
fn a_ring_keeps_the_newest_in_order() {
    let mut r: Ring<u32, 3> = Ring::new(0);
    assert!(r.is_empty() && r.last().is_none());
    for i in 1..=5 {
        r.push(i);
    }
    assert_eq!(r.iter().collect::<Vec<_>>(), [3, 4, 5]);
    assert_eq!((r.len(), r.get(0), r.last()), (3, 3, Some(5)));
    r.clear();
    assert!(r.is_empty());
}

#[test]
fn ages_give_their_quantiles() {
    let mut a = AgeWindow::default();
    assert_eq!(a.quantile(0.5), None);
    for i in 0..100 {
        a.push(i as f64 * 1e-3);
    }
    a.push(f64::NAN);
    // The last 64: 36..99 ms.
    assert!((a.quantile(0.5).unwrap() - 0.068).abs() < 1.1e-3);
    assert!((a.quantile(1.0).unwrap() - 0.099).abs() < 1e-12);
}

/// The timing the controller assumes until it has measured: a 10 ms
/// transport bound, a 10 ms period.
fn prior() -> LoopTiming {
    LoopTiming {
        transport_s: 0.01,
        latency_s: 0.035,
        lag_s: 0.03,
        period_s: 0.01,
    }
}

/// Arrivals of 100 Hz estimates, the k-th stamped at 10 k ms and arriving
/// `delay_ms(k)` later.
fn stream(n: usize, delay_ms: impl Fn(usize) -> f64) -> Arrivals {
    let mut a = Arrivals::default();
    for k in 0..n {
        let stamp = k as f64 * 0.01;
        a.on_arrival(stamp + delay_ms(k) * 1e-3, stamp);
    }
    a
}

#[test]
fn a_regular_stream_is_stale_n_periods_beyond_its_usual_age() {
    // 2 ms transport: due at 12 ms of age; stale beyond 2 + 3 x 10 ms.
    let a = stream(100, |_| 2.0);
    assert!((a.interval_s(0.5).unwrap() - 0.01).abs() < 1e-12);
    assert!((a.interval_s(0.99).unwrap() - 0.01).abs() < 1e-12);
    assert!((a.stale_after_s(3.0, &prior()) - 0.032).abs() < 1e-12);
    // Never one period and a few ms: two periods at the least.
    assert!((a.stale_after_s(2.0, &prior()) - 0.022).abs() < 1e-12);
    // The same estimate seen again is no arrival.
    let mut b = a.clone();
    b.on_arrival(1.0, 0.99);
    b.on_arrival(f64::NAN, 1.0);
    assert_eq!(b.interval_s(0.0), a.interval_s(0.0));
}

#[test]
fn the_bound_widens_by_twice_the_arrival_jitter_at_most_a_period() {
    // One estimate in 8 comes 4 ms later than the rest: r is 12 ms, or 16
    // ms (p99): 12 + 2 x 10 + 2 x 4 = 40 ms.
    let a = stream(160, |k| if k % 8 == 7 { 6.0 } else { 2.0 });
    assert!((a.interval_s(0.5).unwrap() - 0.01).abs() < 1e-12);
    assert!((a.interval_s(0.99).unwrap() - 0.014).abs() < 1e-12);
    assert!((a.stale_after_s(3.0, &prior()) - 0.040).abs() < 1e-12);
    // 10 ms later: the margin stops at a period, 12 + 20 + 10 = 42 ms.
    let a = stream(160, |k| if k % 8 == 7 { 12.0 } else { 2.0 });
    assert!((a.stale_after_s(3.0, &prior()) - 0.042).abs() < 1e-12);
}

#[test]
fn a_burst_of_faster_estimates_does_not_shrink_the_period() {
    // 64 estimates 1 ms apart, 2 ms old on arrival: due at 3 ms of age,
    // then three control periods of 10 ms, not of 1 ms.
    let mut a = Arrivals::default();
    for k in 0..64 {
        let stamp = k as f64 * 0.001;
        a.on_arrival(stamp + 0.002, stamp);
    }
    assert!((a.interval_s(0.5).unwrap() - 0.001).abs() < 1e-12);
    assert!((a.stale_after_s(3.0, &prior()) - 0.023).abs() < 1e-9);
}

#[test]
fn until_measured_the_priors_stand_and_a_slower_stream_is_learnt() {
    // The transport bound and n control periods: 10 + 3 x 10 ms.
    let none = Arrivals::default();
    assert_eq!(none.interval_s(0.5), None);
    assert!((none.stale_after_s(3.0, &prior()) - 0.04).abs() < 1e-12);
    // 3 intervals are not yet a measurement; 4 are.
    assert!((stream(4, |_| 1.0).stale_after_s(3.0, &prior()) - 0.04).abs() < 1e-12);
    assert!((stream(5, |_| 1.0).stale_after_s(3.0, &prior()) - 0.031).abs() < 1e-12);
    // A 50 Hz stream after a 100 Hz one: its own period once it is most
    // of the window, 1 + 3 x 20 ms.
    let mut a = stream(64, |_| 1.0);
    for k in 0..40 {
        let stamp = 0.64 + k as f64 * 0.02;
        a.on_arrival(stamp + 0.001, stamp);
    }
    assert!((a.stale_after_s(3.0, &prior()) - 0.061).abs() < 1e-9);
}
