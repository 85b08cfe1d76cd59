//! Noise: the waiting times of shot noise and hot pixels, and the step of a pixel whose interval
//! holds noise candidates, merged in time with its threshold crossings.

use rand::Rng;
use rand_pcg::Pcg64Mcg;

use super::pixel::{Pixel, Step};
use crate::events::Event;

/// A waiting time, in µs, of a Poisson process of `rate_per_us` (infinite at rate 0).
#[inline]
pub(super) fn exponential(rng: &mut Pcg64Mcg, rate_per_us: f64) -> f64 {
    if rate_per_us <= 0.0 {
        return f64::INFINITY;
    }
    let u: f64 = rng.random();
    -(1.0 - u).ln() / rate_per_us
}

/// The general case: threshold crossings merged in time with noise candidates. Returns `d`
/// at the end of the interval.
#[inline(never)]
pub(super) fn noisy_step(
    q: &mut Pixel,
    mut d: f64,
    g: f64,
    mut cur: f64,
    luma: f32,
    s: &Step,
    rng: &mut Pcg64Mcg,
    x: u16,
    y: u16,
    row: &mut Vec<Event>,
) -> f64 {
    let t1 = s.t1;
    let (th_on, th_off) = (f64::from(q.th_on), f64::from(q.th_off));
    loop {
        let t_sig = if g > 0.0 {
            cur + ((th_on - d) / g).max(0.0)
        } else if g < 0.0 {
            cur + ((-th_off - d) / g).max(0.0)
        } else {
            f64::INFINITY
        };
        let t_noise = q.next_shot.min(q.next_hot);
        if t_sig.min(t_noise) > t1 || row.len() >= s.row_cap {
            break;
        }
        let (t_event, polarity) = if t_sig <= t_noise {
            (t_sig, g > 0.0)
        } else {
            let hot = q.next_hot <= q.next_shot;
            let keep = if hot {
                q.next_hot += exponential(rng, q.hot_per_us);
                true
            } else {
                q.next_shot += exponential(rng, s.shot_max_per_us);
                // Thinning: the rate at this intensity over the highest rate.
                let level = (f64::from(luma) / 255.0).min(1.0);
                let factor = 1.0 + (s.bright_factor - 1.0) * level;
                rng.random::<f64>() * s.max_factor < factor
            };
            // Candidates that fall in a refractory period are lost.
            if !keep || t_noise < cur {
                continue;
            }
            let polarity = hot || rng.random::<bool>();
            (t_noise, polarity)
        };
        row.push(Event {
            t: s.event_time(t_event),
            x,
            y,
            p: polarity,
        });
        // Reset, then hold for the refractory period.
        d = 0.0;
        q.hold_until = t_event + s.refractory;
        cur = q.hold_until.min(t1).max(t_event);
    }
    d + g * (t1 - cur)
}
