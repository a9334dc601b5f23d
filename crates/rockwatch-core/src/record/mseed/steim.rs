//! Steim-1 and Steim-2 compression (SEED manual, appendix B): 64-byte frames of a control
//! word and 15 data words, each packing first differences of the integer samples; frame 0
//! carries the forward (X0) and reverse (Xn) integration constants. Decoding (both versions,
//! either byte order) for the reader, Steim-2 encoding (big-endian) for the writer.

/// Steim frame size (bytes).
const FRAME_BYTES: usize = 64;

/// Which Steim compression a record uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Steim {
    One,
    Two,
}

/// Sign-extends the low `bits` bits of `v`.
fn sign_extend(v: u32, bits: u32) -> i32 {
    let shift = 32 - bits;
    ((v << shift) as i32) >> shift
}

/// Decodes Steim-1 or Steim-2 frames (64 bytes each) into `n` samples. Frame 0 holds the
/// forward (X0, first sample) and reverse (Xn, last sample) integration constants; the
/// record's first difference refers to the previous record and is not used. Both the
/// sample count and Xn are checked.
pub(super) fn decode_steim(
    data: &[u8],
    big_endian: bool,
    version: Steim,
    n: usize,
) -> Result<Vec<f64>, String> {
    let name = match version {
        Steim::One => "Steim-1",
        Steim::Two => "Steim-2",
    };
    let frames = data.len() / FRAME_BYTES;
    let max_per_frame = match version {
        Steim::One => 15 * 4,
        Steim::Two => 15 * 7,
    };
    if frames == 0 {
        return Err(format!(
            "{name}: data section of {} bytes holds no 64-byte frame",
            data.len()
        ));
    }
    if n > frames * max_per_frame {
        return Err(format!(
            "{name}: header says {n} samples, but {frames} frames hold at most {}",
            frames * max_per_frame
        ));
    }
    let word_bytes = |i: usize| -> [u8; 4] {
        data.get(4 * i..4 * i + 4)
            .and_then(|w| w.try_into().ok())
            .unwrap_or([0; 4])
    };
    let word = |i: usize| {
        let b = word_bytes(i);
        if big_endian {
            u32::from_be_bytes(b)
        } else {
            u32::from_le_bytes(b)
        }
    };
    let x0 = word(1) as i32;
    let xn = word(2) as i32;
    let mut out: Vec<f64> = Vec::with_capacity(n);
    let mut last = x0;
    let mut first_difference = true;
    // Differences of one word; at most 7 (Steim-2, code 3, sub-code 2).
    let mut differences = [0i32; 7];
    'frames: for frame in 0..frames {
        let control = word(frame * 16);
        let first_word = if frame == 0 { 3 } else { 1 };
        for w in first_word..16 {
            let nibble = (control >> (30 - 2 * w)) & 3;
            let raw = word_bytes(frame * 16 + w);
            let value = word(frame * 16 + w);
            // Byte-wide differences are stored in memory order and Steim-1 16-bit ones as
            // two values in the data byte order (libmseed's reading of little-endian Steim);
            // everything else is a bit field of the whole 32-bit word.
            let count = match (version, nibble) {
                (_, 0) => continue,
                (_, 1) => {
                    for (d, &b) in differences.iter_mut().zip(&raw) {
                        *d = i32::from(b as i8);
                    }
                    4
                }
                (Steim::One, 2) => {
                    for (k, d) in differences.iter_mut().take(2).enumerate() {
                        let pair = [raw[2 * k], raw[2 * k + 1]];
                        *d = i32::from(if big_endian {
                            i16::from_be_bytes(pair)
                        } else {
                            i16::from_le_bytes(pair)
                        });
                    }
                    2
                }
                (Steim::One, _) => {
                    differences[0] = value as i32;
                    1
                }
                (Steim::Two, _) => {
                    // (count, bits per difference) of the packed differences.
                    let (count, bits) = match (nibble, value >> 30) {
                        (2, 1) => (1, 30),
                        (2, 2) => (2, 15),
                        (2, 3) => (3, 10),
                        (3, 0) => (5, 6),
                        (3, 1) => (6, 5),
                        (3, 2) => (7, 4),
                        (code, sub) => {
                            return Err(format!(
                                "{name}: invalid sub-code {sub} for code {code} in frame {frame}, word {w}"
                            ))
                        }
                    };
                    let mask = (1u32 << bits) - 1;
                    for (k, d) in differences.iter_mut().take(count).enumerate() {
                        let shift = bits * (count - 1 - k) as u32;
                        *d = sign_extend((value >> shift) & mask, bits);
                    }
                    count
                }
            };
            for &difference in &differences[..count] {
                if first_difference {
                    first_difference = false;
                    out.push(f64::from(x0));
                } else {
                    last = last
                        .checked_add(difference)
                        .ok_or_else(|| format!("{name}: sample {} overflows 32 bits", out.len()))?;
                    out.push(f64::from(last));
                }
                if out.len() == n {
                    break 'frames;
                }
            }
        }
    }
    if out.len() != n {
        return Err(format!(
            "{name}: only decoded {} of the {n} samples the header announces",
            out.len()
        ));
    }
    if last != xn {
        return Err(format!(
            "{name} integrity check failed: last decoded sample {last} differs from the \
             reverse integration constant {xn} (corrupt data or wrong byte order)"
        ));
    }
    Ok(out)
}

/// Whether `value` fits a signed field of `bits` bits.
pub(super) fn fits(value: i64, bits: u32) -> bool {
    let half = 1i64 << (bits - 1);
    (-half..half).contains(&value)
}

/// Steim-2 packings of one 32-bit word, densest first: (differences, bits each, 2-bit
/// code in the control word, 2-bit sub-code "dnib" at the top of the word; none for code 1).
const STEIM2_PACKINGS: [(usize, u32, u32, Option<u32>); 7] = [
    (7, 4, 3, Some(2)),
    (6, 5, 3, Some(1)),
    (5, 6, 3, Some(0)),
    (4, 8, 1, None),
    (3, 10, 2, Some(3)),
    (2, 15, 2, Some(2)),
    (1, 30, 2, Some(1)),
];

/// Encodes as many of `samples` as fit into the Steim-2 frames of `data` (big-endian; the
/// section length is a multiple of 64). `previous` is the channel's sample before
/// `samples[0]` (the first difference refers to it; 0 for the first record). Returns the
/// number of samples and of frames used. Differences must fit 30 bits (checked before).
/// Greedy: each word takes the densest packing that the next differences fit.
pub(super) fn encode_steim2(
    samples: &[i32],
    previous: Option<i32>,
    data: &mut [u8],
) -> (usize, usize) {
    let difference = |j: usize| -> i64 {
        match (j, previous) {
            (0, None) => 0,
            (0, Some(p)) => i64::from(samples[0]) - i64::from(p),
            (j, _) => i64::from(samples[j]) - i64::from(samples[j - 1]),
        }
    };
    let frames = data.len() / FRAME_BYTES;
    let mut next = 0usize; // next sample (difference) to pack
    let mut frames_used = 0usize;
    for frame in 0..frames {
        if next == samples.len() {
            break;
        }
        let base = frame * FRAME_BYTES;
        let mut control = 0u32;
        let first_word = if frame == 0 { 3 } else { 1 };
        for w in first_word..16 {
            if next == samples.len() {
                break;
            }
            let remaining = samples.len() - next;
            let Some(&(count, bits, nibble, dnib)) =
                STEIM2_PACKINGS.iter().find(|(count, bits, _, _)| {
                    *count <= remaining && (next..next + count).all(|j| fits(difference(j), *bits))
                })
            else {
                // Unreachable when differences fit 30 bits (checked in `prepare`).
                break;
            };
            let word = match dnib {
                None => {
                    let mut bytes = [0u8; 4];
                    for (k, b) in bytes.iter_mut().enumerate() {
                        *b = difference(next + k) as i8 as u8;
                    }
                    u32::from_be_bytes(bytes)
                }
                Some(dnib) => {
                    let mask = (1u32 << bits) - 1;
                    let mut word = dnib << 30;
                    for k in 0..count {
                        let shift = bits * (count - 1 - k) as u32;
                        word |= ((difference(next + k) as i32 as u32) & mask) << shift;
                    }
                    word
                }
            };
            data[base + 4 * w..base + 4 * w + 4].copy_from_slice(&word.to_be_bytes());
            control |= nibble << (30 - 2 * w);
            next += count;
        }
        data[base..base + 4].copy_from_slice(&control.to_be_bytes());
        frames_used = frame + 1;
    }
    if next > 0 {
        // Forward (X0) and reverse (Xn) integration constants in frame 0, words 1 and 2.
        data[4..8].copy_from_slice(&samples[0].to_be_bytes());
        data[8..12].copy_from_slice(&samples[next - 1].to_be_bytes());
    }
    (next, frames_used)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Builds big-endian Steim frames by hand: control word, then data words.
    fn frame(control: u32, words: &[u32]) -> Vec<u8> {
        let mut f = control.to_be_bytes().to_vec();
        for w in words {
            f.extend_from_slice(&w.to_be_bytes());
        }
        f.resize(64, 0);
        f
    }

    #[test]
    fn steim1_hand_built_frame_decodes() {
        // Samples 10, 11, 9, 9, 1009: differences (·), 1, −2, 0, 1000.
        // Word 3: four 8-bit differences (0, 1, −2, 0), code 1; word 4: one 32-bit (1000), code 3.
        let control = (1 << (30 - 2 * 3)) | (3 << (30 - 2 * 4));
        let words = [10, 1009, 0x0001_FE00, 1000];
        let data = frame(control, &words);
        let got = decode_steim(&data, true, Steim::One, 5).unwrap();
        assert_eq!(got, vec![10.0, 11.0, 9.0, 9.0, 1009.0]);
    }

    #[test]
    fn steim2_seven_four_bit_differences_decode() {
        // Code 3, sub-code 2: seven 4-bit differences 0, 1, 2, 3, −1, −2, −8.
        let diffs: [i32; 7] = [0, 1, 2, 3, -1, -2, -8];
        let mut word = 2u32 << 30;
        for (k, d) in diffs.iter().enumerate() {
            word |= ((*d as u32) & 0xF) << (4 * (6 - k));
        }
        let mut expected = vec![100.0];
        let mut x = 100;
        for d in &diffs[1..] {
            x += d;
            expected.push(f64::from(x));
        }
        let control = 3 << (30 - 2 * 3);
        let data = frame(control, &[100, x as u32, word]);
        assert_eq!(decode_steim(&data, true, Steim::Two, 7).unwrap(), expected);
    }

    #[test]
    fn steim_wrong_reverse_constant_is_an_error() {
        let control = 1 << (30 - 2 * 3);
        let data = frame(control, &[10, 99, 0x0001_0101]);
        let err = decode_steim(&data, true, Steim::One, 4).unwrap_err();
        assert!(err.contains("integrity check"), "{err}");
    }

    #[test]
    fn steim_too_few_differences_is_an_error() {
        let control = 1 << (30 - 2 * 3);
        let data = frame(control, &[10, 12, 0x0001_0100]);
        let err = decode_steim(&data, true, Steim::One, 9).unwrap_err();
        assert!(err.contains("only decoded 4"), "{err}");
    }
}
