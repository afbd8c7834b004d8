//! The paper's six ShapeNet categories and their synset ids.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

/// A ShapeNet category used by the paper (and by NMR/SoftRas/DVR's 13-class data).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Category {
    Airplane,
    Bench,
    Car,
    Chair,
    Table,
    Watercraft,
}

impl Category {
    /// All six, in the paper's table order.
    pub const ALL: [Category; 6] = [
        Category::Airplane,
        Category::Bench,
        Category::Car,
        Category::Chair,
        Category::Table,
        Category::Watercraft,
    ];

    /// ShapeNet synset id, the file prefix of Kato's npz files.
    pub fn synset(self) -> &'static str {
        match self {
            Category::Airplane => "02691156",
            Category::Bench => "02828884",
            Category::Car => "02958343",
            Category::Chair => "03001627",
            Category::Table => "04379243",
            Category::Watercraft => "04530566",
        }
    }

    /// Lower-case English name.
    pub fn name(self) -> &'static str {
        match self {
            Category::Airplane => "airplane",
            Category::Bench => "bench",
            Category::Car => "car",
            Category::Chair => "chair",
            Category::Table => "table",
            Category::Watercraft => "watercraft",
        }
    }

    /// Looks a category up by synset id.
    pub fn from_synset(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|c| c.synset() == s)
    }
}

impl fmt::Display for Category {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Category {
    type Err = String;

    /// Accepts a name (`chair`) or a synset id (`03001627`).
    fn from_str(s: &str) -> Result<Self, String> {
        let t = s.trim().to_ascii_lowercase();
        Self::ALL
            .into_iter()
            .find(|c| c.name() == t || c.synset() == t)
            .ok_or_else(|| {
                let names: Vec<_> = Self::ALL.iter().map(|c| c.name()).collect();
                format!(
                    "unknown category '{s}': expected one of {} or their synset ids",
                    names.join(", ")
                )
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_and_synsets_round_trip() {
        for c in Category::ALL {
            assert_eq!(c.name().parse::<Category>().unwrap(), c);
            assert_eq!(c.synset().parse::<Category>().unwrap(), c);
            assert_eq!(Category::from_synset(c.synset()), Some(c));
        }
        assert_eq!("03001627".parse::<Category>().unwrap(), Category::Chair);
        let e = "chiar".parse::<Category>().unwrap_err();
        assert!(e.contains("chiar") && e.contains("chair"));
    }
}
