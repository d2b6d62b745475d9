//! Scalar streams as 8-bit video samples: a value in [min, max] becomes the
//! nearest of 256 levels. An optional second layer carries the first layer's
//! residual, amplified: after H.264 has coded (and distorted) layer 1, the
//! encoder decodes it, and layer 2 codes `value - decoded`, clipped to
//! ±`residual_steps` layer-1 steps and spread over its own 256 levels, so the
//! pair resolves about log2(256 / (2 * residual_steps)) more bits.

/// Linear 8-bit quantization over a range.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Quantizer {
    /// Range of the (companded) values.
    pub min: f32,
    pub max: f32,
}

impl Quantizer {
    /// A quantizer covering `[min, max]`; a degenerate range is widened so
    /// that every value still maps to a level.
    pub fn new(min: f32, max: f32) -> Quantizer {
        let (min, max) = if max > min { (min, max) } else { (min - 0.5, min + 0.5) };
        Quantizer { min, max }
    }

    /// Size of one level.
    pub fn step(&self) -> f32 {
        (self.max - self.min) / 255.0
    }

    pub fn quantize(&self, x: f32) -> u8 {
        ((x - self.min) / self.step()).round().clamp(0.0, 255.0) as u8
    }

    pub fn dequantize(&self, q: u8) -> f32 {
        self.min + q as f32 * self.step()
    }

    /// The quantizer of a second layer refining this one (in its coded domain).
    pub fn residual(&self, residual_steps: f32) -> Quantizer {
        let r = self.step() * residual_steps;
        Quantizer { min: -r, max: r }
    }

    pub fn is_valid(&self) -> bool {
        self.min.is_finite() && self.max.is_finite() && self.max > self.min
    }
}

/// Running minimum and maximum of a stream.
#[derive(Debug, Clone, Copy)]
pub struct Range {
    pub min: f32,
    pub max: f32,
}

impl Default for Range {
    fn default() -> Self {
        Range { min: f32::INFINITY, max: f32::NEG_INFINITY }
    }
}

impl Range {
    pub fn add(&mut self, values: &[f32]) {
        for &v in values {
            self.min = self.min.min(v);
            self.max = self.max.max(v);
        }
    }

    pub fn quantizer(&self) -> Quantizer {
        if self.min.is_finite() {
            Quantizer::new(self.min, self.max)
        } else {
            Quantizer::new(0.0, 1.0)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_within_half_a_step() {
        let q = Quantizer::new(-2.0, 3.0);
        for i in 0..=1000 {
            let x = -2.0 + 5.0 * i as f32 / 1000.0;
            assert!((q.dequantize(q.quantize(x)) - x).abs() <= q.step() / 2.0 + 1e-6);
        }
        assert_eq!(q.quantize(-10.0), 0);
        assert_eq!(q.quantize(10.0), 255);
        let r = q.residual(4.0);
        assert!((r.step() - q.step() * 8.0 / 255.0).abs() < 1e-9);
        assert!(Quantizer::new(1.0, 1.0).is_valid());
    }
}
