//! The vertex residual's step for a size (format v18): a file shrinks as
//! the step grows, about a bit a value per halving, so the step is searched
//! as a QP is for a bitrate: secant steps on log(size) against log(step)
//! inside a shrinking bracket. `cgv eval`'s `skinned-residual` entry and a
//! `--kbps` budget's residual try use it.

use crate::error::Result;

/// The residual's range searched, percent of the diagonal.
pub const FINEST: f64 = 0.001;
pub const COARSEST: f64 = 5.0;
/// Encodes at most.
pub const TRIES: usize = 10;

/// A try's log(step) and log(size).
type LogPoint = (f64, f64);

/// Calls `size_of(percent)` with steps that close in on a file of `target`
/// bytes, until one lands within `tol` of it (a fraction) or [`TRIES`]
/// calls; the caller keeps whichever try it likes best. Returns the calls.
pub fn search_step(target: usize, tol: f64, size_of: &mut dyn FnMut(f64) -> Result<usize>) -> Result<usize> {
    // (log step, log size) of the coarsest step whose file is still too
    // large and the finest whose file is too small.
    let (mut lo, mut hi): (Option<LogPoint>, Option<LogPoint>) = (None, None);
    let goal = (target.max(1) as f64).ln();
    let mut p = 0.1f64;
    for tries in 1..=TRIES {
        let size = size_of(p)?;
        if (size as f64 / target.max(1) as f64 - 1.0).abs() <= tol {
            return Ok(tries);
        }
        let (x, y) = (p.ln(), (size.max(1) as f64).ln());
        if size > target {
            lo = Some((x, y));
        } else {
            hi = Some((x, y));
        }
        let next = match (lo, hi) {
            // Between the bracket's ends, on the line through them.
            (Some(l), Some(h)) if (h.0 - l.0).abs() > 1e-3 => l.0 + (goal - l.1) * (h.0 - l.0) / (h.1 - l.1),
            (Some(_), Some(_)) => return Ok(tries),
            // Outward: bits fall about one per halving of the step.
            (Some(_), None) => x + (y - goal).max(0.35) * 2.0,
            (None, _) => x - (goal - y).max(0.35) * 2.0,
        };
        p = next.exp().clamp(FINEST, COARSEST);
        if (p.ln() - x).abs() < 1e-3 {
            return Ok(tries);
        }
    }
    Ok(TRIES)
}

#[cfg(test)]
mod tests {
    use super::search_step;

    #[test]
    fn the_step_for_a_size_is_found_in_a_few_tries() {
        // A residual that costs 6 bits a value at 0.01 % and one less a
        // halving, over 30,000 values, and a fixed 5 KB.
        let size = |p: f64| 5000 + (30_000.0 * (6.0 - (p / 0.01).log2()).max(0.1) / 8.0) as usize;
        for target in [12_000, 20_000, 30_000] {
            let mut seen = Vec::new();
            let tries = search_step(target, 0.05, &mut |p| {
                seen.push(size(p));
                Ok(size(p))
            })
            .unwrap();
            let last = *seen.last().unwrap();
            assert!((last as f64 / target as f64 - 1.0).abs() <= 0.05, "{target}: {seen:?}");
            assert!(tries <= 6, "{target}: {tries} tries");
        }
    }
}
