//! The rectangle of pixels an estimator of this module follows (the rotor signature's and the
//! rate spectrum's box), and the cap on its size.

use crate::error::{Error, Result};
use crate::events::SensorSize;

/// The largest number of pixels one estimator may follow (a 2048×2048 box, 128 MiB of state).
pub const MAX_PIXELS: usize = 1 << 22;

/// The rectangle of pixels an estimator follows: columns `x0..x0 + width`, rows `y0..y0 + height`.
///
/// The fields are public, so a region written as a struct literal may be empty, leave the
/// 16-bit coordinates or exceed [`MAX_PIXELS`]. The estimators that take one
/// ([`RotorSignature::new`](super::RotorSignature::new),
/// [`RotorSpectrum::new`](super::spectrum::RotorSpectrum::new)) check it
/// ([`Region::validate`]) and refuse it with the [`Error::InvalidParameter`] (`box`) that
/// [`Region::new`] gives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Region {
    /// Left column.
    pub x0: u16,
    /// Top row.
    pub y0: u16,
    /// Columns, at least 1.
    pub width: u16,
    /// Rows, at least 1.
    pub height: u16,
}

impl Region {
    /// A region, rejecting an empty one, one that overflows the 16-bit coordinates, or one of more
    /// than [`MAX_PIXELS`] pixels.
    ///
    /// # Errors
    ///
    /// [`Error::InvalidParameter`] (`box`) for the cases above.
    pub fn new(x0: u16, y0: u16, width: u16, height: u16) -> Result<Self> {
        if width == 0 || height == 0 {
            return Err(Error::param(
                "box",
                format!("width and height must be positive, got {width}x{height}"),
            ));
        }
        if x0 as u32 + width as u32 > 65_536 || y0 as u32 + height as u32 > 65_536 {
            return Err(Error::param(
                "box",
                format!("({x0}, {y0}) + {width}x{height} leaves the 16-bit coordinates"),
            ));
        }
        let area = width as usize * height as usize;
        if area > MAX_PIXELS {
            return Err(Error::param(
                "box",
                format!("{width}x{height} = {area} pixels is above the cap of {MAX_PIXELS}"),
            ));
        }
        Ok(Self {
            x0,
            y0,
            width,
            height,
        })
    }

    /// This region re-checked as [`Region::new`] checks one: the fields are public, so a
    /// region written as a struct literal may be empty, overflow or exceed [`MAX_PIXELS`].
    ///
    /// # Errors
    ///
    /// As [`Region::new`].
    pub fn validate(self) -> Result<Self> {
        Self::new(self.x0, self.y0, self.width, self.height)
    }

    /// The whole sensor.
    ///
    /// # Errors
    ///
    /// [`Error::InvalidParameter`] (`sensor_size`) for a sensor with a zero side
    /// ([`SensorSize::validate`]), else as [`Region::new`].
    pub fn sensor(sensor: SensorSize) -> Result<Self> {
        let sensor = sensor.validate()?;
        Self::new(0, 0, sensor.width, sensor.height)
    }

    /// Number of pixels.
    pub fn area(self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Row-major index of a pixel inside the region, or `None` outside it.
    #[inline]
    pub(super) fn index(self, x: u16, y: u16) -> Option<usize> {
        let dx = x.wrapping_sub(self.x0);
        let dy = y.wrapping_sub(self.y0);
        (x >= self.x0 && y >= self.y0 && dx < self.width && dy < self.height)
            .then(|| dy as usize * self.width as usize + dx as usize)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_overflowing_and_oversized_regions_are_typed_errors() {
        assert!(Region::new(0, 0, 0, 4).is_err());
        assert!(Region::new(65_535, 0, 2, 4).is_err());
        assert!(Region::new(0, 0, 4096, 2048).is_err());
        assert!(Region::new(65_534, 0, 2, 4).is_ok());
    }

    #[test]
    fn the_region_of_a_zero_sensor_blames_the_sensor() {
        // A 0x0 SensorSize literal was refused as an empty `box`, a parameter the caller of
        // `Region::sensor` never gave.
        let zero = SensorSize {
            width: 0,
            height: 0,
        };
        crate::events::assert_zero_sensor(&Region::sensor(zero).unwrap_err());
        let sensor = SensorSize::new(240, 180).unwrap();
        assert_eq!(Region::sensor(sensor), Region::new(0, 0, 240, 180));
    }

    #[test]
    fn index_is_row_major_inside_and_none_outside() {
        let r = Region::new(10, 20, 4, 3).unwrap();
        assert_eq!(r.area(), 12);
        assert_eq!(r.index(10, 20), Some(0));
        assert_eq!(r.index(13, 20), Some(3));
        assert_eq!(r.index(10, 21), Some(4));
        assert_eq!(r.index(13, 22), Some(11));
        for (x, y) in [
            (9, 20),
            (14, 20),
            (10, 19),
            (10, 23),
            (0, 0),
            (u16::MAX, u16::MAX),
        ] {
            assert_eq!(r.index(x, y), None, "({x}, {y})");
        }
    }
}
