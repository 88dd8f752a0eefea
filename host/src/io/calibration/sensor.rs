//! `[sensor]`: the camera's read noise, measured by `calibrate reference` from the reference
//! plane's captures (issue #19 item 5), so that `scan` and a head (`device upload`) set the
//! decoder's minimum modulation in the sensor's own terms, `12σ`
//! ([`DecodeConfig::for_sensor`]), at any bit depth, without `--noise`.

use fringe3d_core::decode::DecodeConfig;

/// The camera's read noise: σ of one sample in codes of `bits`-bit images.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorNoise {
    /// The bit depth of the images it was measured on (1 to 16).
    pub bits: u8,
    /// σ of one sample, codes of such images.
    pub noise: f64,
}

impl SensorNoise {
    /// Check the fields; the message names the key.
    pub fn validate(&self) -> Result<(), String> {
        if !(1..=16).contains(&self.bits) {
            return Err(format!("[sensor] bits must be 1 to 16, got {}", self.bits));
        }
        let full = ((1u32 << self.bits) - 1) as f64;
        if !(self.noise.is_finite() && self.noise > 0.0 && self.noise < full) {
            return Err(format!(
                "[sensor] noise must be more than 0 and below full scale ({full} codes at {} \
                 bits), got {}",
                self.bits, self.noise
            ));
        }
        Ok(())
    }

    /// σ in codes of `bits`-bit images: the same noise relative to full scale (a capture's bit
    /// depth may differ from the calibration's, e.g. 8-bit previews of a 16-bit camera).
    pub fn sigma_at(&self, bits: u8) -> f32 {
        let full = |b: u8| ((1u32 << b.clamp(1, 16)) - 1) as f64;
        (self.noise * full(bits) / full(self.bits)) as f32
    }

    /// The decoder's defaults for `bits`-bit images of this sensor: the bit depth's, with the
    /// minimum modulation at `12σ` ([`DecodeConfig::for_sensor`]).
    pub fn decode_config(&self, bits: u8) -> DecodeConfig {
        DecodeConfig::for_sensor(u32::from(bits), self.sigma_at(bits))
    }
}
