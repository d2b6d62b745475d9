//! LEB128 numbers (7 bits a byte, low first, the high bit set on all but
//! the last): the access-unit lengths of frame chunks and the source
//! mesh's face indices.

/// Appends `n`.
pub fn write(out: &mut Vec<u8>, mut n: u64) {
    loop {
        let byte = (n & 0x7f) as u8;
        n >>= 7;
        out.push(if n > 0 { byte | 0x80 } else { byte });
        if n == 0 {
            return;
        }
    }
}

/// Reads a number of at most `max_bytes` bytes at `b[*at..]`, advancing
/// `at`; `None` if it is cut short or longer.
pub fn read(b: &[u8], at: &mut usize, max_bytes: usize) -> Option<u64> {
    let mut n = 0u64;
    for k in 0..max_bytes.min(9) {
        let byte = *b.get(*at)?;
        *at += 1;
        n |= ((byte & 0x7f) as u64) << (7 * k);
        if byte & 0x80 == 0 {
            return Some(n);
        }
    }
    None
}
