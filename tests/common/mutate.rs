//! Random mutations of a text input: deleted, duplicated and swapped lines, swapped tokens,
//! truncation, random bytes. A fixed-seed SplitMix64 picks them, so a failure reproduces.

/// SplitMix64: small, fast, good enough to pick mutations.
pub(crate) struct Rng(pub u64);

impl Rng {
    /// The next 64 random bits.
    pub(crate) fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// A number in `0..n` (0 when `n` is 0).
    pub(crate) fn below(&mut self, n: usize) -> usize {
        if n == 0 {
            0
        } else {
            (self.next() % n as u64) as usize
        }
    }
}

/// One random mutation of `text`, and what it was.
pub(crate) fn mutate(text: &[u8], rng: &mut Rng) -> (Vec<u8>, &'static str) {
    let lines: Vec<&[u8]> = text.split_inclusive(|&b| b == b'\n').collect();
    let mut lines: Vec<Vec<u8>> = lines.into_iter().map(<[u8]>::to_vec).collect();
    let what = match rng.below(8) {
        0 => {
            lines.remove(rng.below(lines.len()));
            "deleted a line"
        }
        1 => {
            let i = rng.below(lines.len());
            let line = lines[i].clone();
            lines.insert(rng.below(lines.len() + 1), line);
            "duplicated a line"
        }
        2 => {
            let (i, j) = (rng.below(lines.len()), rng.below(lines.len()));
            lines.swap(i, j);
            "swapped two lines"
        }
        3 => return (swap_tokens(text, rng), "swapped two tokens"),
        4 => return (text[..rng.below(text.len() + 1)].to_vec(), "truncated"),
        5 => {
            let mut out = text.to_vec();
            for _ in 0..=rng.below(4) {
                let at = rng.below(out.len());
                out[at] = rng.next() as u8;
            }
            return (out, "replaced bytes with random ones");
        }
        6 => {
            let mut out = text.to_vec();
            let at = rng.below(out.len() + 1);
            let noise: Vec<u8> = (0..=rng.below(16)).map(|_| rng.next() as u8).collect();
            out.splice(at..at, noise);
            return (out, "inserted random bytes");
        }
        _ => {
            // A printable character from the language's alphabet, where it may not belong.
            let alphabet = b"()[]{}=:,->< 01#\"\n*^/+.e_xyzRCI";
            let mut out = text.to_vec();
            let at = rng.below(out.len());
            out[at] = alphabet[rng.below(alphabet.len())];
            return (out, "replaced a byte with a token character");
        }
    };
    (lines.concat(), what)
}

fn swap_tokens(text: &[u8], rng: &mut Rng) -> Vec<u8> {
    let tokens: Vec<&[u8]> = text
        .split(|b| b.is_ascii_whitespace())
        .filter(|t| !t.is_empty())
        .collect();
    let (i, j) = (rng.below(tokens.len()), rng.below(tokens.len()));
    let mut swapped = tokens.clone();
    swapped.swap(i, j);
    // Keep line structure: rebuild with the original separators.
    let mut out = Vec::with_capacity(text.len());
    let mut k = 0;
    let mut in_token = false;
    for &b in text {
        if b.is_ascii_whitespace() {
            in_token = false;
            out.push(b);
        } else if !in_token {
            in_token = true;
            out.extend_from_slice(swapped[k]);
            k += 1;
        }
    }
    out
}
