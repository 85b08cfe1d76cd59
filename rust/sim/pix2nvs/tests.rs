use super::compat::x86_int;
use super::*;
use ndarray::Array2;

fn run(params: Pix2NvsParams, frames: &[Array2<u8>], dt: u64) -> Vec<Event> {
    let (h, w) = frames[0].dim();
    let mut sim = Pix2Nvs::new(params, w, h, None).unwrap();
    let mut out = Vec::new();
    for (k, f) in frames.iter().enumerate() {
        sim.push(&Frame::Gray(f.view()), k as u64 * dt, &mut out)
            .unwrap();
    }
    out
}

fn flat(w: usize, h: usize, v: u8) -> Array2<u8> {
    Array2::from_elem((h, w), v)
}

#[test]
fn static_scene_is_silent() {
    let f = flat(8, 6, 90);
    assert!(run(Pix2NvsParams::default(), &[f.clone(), f.clone(), f], 1000).is_empty());
}

#[test]
fn counts_and_times_follow_print_event() {
    // ln(201/51) = 1.371 -> floor(1.371/0.4) = 3 ON events at k*0.4/1.371 of the interval.
    let p = Pix2NvsParams {
        adaptive: 0.0,
        ..Pix2NvsParams::default()
    };
    let ev = run(p, &[flat(1, 1, 50), flat(1, 1, 200)], 30_000);
    let d = (201.0f64 / 51.0).ln();
    let want: Vec<u64> = (1..=3)
        .map(|k| (30_000.0 * f64::from(k) * 0.4 / d).round() as u64)
        .collect();
    assert_eq!(ev.iter().map(|e| e.t).collect::<Vec<_>>(), want);
    assert!(ev.iter().all(|e| e.p));
    // and OFF going back down, capped by n_max
    let p2 = Pix2NvsParams { n_max: 2, ..p };
    let ev = run(p2, &[flat(1, 1, 200), flat(1, 1, 50)], 30_000);
    assert_eq!(ev.len(), 2);
    assert!(ev.iter().all(|e| !e.p));
}

#[test]
fn increment_mode_keeps_the_remainder() {
    let p = Pix2NvsParams {
        adaptive: 0.0,
        threshold: 0.5,
        reference: ReferenceUpdate::EventIncrement,
        ..Pix2NvsParams::default()
    };
    // ln(2.7 * 51) - ln(51) ~ 0.99 -> 1 event, remainder 0.49 stays; a small further
    // rise of 0.02 then makes a second event in increment mode only.
    let a = flat(1, 1, 50);
    let b = flat(1, 1, 137);
    let c = flat(1, 1, 140);
    assert_eq!(run(p, &[a.clone(), b.clone(), c.clone()], 10).len(), 2);
    let copy = Pix2NvsParams {
        reference: ReferenceUpdate::EventCopy,
        ..p
    };
    assert_eq!(run(copy, &[a, b, c], 10).len(), 1);
}

#[test]
fn inhibition_keeps_one_pixel_per_block_and_pooling_one_per_output() {
    let mut b = flat(4, 4, 50);
    b[[0, 0]] = 120;
    b[[1, 1]] = 250; // strongest in the top-left 2x2 block
    b[[3, 3]] = 200;
    let p = Pix2NvsParams {
        block_size: 2,
        n_max: 1,
        ..Pix2NvsParams::default()
    };
    let ev = run(p, &[flat(4, 4, 50), b.clone()], 100);
    let mut xy: Vec<(u16, u16)> = ev.iter().map(|e| (e.x, e.y)).collect();
    xy.sort_unstable();
    assert_eq!(xy, vec![(1, 1), (3, 3)]);

    let p1 = Pix2NvsParams {
        n_max: 1,
        ..Pix2NvsParams::default()
    };
    let mut sim = Pix2Nvs::new(p1, 4, 4, Some((2, 2, Pooling::Strongest))).unwrap();
    let mut out = Vec::new();
    sim.push(&Frame::Gray(flat(4, 4, 50).view()), 0, &mut out)
        .unwrap();
    sim.push(&Frame::Gray(b.view()), 100, &mut out).unwrap();
    let mut xy: Vec<(u16, u16)> = out.iter().map(|e| (e.x, e.y)).collect();
    xy.sort_unstable();
    assert_eq!(xy, vec![(0, 0), (1, 1)]);
    let mut all = Pix2Nvs::new(p1, 4, 4, Some((2, 2, Pooling::All))).unwrap();
    let mut out = Vec::new();
    all.push(&Frame::Gray(flat(4, 4, 50).view()), 0, &mut out)
        .unwrap();
    all.push(&Frame::Gray(b.view()), 100, &mut out).unwrap();
    assert_eq!(out.len(), 3);
}

#[test]
fn adaptive_threshold_rises_after_events() {
    // Same step twice: with a large adaptive coefficient the second step is below the
    // raised threshold.
    let p = Pix2NvsParams {
        adaptive: 0.5,
        threshold: 0.3,
        n_max: 1,
        reference: ReferenceUpdate::EventCopy,
        ..Pix2NvsParams::default()
    };
    let steps = [flat(1, 1, 50), flat(1, 1, 75), flat(1, 1, 112)];
    assert_eq!(run(p, &steps, 10).len(), 1);
    // A ceiling on the threshold lets the second step through again.
    let capped = Pix2NvsParams {
        threshold_max: 0.35,
        ..p
    };
    assert_eq!(run(capped, &steps, 10).len(), 2);
    let bad = Pix2NvsParams {
        threshold_min: 0.5,
        ..p
    };
    assert!(bad.validate().is_err());
}

#[test]
fn compat_reads_luma_two_bytes_late_and_converts_like_x86() {
    // One row of 4 pixels (12 bytes, no padding): pixel x's luma takes the red of x and
    // the blue and green of x + 1; the last takes pixel 0 of the row above, here past
    // the end of the data (0).
    let mut img = ndarray::Array3::<u8>::zeros((1, 4, 3));
    for x in 0..4 {
        img[[0, x, 0]] = 10 + x as u8; // B
        img[[0, x, 1]] = 20 + x as u8; // G
        img[[0, x, 2]] = 30 + x as u8; // R
    }
    let mut out = vec![0.0f32; 4];
    compat_luma_row(&Frame::Bgr(img.view()), 0, &mut out);
    for (x, &got) in out.iter().take(3).enumerate() {
        let (r, b, g) = (30.0 + x as f64, 11.0 + x as f64, 21.0 + x as f64);
        let y = (0.299 * g + 0.587 * b + 0.114 * r) as f32;
        assert_eq!(got.to_bits(), y.ln().to_bits(), "pixel {x}");
    }
    assert_eq!(out[3].to_bits(), ((0.114 * 33.0) as f32).ln().to_bits());
    assert_eq!(x86_int(f32::INFINITY), i32::MIN);
    assert_eq!(x86_int(f32::NAN), i32::MIN);
    assert_eq!(x86_int(3.9), 3);
    let odd = Pix2NvsParams {
        compat: true,
        block_size: 2,
        ..Pix2NvsParams::default()
    };
    assert!(Pix2Nvs::new(odd, 3, 2, None).is_err());
    assert!(Pix2Nvs::new(odd, 4, 2, None).is_ok());
}

#[test]
fn rejects_bad_input() {
    let mut sim = Pix2Nvs::new(Pix2NvsParams::default(), 3, 2, None).unwrap();
    let mut out = Vec::new();
    sim.push(&Frame::Gray(flat(3, 2, 1).view()), 10, &mut out)
        .unwrap();
    let e = sim
        .push(&Frame::Gray(flat(3, 2, 1).view()), 10, &mut out)
        .unwrap_err();
    assert!(e.to_string().contains("not after"), "{e}");
    assert!(sim
        .push(&Frame::Gray(flat(2, 2, 1).view()), 20, &mut out)
        .is_err());
    let bad = Pix2NvsParams {
        threshold: f32::NAN,
        ..Pix2NvsParams::default()
    };
    assert!(Pix2Nvs::new(bad, 3, 2, None).is_err());
    assert!(Pix2Nvs::new(Pix2NvsParams::default(), 3, 2, Some((4, 2, Pooling::All))).is_err());
    assert!(Pix2Nvs::new(Pix2NvsParams::default(), 0, 2, None).is_err());
}

#[test]
fn a_simulator_above_the_memory_cap_is_refused() {
    let err = Pix2Nvs::new(Pix2NvsParams::default(), 65535, 65535, None).unwrap_err();
    crate::error::assert_over_cap(&err, "frame size");
    Pix2Nvs::new(Pix2NvsParams::default(), 1280, 720, None).unwrap();
}
