//! Sub-frame samples: between two frames, disjoint patches of the sensor (a rotor, a wing)
//! known at more times than the frames, so that what changes faster than the frame rate
//! reaches their pixels ([`DvsEmulator::push_with_samples`]): the patches' type and the checks
//! they pass before any pixel moves.

use super::DvsEmulator;
use crate::error::{Error, Result};

/// Luma of one rectangular patch of the sensor at times between two frames.
#[derive(Debug, Clone, Copy)]
pub struct SubSamples<'a> {
    /// Left column of the patch.
    pub x0: usize,
    /// Top row of the patch.
    pub y0: usize,
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Sample times in microseconds, strictly increasing, strictly between the two frames.
    pub times: &'a [u64],
    /// Luma (0–255 scale, linear), `times.len()` row-major planes of `height × width`.
    pub values: &'a [f32],
}

impl DvsEmulator {
    /// Patches on the sensor, disjoint, with strictly increasing times inside `(t0, t1)` and
    /// one finite, non-negative value per time and pixel.
    pub(super) fn check_patches(&self, patches: &[SubSamples<'_>], t0: u64, t1: u64) -> Result<()> {
        let bad = |i: usize, why: String| {
            Err(Error::Simulation(format!(
                "frame {}: sub-frame patch {i}: {why}",
                self.frames
            )))
        };
        for (i, pa) in patches.iter().enumerate() {
            // Checked: offsets near `usize::MAX` must not wrap onto the sensor.
            let fits = |start: usize, len: usize, side: usize| {
                len > 0 && start.checked_add(len).is_some_and(|end| end <= side)
            };
            if !(fits(pa.x0, pa.width, self.width) && fits(pa.y0, pa.height, self.height)) {
                return bad(
                    i,
                    format!(
                        "{}x{} at ({}, {}) does not lie on the {}x{} sensor",
                        pa.width, pa.height, pa.x0, pa.y0, self.width, self.height
                    ),
                );
            }
            let mut prev = t0;
            for &t in pa.times {
                if t <= prev || t >= t1 {
                    return bad(
                        i,
                        format!(
                            "time {t} us is not strictly between {prev} us and the frame at \
                             {t1} us"
                        ),
                    );
                }
                prev = t;
            }
            // The patch lies on the sensor, so `width · height` fits; the product with the
            // times is checked.
            let expected = pa.times.len().checked_mul(pa.width * pa.height);
            if expected != Some(pa.values.len()) {
                return bad(
                    i,
                    format!(
                        "{} values for {} times of {}x{} pixels",
                        pa.values.len(),
                        pa.times.len(),
                        pa.width,
                        pa.height
                    ),
                );
            }
            if let Some(v) = pa.values.iter().find(|v| !(v.is_finite() && **v >= 0.0)) {
                return bad(i, format!("luma must be finite and >= 0, got {v}"));
            }
            for (j, other) in patches[..i].iter().enumerate() {
                let apart = pa.x0 >= other.x0 + other.width
                    || other.x0 >= pa.x0 + pa.width
                    || pa.y0 >= other.y0 + other.height
                    || other.y0 >= pa.y0 + pa.height;
                if !apart {
                    return bad(i, format!("overlaps patch {j}"));
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::run;
    use super::*;
    use crate::events::Event;
    use crate::sim::{DvsParams, Frame};
    use ndarray::Array2;

    #[test]
    fn sub_frame_samples_equal_frames_at_those_times() {
        // A patch sampled between two frames gives exactly the events of full frames at the
        // samples' times; outside the patch, the frames alone.
        let p = DvsParams {
            cutoff_hz: 2000.0,
            cutoff_dark_luma: 1.0,
            ..DvsParams::ideal()
        };
        let frame = |k: usize| {
            Array2::from_shape_fn((4, 6), |(y, x)| {
                (40.0 + 30.0 * ((x + 2 * y + 3 * k) % 5) as f32) * (1.0 + 0.5 * k as f32)
            })
        };
        let all: Vec<Array2<f32>> = (0..4).map(frame).collect();
        let full = run(p, &all, &[0, 100, 250, 400], 0);
        let mut emu = DvsEmulator::new(p, 6, 4, 0).unwrap();
        let mut out = Vec::new();
        emu.push(&Frame::GrayF32(all[0].view()), 0, &mut out)
            .unwrap();
        let mut last = all[3].clone();
        // Outside the patch (columns 2..5, rows 1..3) the pixels move from frame 0 to frame 3.
        for y in 0..4 {
            for x in 0..6 {
                if !((2..5).contains(&x) && (1..3).contains(&y)) {
                    last[(y, x)] = all[0][(y, x)];
                }
            }
        }
        let values: Vec<f32> = [1, 2]
            .iter()
            .flat_map(|&k| {
                let f = &all[k];
                (1..3).flat_map(move |y| (2..5).map(move |x| f[(y, x)]))
            })
            .collect();
        let patch = SubSamples {
            x0: 2,
            y0: 1,
            width: 3,
            height: 2,
            times: &[100, 250],
            values: &values,
        };
        emu.push_with_samples(&Frame::GrayF32(last.view()), 400, &[patch], &mut out)
            .unwrap();
        let inside = |e: &&Event| (2..5).contains(&e.x) && (1..3).contains(&e.y);
        let want: Vec<Event> = full.iter().filter(inside).copied().collect();
        let got: Vec<Event> = out.iter().filter(inside).copied().collect();
        assert!(!want.is_empty());
        assert_eq!(got, want);
        assert!(out.iter().all(|e| inside(&e)), "static pixels made events");
        assert!(out.windows(2).all(|w| w[0].t <= w[1].t));
    }

    #[test]
    fn float_frames_match_8_bit_frames() {
        // Float input keeps each pixel's response while its luma does not change; 8-bit input
        // reads a table every frame. With integer luma and no low-pass (whose tables differ)
        // both give the same events: pixels that stay, change, and come back.
        let p = DvsParams {
            leak_rate_hz: 50.0,
            shot_noise_rate_hz: 20.0,
            hot_pixel_fraction: 0.05,
            refractory_us: 300.0,
            cutoff_hz: 0.0,
            ..DvsParams::default()
        };
        let (h, w) = (6, 9);
        let frames: Vec<Array2<u8>> = (0..40u32)
            .map(|k| {
                Array2::from_shape_fn((h, w), |(y, x)| {
                    let moving = (x + y) % 3 == 0 && (k / 4) % 2 == 1;
                    (30 + 20 * ((x + 2 * y) % 7) + if moving { 60 } else { 0 }) as u8
                })
            })
            .collect();
        let times: Vec<u64> = (0..40).map(|k| k * 2_000).collect();
        let mut a = DvsEmulator::new(p, w, h, 5).unwrap();
        let mut b = DvsEmulator::new(p, w, h, 5).unwrap();
        let (mut ea, mut eb) = (Vec::new(), Vec::new());
        for (f, &t) in frames.iter().zip(&times) {
            a.push(&Frame::Gray(f.view()), t, &mut ea).unwrap();
            let g = f.mapv(f32::from);
            b.push(&Frame::GrayF32(g.view()), t, &mut eb).unwrap();
        }
        assert!(ea.len() > 100, "{}", ea.len());
        assert_eq!(ea, eb);
    }

    #[test]
    fn rejects_bad_patches() {
        let mut emu = DvsEmulator::new(DvsParams::ideal(), 4, 4, 0).unwrap();
        let f = Array2::from_elem((4, 4), 10.0f32);
        let mut out = Vec::new();
        let v = [1.0f32; 4];
        let ok = SubSamples {
            x0: 0,
            y0: 0,
            width: 2,
            height: 2,
            times: &[5],
            values: &v,
        };
        // The first frame takes none.
        assert!(emu
            .push_with_samples(&Frame::GrayF32(f.view()), 0, &[ok], &mut out)
            .is_err());
        emu.push(&Frame::GrayF32(f.view()), 0, &mut out).unwrap();
        let bad = [
            SubSamples { x0: 3, ..ok },
            SubSamples { times: &[10], ..ok },
            SubSamples { times: &[0], ..ok },
            SubSamples {
                values: &v[..3],
                ..ok
            },
            SubSamples {
                values: &[1.0, f32::NAN, 1.0, 1.0],
                ..ok
            },
        ];
        for b in bad {
            assert!(emu
                .push_with_samples(&Frame::GrayF32(f.view()), 10, &[b], &mut out)
                .is_err());
        }
        assert!(emu
            .push_with_samples(
                &Frame::GrayF32(f.view()),
                10,
                &[ok, SubSamples { x0: 1, ..ok }],
                &mut out
            )
            .is_err());
        assert_eq!(emu.frames_seen(), 1);
        // Offsets near the end of `usize` wrap `x0 + width` onto the sensor unless checked.
        for b in [
            SubSamples {
                x0: usize::MAX,
                ..ok
            },
            SubSamples {
                y0: usize::MAX - 1,
                ..ok
            },
            SubSamples {
                width: usize::MAX,
                ..ok
            },
        ] {
            let err = emu
                .push_with_samples(&Frame::GrayF32(f.view()), 10, &[b], &mut out)
                .unwrap_err();
            assert!(err.to_string().contains("does not lie on"), "{err}");
        }
        assert_eq!(emu.frames_seen(), 1);
        assert_eq!(emu.last_time(), Some(0));
        emu.push_with_samples(
            &Frame::GrayF32(f.view()),
            10,
            &[ok, SubSamples { x0: 2, ..ok }],
            &mut out,
        )
        .unwrap();
    }
}
