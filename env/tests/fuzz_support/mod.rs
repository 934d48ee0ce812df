//! Shared input generators of the fuzz targets (`*/tests/fuzz*.rs`):
//! structure-aware mutations of valid inputs, random text and bytes, and the
//! case count. Included by path from the other crates' fuzz targets.
//!
//! Random bytes alone rarely get past a parser's first line, so most cases
//! start from a real input (a shipped map, config or encoded message) and
//! apply a few mutations that keep it close to valid: a number replaced by a
//! boundary value, a line duplicated, dropped or swapped, a token inserted, a
//! byte flipped, the text cut short.

#![allow(dead_code)]

use proptest::prelude::*;

/// Cases per target: `BURIDAN_FUZZ_CASES`, else a small count that keeps
/// The shipped TOML files that contain `section` (`"[study]"`,
/// `"[experiment]"`), with their paths, sorted: every file of
/// `learner/studies/` and each kept result's `docs/results/*/kept`.
pub fn shipped_tomls(kept: &str, section: &str) -> Vec<(std::path::PathBuf, String)> {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut paths: Vec<_> = std::fs::read_dir(root.join("learner/studies"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    for d in std::fs::read_dir(root.join("docs/results")).unwrap() {
        paths.push(d.unwrap().path().join(kept));
    }
    paths.sort();
    paths
        .into_iter()
        .filter(|p| p.extension().is_some_and(|x| x == "toml") && p.is_file())
        .filter_map(|p| {
            let text = std::fs::read_to_string(&p).unwrap();
            text.contains(section).then_some((p, text))
        })
        .collect()
}

/// the CI run of all targets well under a minute.
pub fn cases() -> u32 {
    std::env::var("BURIDAN_FUZZ_CASES")
        .ok()
        .and_then(|v| v.trim().replace('_', "").parse().ok())
        .unwrap_or(256)
}

/// The proptest settings of every fuzz target: [`cases`], no regression
/// files (minimal inputs become named regression tests instead), and no
/// limit on local rejects.
pub fn config() -> ProptestConfig {
    ProptestConfig {
        cases: cases(),
        failure_persistence: None,
        max_shrink_iters: 4096,
        ..ProptestConfig::default()
    }
}

/// Values at the edges of the integer and float types, and words parsers
/// give meaning to.
pub const NUMBERS: &[&str] = &[
    "0",
    "1",
    "-1",
    "2",
    "-0",
    "0.0",
    "-0.0",
    "255",
    "256",
    "65535",
    "65536",
    "16777216",
    "2147483647",
    "2147483648",
    "4294967295",
    "4294967296",
    "9223372036854775807",
    "9223372036854775808",
    "-9223372036854775808",
    "18446744073709551615",
    "18446744073709551616",
    "99999999999999999999999999",
    "1e308",
    "1e309",
    "-1e308",
    "1e-320",
    "1e30",
    "nan",
    "inf",
    "-inf",
    "+inf",
    "0.5",
    "1.5h",
    "1e3",
    "0x10",
    "1_000",
];

/// One edit of a text or byte buffer. Positions are taken modulo the
/// buffer's length (or its number of lines or numbers) when applied.
#[derive(Debug, Clone)]
pub enum Mutation {
    /// Insert a byte.
    InsertByte(usize, u8),
    /// Overwrite a byte.
    SetByte(usize, u8),
    /// Flip one bit of a byte.
    FlipBit(usize, u8),
    /// Delete up to `n` bytes.
    Delete(usize, usize),
    /// Insert a token (a number or a word of the format).
    InsertToken(usize, String),
    /// Replace the k-th number in the text by a token.
    ReplaceNumber(usize, String),
    /// Repeat a line.
    DuplicateLine(usize),
    /// Remove a line.
    DeleteLine(usize),
    /// Swap two lines.
    SwapLines(usize, usize),
    /// Copy a range of bytes to another position.
    Splice(usize, usize, usize),
    /// Cut the buffer short.
    Truncate(usize),
}

/// A mutation drawing tokens from `NUMBERS` and `words`.
pub fn mutation(words: &'static [&'static str]) -> impl Strategy<Value = Mutation> {
    let token = prop_oneof![
        prop::sample::select(NUMBERS).prop_map(str::to_string),
        prop::sample::select(words).prop_map(str::to_string),
        any::<u64>().prop_map(|n| n.to_string()),
        any::<i64>().prop_map(|n| n.to_string()),
        any::<f64>().prop_map(|x| x.to_string()),
    ];
    let pos = any::<usize>();
    prop_oneof![
        1 => (pos, any::<u8>()).prop_map(|(p, b)| Mutation::InsertByte(p, b)),
        1 => (pos, any::<u8>()).prop_map(|(p, b)| Mutation::SetByte(p, b)),
        1 => (pos, 0u8..8).prop_map(|(p, b)| Mutation::FlipBit(p, b)),
        1 => (pos, 1usize..16).prop_map(|(p, n)| Mutation::Delete(p, n)),
        3 => (pos, token.clone()).prop_map(|(p, t)| Mutation::InsertToken(p, t)),
        4 => (pos, token).prop_map(|(p, t)| Mutation::ReplaceNumber(p, t)),
        1 => pos.prop_map(Mutation::DuplicateLine),
        1 => pos.prop_map(Mutation::DeleteLine),
        1 => (pos, pos).prop_map(|(a, b)| Mutation::SwapLines(a, b)),
        1 => (pos, 1usize..64, pos).prop_map(|(a, n, b)| Mutation::Splice(a, n, b)),
        1 => pos.prop_map(Mutation::Truncate),
    ]
}

/// Byte ranges of the numbers (digits with an optional sign, point and
/// exponent) in `buf`.
fn numbers(buf: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < buf.len() {
        if buf[i].is_ascii_digit() {
            let mut start = i;
            if start > 0 && buf[start - 1] == b'-' {
                start -= 1;
            }
            while i < buf.len()
                && (buf[i].is_ascii_digit() || matches!(buf[i], b'.' | b'e' | b'E' | b'_'))
            {
                i += 1;
            }
            out.push((start, i));
        } else {
            i += 1;
        }
    }
    out
}

/// Byte ranges of the lines of `buf`, each with its newline.
fn lines(buf: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut start = 0;
    for (i, &b) in buf.iter().enumerate() {
        if b == b'\n' {
            out.push((start, i + 1));
            start = i + 1;
        }
    }
    if start < buf.len() {
        out.push((start, buf.len()));
    }
    out
}

/// Applies `m` to `buf`.
pub fn apply(buf: &mut Vec<u8>, m: &Mutation) {
    let at = |p: usize, len: usize| if len == 0 { 0 } else { p % (len + 1) };
    match m {
        Mutation::InsertByte(p, b) => {
            let p = at(*p, buf.len());
            buf.insert(p, *b);
        }
        Mutation::SetByte(p, b) => {
            if !buf.is_empty() {
                let p = p % buf.len();
                buf[p] = *b;
            }
        }
        Mutation::FlipBit(p, bit) => {
            if !buf.is_empty() {
                let p = p % buf.len();
                buf[p] ^= 1 << bit;
            }
        }
        Mutation::Delete(p, n) => {
            let p = at(*p, buf.len());
            let end = (p + n).min(buf.len());
            buf.drain(p..end);
        }
        Mutation::InsertToken(p, t) => {
            let p = at(*p, buf.len());
            buf.splice(p..p, t.bytes());
        }
        Mutation::ReplaceNumber(k, t) => {
            let nums = numbers(buf);
            if !nums.is_empty() {
                let (a, b) = nums[k % nums.len()];
                buf.splice(a..b, t.bytes());
            }
        }
        Mutation::DuplicateLine(k) => {
            let ls = lines(buf);
            if !ls.is_empty() {
                let (a, b) = ls[k % ls.len()];
                let line = buf[a..b].to_vec();
                buf.splice(b..b, line);
            }
        }
        Mutation::DeleteLine(k) => {
            let ls = lines(buf);
            if !ls.is_empty() {
                let (a, b) = ls[k % ls.len()];
                buf.drain(a..b);
            }
        }
        Mutation::SwapLines(i, j) => {
            let ls = lines(buf);
            if ls.len() > 1 {
                let (mut x, mut y) = (ls[i % ls.len()], ls[j % ls.len()]);
                if x.0 > y.0 {
                    std::mem::swap(&mut x, &mut y);
                }
                if x != y {
                    let first = buf[x.0..x.1].to_vec();
                    let second = buf[y.0..y.1].to_vec();
                    buf.splice(y.0..y.1, first);
                    buf.splice(x.0..x.1, second);
                }
            }
        }
        Mutation::Splice(a, n, b) => {
            if !buf.is_empty() {
                let a = a % buf.len();
                let end = (a + n).min(buf.len());
                let piece = buf[a..end].to_vec();
                let b = at(*b, buf.len());
                buf.splice(b..b, piece);
            }
        }
        Mutation::Truncate(p) => {
            let p = at(*p, buf.len());
            buf.truncate(p);
        }
    }
}

/// `seed` with `mutations` applied.
pub fn mutate(seed: &[u8], mutations: &[Mutation]) -> Vec<u8> {
    let mut buf = seed.to_vec();
    for m in mutations {
        apply(&mut buf, m);
    }
    buf
}

/// One of `seeds`, mutated 0–7 times, as bytes.
pub fn mutated_bytes(
    seeds: Vec<Vec<u8>>,
    words: &'static [&'static str],
) -> impl Strategy<Value = Vec<u8>> {
    assert!(!seeds.is_empty(), "no seed inputs");
    (
        prop::sample::select(seeds),
        prop::collection::vec(mutation(words), 0..8),
    )
        .prop_map(|(seed, ms)| mutate(&seed, &ms))
}

/// One of `seeds`, mutated 0–7 times, as text (invalid UTF-8 replaced).
pub fn mutated_text(
    seeds: Vec<String>,
    words: &'static [&'static str],
) -> impl Strategy<Value = String> {
    mutated_bytes(seeds.into_iter().map(String::into_bytes).collect(), words)
        .prop_map(|b| String::from_utf8_lossy(&b).into_owned())
}

/// Arbitrary text: any Unicode, or printable ASCII with line breaks, or
/// arbitrary bytes read as UTF-8 lossily.
pub fn random_text() -> impl Strategy<Value = String> {
    prop_oneof![
        any::<String>(),
        "[ -~\t\r\n]{0,200}",
        prop::collection::vec(any::<u8>(), 0..256)
            .prop_map(|b| String::from_utf8_lossy(&b).into_owned()),
    ]
}

/// Runs one fuzz target: `check` on [`cases`] inputs drawn from
/// `strategy`, returning whether the parser accepted the input. Panics
/// with the smallest failing input found; prints the target's name, its
/// case count, how many inputs were accepted and the wall time.
pub fn run<S>(name: &str, strategy: S, check: impl Fn(S::Value) -> Result<bool, TestCaseError>)
where
    S: Strategy,
    S::Value: std::fmt::Debug,
{
    use std::sync::atomic::{AtomicU64, Ordering::Relaxed};
    let (inputs, accepted) = (AtomicU64::new(0), AtomicU64::new(0));
    let start = std::time::Instant::now();
    // Failing inputs panic again and again while proptest shrinks them:
    // keep the log to the one report below.
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let mut runner = proptest::test_runner::TestRunner::new(config());
    let result = runner.run(&strategy, |input| {
        inputs.fetch_add(1, Relaxed);
        if check(input)? {
            accepted.fetch_add(1, Relaxed);
        }
        Ok(())
    });
    std::panic::set_hook(hook);
    if let Err(e) = result {
        panic!("fuzz target {name} failed: {e}");
    }
    let n = inputs.load(Relaxed);
    eprintln!(
        "fuzz target {name}: {n} inputs, {} accepted ({:.1} %), {:.1} s",
        accepted.load(Relaxed),
        100.0 * accepted.load(Relaxed) as f64 / n.max(1) as f64,
        start.elapsed().as_secs_f64()
    );
}
