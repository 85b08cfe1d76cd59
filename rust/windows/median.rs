//! The paper's 3×3 median filter on a window's active pixels.
//!
//! Definition: let `A` be the window's binary map of active pixels (1 where the pixel has an
//! input spike), padded with zeros outside the sensor. An active pixel is kept iff the median of
//! its 3×3 neighbourhood in `A` (itself included) is 1, that is, iff at least
//! [`MEDIAN_MIN_ACTIVE`] = 5 of those 9 pixels are active. The filter is applied once, to the
//! unfiltered map. It only removes spikes: a silent pixel whose neighbourhood median is 1 stays
//! silent, since it has no time to give. Kept spikes keep their times and their order.
//!
//! Cost: `O(spikes)` per window, with a per-pixel stamp array that is never cleared (a new stamp
//! marks each window).

use crate::error::{check_alloc, Error, Result};
use crate::events::SensorSize;

/// Active pixels (out of 9) a 3×3 neighbourhood needs for its median to be 1.
pub const MEDIAN_MIN_ACTIVE: u32 = 5;

/// Reusable state of the median filter for one sensor (8 bytes a pixel). Internal to windowing:
/// [`compact`](Self::compact) trusts its spikes to lie on the sensor, as windowing's are; users
/// filter pixels with [`median_keep`].
#[derive(Debug, Clone)]
pub(crate) struct MedianFilter {
    sensor: SensorSize,
    mark: Vec<u64>,
    stamp: u64,
}

impl MedianFilter {
    /// A filter for `sensor`, or [`Error::InvalidParameter`] (`sensor_size`) when it has a
    /// zero side or its 8 bytes a pixel are above
    /// [`MAX_ALLOC_BYTES`](crate::error::MAX_ALLOC_BYTES).
    pub(crate) fn new(sensor: SensorSize) -> Result<Self> {
        sensor.validate()?;
        check_alloc(
            "sensor_size",
            || {
                format!(
                    "the median filter of a {}x{} sensor (8 bytes a pixel)",
                    sensor.width, sensor.height
                )
            },
            sensor.area(),
            8,
        )?;
        Ok(Self {
            sensor,
            mark: vec![0; sensor.area()],
            stamp: 0,
        })
    }

    /// Filter one window's spikes (columns of equal length, on the sensor, one per pixel) in
    /// place: the kept spikes move to the front, in order; returns how many were kept.
    pub(crate) fn compact(&mut self, t: &mut [u64], x: &mut [u16], y: &mut [u16]) -> usize {
        self.stamp += 1;
        for (&xi, &yi) in x.iter().zip(y.iter()) {
            self.mark[self.sensor.index(xi, yi)] = self.stamp;
        }
        let mut kept = 0;
        for j in 0..t.len() {
            if self.active_around(x[j], y[j]) >= MEDIAN_MIN_ACTIVE {
                t[kept] = t[j];
                x[kept] = x[j];
                y[kept] = y[j];
                kept += 1;
            }
        }
        kept
    }

    /// Active pixels in the 3×3 neighbourhood of `(x, y)` under the current stamp.
    fn active_around(&self, x: u16, y: u16) -> u32 {
        let (w, h) = (self.sensor.width, self.sensor.height);
        let mut count = 0;
        for ny in y.saturating_sub(1)..=(y + 1).min(h - 1) {
            for nx in x.saturating_sub(1)..=(x + 1).min(w - 1) {
                count += u32::from(self.mark[self.sensor.index(nx, ny)] == self.stamp);
            }
        }
        count
    }
}

/// Which of the pixels `(x[i], y[i])` (distinct, on the sensor) the median filter keeps.
///
/// # Errors
///
/// [`Error::Shape`] when the columns differ in length, [`Error::InvalidEvent`] for a pixel off
/// the sensor, [`Error::InvalidParameter`] (`sensor_size`) when the sensor has a zero side
/// ([`SensorSize::validate`]) or the filter's 8 bytes a pixel are above
/// [`MAX_ALLOC_BYTES`](crate::error::MAX_ALLOC_BYTES).
pub fn median_keep(sensor: SensorSize, x: &[u16], y: &[u16]) -> Result<Vec<bool>> {
    sensor.validate()?;
    if x.len() != y.len() {
        return Err(Error::Shape {
            name: "x, y",
            expected: "columns of equal length".into(),
            got: format!("{} and {}", x.len(), y.len()),
        });
    }
    let mut filter = MedianFilter::new(sensor)?;
    filter.stamp = 1;
    for (i, (&xi, &yi)) in x.iter().zip(y).enumerate() {
        if !sensor.contains(xi, yi) {
            return Err(Error::InvalidEvent {
                index: i,
                reason: format!(
                    "(x={xi}, y={yi}) is outside the {}x{} sensor",
                    sensor.width, sensor.height
                ),
            });
        }
        filter.mark[sensor.index(xi, yi)] = 1;
    }
    Ok(x.iter()
        .zip(y)
        .map(|(&xi, &yi)| filter.active_around(xi, yi) >= MEDIAN_MIN_ACTIVE)
        .collect())
}
