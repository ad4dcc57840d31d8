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
    let what = match rng.below(10) {
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
        8 | 9 => return (hostile(text, rng), "replaced a token with a hostile one"),
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

/// What the campaign of [13/14] found wrong output or crashes with, each once: a token of
/// `text` replaced by one of them, or one appended to a token (`x` becomes `x/0`).
const HOSTILE: [&str; 16] = [
    "/0",
    "/(t-t)",
    "*0/0",
    "log(0)",
    "sqrt(-1)",
    "exp(1000)",
    "1e308*10",
    "0^-1",
    "der(sin(t)*cos(t)*exp(t)*tanh(t)*atan(t)*log(t+2)*sqrt(t+1)*abs(t), 16)",
    "der(t, 17)",
    "*sign(t)",
    "*abs(t)",
    "((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((1))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))))",
    "1e-320",
    "-0",
    "\u{feff}",
];

/// `text` with one token replaced by, or followed by, a hostile piece; or one name made
/// 70,000 characters long (past the 65,535 columns a formatter once panicked at).
fn hostile(text: &[u8], rng: &mut Rng) -> Vec<u8> {
    let starts: Vec<usize> = (0..text.len())
        .filter(|&i| {
            !text[i].is_ascii_whitespace() && (i == 0 || text[i - 1].is_ascii_whitespace())
        })
        .collect();
    if starts.is_empty() {
        return text.to_vec();
    }
    let at = starts[rng.below(starts.len())];
    let end = (at..text.len())
        .find(|&i| text[i].is_ascii_whitespace())
        .unwrap_or(text.len());
    let piece: Vec<u8> = match rng.below(HOSTILE.len() + 1) {
        k if k == HOSTILE.len() => {
            let mut long = text[at..end].to_vec();
            long.extend(std::iter::repeat_n(b'x', 70_000));
            long
        }
        k if rng.below(2) == 0 => HOSTILE[k].as_bytes().to_vec(),
        k => [&text[at..end], HOSTILE[k].as_bytes()].concat(),
    };
    [&text[..at], &piece[..], &text[end..]].concat()
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
