//! Orderings vs the paper: which pairs of entries the run resolves (paired standard errors over
//! seeds × objects), and whether each agrees with the paper's tables.

use std::collections::BTreeMap;
use std::fmt::Write as _;

/// The smallest difference of mean IoUs read as an ordering (half a point of IoU): below it a
/// pair is within noise however consistent the per-object differences are (nearly identical
/// models give tiny, consistent differences).
pub const MIN_RESOLVED_DIFF: f32 = 0.005;

/// One row of the comparison: our mean IoU, the paper's, and our per-object IoUs (keyed by
/// `category/id`, for the paired noise estimate).
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    pub name: String,
    pub ours: f32,
    pub paper: f32,
    pub per_object: BTreeMap<String, f32>,
}

/// How one pair's order compares.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Same order as the paper, and our difference exceeds 2 SE and [`MIN_RESOLVED_DIFF`].
    Agrees,
    /// Opposite order, and our difference exceeds 2 SE and [`MIN_RESOLVED_DIFF`].
    Disagrees,
    /// Our difference is within 2 SE or below [`MIN_RESOLVED_DIFF`] (or the SE cannot be
    /// estimated): within noise. `sign_agrees`: the
    /// sign of our difference matches the paper's order anyway.
    Unresolved { sign_agrees: bool },
    /// The paper gives both the same number.
    PaperTie,
}

/// One pair of rows (`a < b`, indices into the rows).
#[derive(Clone, Debug, PartialEq)]
pub struct Pair {
    pub a: usize,
    pub b: usize,
    /// Our `ours[a] − ours[b]`.
    pub diff: f32,
    /// Standard error of the paired per-object differences; `None` with fewer than 2 shared
    /// objects.
    pub se: Option<f32>,
    pub verdict: Verdict,
}

/// Rankings and pairwise verdicts of rows.
#[derive(Clone, Debug, PartialEq)]
pub struct Comparison {
    pub pairs: Vec<Pair>,
    /// Rank of each row by our IoU (1 = best; equal values share a rank).
    pub ours_rank: Vec<usize>,
    /// Rank of each row by the paper's IoU.
    pub paper_rank: Vec<usize>,
}

pub(super) fn ranks(v: &[f32]) -> Vec<usize> {
    v.iter()
        .map(|x| 1 + v.iter().filter(|y| *y > x).count())
        .collect()
}

/// The paired standard error of `a − b` over the objects both have.
pub(super) fn paired_se(a: &BTreeMap<String, f32>, b: &BTreeMap<String, f32>) -> Option<f32> {
    let d: Vec<f64> = a
        .iter()
        .filter_map(|(k, x)| b.get(k).map(|y| (*x - *y) as f64))
        .collect();
    let n = d.len();
    if n < 2 {
        return None;
    }
    let mean = d.iter().sum::<f64>() / n as f64;
    let var = d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
    Some((var / n as f64).sqrt() as f32)
}

/// The mean of the paired differences `a − b` over the keys both maps have, and its standard
/// error; `None` with fewer than 2 shared keys.
pub fn paired_difference(
    a: &BTreeMap<String, f32>,
    b: &BTreeMap<String, f32>,
) -> Option<(f32, f32)> {
    let d: Vec<f32> = a
        .iter()
        .filter_map(|(k, x)| b.get(k).map(|y| x - y))
        .collect();
    let se = paired_se(a, b)?;
    Some((d.iter().sum::<f32>() / d.len() as f32, se))
}

/// Compares our ordering of `rows` with the paper's (the rule is in the module docs).
pub fn compare(rows: &[Row]) -> Comparison {
    let mut pairs = Vec::new();
    for a in 0..rows.len() {
        for b in a + 1..rows.len() {
            let (ra, rb) = (&rows[a], &rows[b]);
            let diff = ra.ours - rb.ours;
            let se = paired_se(&ra.per_object, &rb.per_object);
            let paper = ra.paper - rb.paper;
            let verdict = if paper == 0.0 {
                Verdict::PaperTie
            } else {
                let sign_agrees = diff != 0.0 && (diff > 0.0) == (paper > 0.0);
                let resolved =
                    diff.abs() >= MIN_RESOLVED_DIFF && se.is_some_and(|se| diff.abs() > 2.0 * se);
                match (resolved, sign_agrees) {
                    (true, true) => Verdict::Agrees,
                    (true, false) => Verdict::Disagrees,
                    (false, s) => Verdict::Unresolved { sign_agrees: s },
                }
            };
            pairs.push(Pair {
                a,
                b,
                diff,
                se,
                verdict,
            });
        }
    }
    Comparison {
        pairs,
        ours_rank: ranks(&rows.iter().map(|r| r.ours).collect::<Vec<_>>()),
        paper_rank: ranks(&rows.iter().map(|r| r.paper).collect::<Vec<_>>()),
    }
}

/// Counts of verdicts: `(agree, disagree, unresolved, unresolved with the paper's sign, ties)`.
pub fn tally<'a>(pairs: impl Iterator<Item = &'a Pair>) -> (usize, usize, usize, usize, usize) {
    let mut t = (0, 0, 0, 0, 0);
    for p in pairs {
        match p.verdict {
            Verdict::Agrees => t.0 += 1,
            Verdict::Disagrees => t.1 += 1,
            Verdict::Unresolved { sign_agrees } => {
                t.2 += 1;
                t.3 += sign_agrees as usize;
            }
            Verdict::PaperTie => t.4 += 1,
        }
    }
    t
}

/// A one-paragraph verdict on the whole ordering.
pub fn summary(rows: &[Row], c: &Comparison) -> String {
    if rows.len() < 2 {
        return "Fewer than two finished variants with the paper's numbers: nothing to compare yet."
            .into();
    }
    let (agree, disagree, unresolved, same_sign, ties) = tally(c.pairs.iter());
    let counted = agree + disagree + unresolved;
    let overall = if disagree > 0 {
        format!(
            "**Our ordering disagrees with the paper's** on {disagree} of {counted} pair(s) beyond noise"
        )
    } else if unresolved > 0 {
        format!(
            "**No resolved pair contradicts the paper's ordering, but {unresolved} of {counted} pair(s) are within noise**, so our runs do not confirm it"
        )
    } else {
        format!(
            "**Our ordering agrees with the paper's** on all {counted} pair(s), each beyond noise"
        )
    };
    let best = |ranks: &[usize]| -> Vec<&str> {
        rows.iter()
            .zip(ranks)
            .filter(|(_, r)| **r == 1)
            .map(|(r, _)| r.name.as_str())
            .collect()
    };
    let (ob, pb) = (best(&c.ours_rank), best(&c.paper_rank));
    let best_match = if ob == pb {
        "matches"
    } else {
        "does not match"
    };
    let mut s = format!(
        "{overall}: {agree} agree, {disagree} disagree, {unresolved} within noise ({same_sign} of them with the paper's sign)"
    );
    if ties > 0 {
        let _ = write!(s, ", {ties} tied in the paper (not counted)");
    }
    let _ = write!(
        s,
        ". Our best: {}; the paper's best: {} — {best_match}.",
        ob.join(", "),
        pb.join(", ")
    );
    s
}

/// How a report words a verdict (Markdown).
pub fn verdict_text(v: Verdict) -> &'static str {
    match v {
        Verdict::Agrees => "agrees",
        Verdict::Disagrees => "**disagrees**",
        Verdict::Unresolved { sign_agrees: true } => "within noise (same sign as the paper)",
        Verdict::Unresolved { sign_agrees: false } => "within noise (opposite sign)",
        Verdict::PaperTie => "paper tie",
    }
}

/// The standard error of the mean of `v` (`None` below two values).
pub fn se_of(v: &[f32]) -> Option<f32> {
    let n = v.len();
    (n >= 2).then(|| {
        let m = v.iter().sum::<f32>() / n as f32;
        let var = v.iter().map(|x| (x - m).powi(2)).sum::<f32>() / (n - 1) as f32;
        (var / n as f32).sqrt()
    })
}
